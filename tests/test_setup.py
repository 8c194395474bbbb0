"""The setup takes the CPU build of torch by version alone (README: no package-index URL)."""

from __future__ import annotations

import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def test_makefile_names_no_package_index() -> None:
    text = (ROOT / "Makefile").read_text(encoding="utf-8")
    assert not re.search(r"--(extra-)?index-url|https?://", text)
    assert '"torch==2.13.0"' in text  # the pinned CPU build, installed first


def test_ci_runs_the_readme_test_command() -> None:
    ci = (ROOT / ".ci" / "run").read_text(encoding="utf-8")
    readme = (ROOT / "README.md").read_text(encoding="utf-8")
    assert "make test" in ci and "make test" in readme


def test_ci_runs_the_wheel_smoke_test_after_the_suite() -> None:
    lines = [ln.strip() for ln in (ROOT / ".ci" / "run").read_text(encoding="utf-8").splitlines()]
    assert lines.index("bash .ci/wheel-smoke") > lines.index("make test")
    smoke = (ROOT / ".ci" / "wheel-smoke").read_text(encoding="utf-8")
    assert '"torch==2.13.0"' in smoke  # the CPU build first, before the wheel's extras
    for command in ("wheelgym main --total-timesteps 4096", "wheelgym pretrained list",
                    "wheelgym evaluate --pretrained ThreeWheel-goal-velocity --episodes 2",
                    'gym.make("wheelgym:wheelgym/ThreeWheel-v0")'):
        assert command in smoke, command


def test_make_test_compiles_the_kernels_before_the_suite() -> None:
    lines = [ln.strip() for ln in (ROOT / "Makefile").read_text(encoding="utf-8").splitlines()]
    body = lines[lines.index("test: $(STAMP)") + 1:][:2]
    assert body[0].startswith("$(PY) -m wheelgym.warmup") and "pytest" in body[1]


def test_warmup_jobs_cover_every_kernel_once() -> None:
    import pytest

    from wheelgym.envs.robots import available_robots, get_spec
    from wheelgym.warmup import _combos, warm_jobs, warm_one

    jobs = warm_jobs()
    combos = [(robot, tuple(sorted(kw.items()))) for job in jobs for robot, kw in _combos(job)]
    assert len(set(combos)) == len(combos)  # each combination in one job only
    kinematic = [r for r in available_robots() if get_spec(r).kinematic]
    assert [job for job in jobs if job[1] is None] == [(tuple(kinematic), None)]  # one job
    for robot in available_robots():
        spec = get_spec(robot)
        expect = {(("action_mode", m),) for m in spec.action_modes}
        if spec.n_motor:
            expect |= {(("action_mode", "voltage"),)}
            expect |= {(("action_mode", m), ("motor", "dc")) for m in spec.action_modes}
        assert {c for r, c in combos if r == robot} == expect, robot
    assert set(jobs) - set(warm_jobs(("ThreeWheel",))) == {(("ThreeWheel",), "dc")}
    with pytest.raises(ValueError, match="unknown robots.*valid"):
        warm_jobs(("Tricycle",))
    job, seconds = warm_one((("Unicycle",), None))
    assert job == (("Unicycle",), None) and seconds >= 0.0
