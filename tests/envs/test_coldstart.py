"""A fresh process on an empty numba cache compiles only the kernels its env uses, says so on
screen when the compile is long, and a second process on the same cache compiles nothing
(``benchmarks/coldstart.py``, which these tests drive on a copy of the working tree)."""

from __future__ import annotations

import importlib.util
from pathlib import Path

import pytest

_PATH = Path(__file__).resolve().parents[2] / "benchmarks" / "coldstart.py"
_spec = importlib.util.spec_from_file_location("coldstart_bench", _PATH)
coldstart = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(coldstart)

OTHER_ROBOTS = ("three_wheel", "skid_steer", "caster_agv", "kinematic")


def _compiled(row: dict) -> list[str]:
    return [name for name, _s, _depth in row["kernels"]]


def _assert_only_own(names: list[str], robot_module: str) -> None:
    """No kernel of another robot, no threaded, block or DC kernel, no single-state model
    kernel (``k_step1`` / ``k_deriv1``: the env never calls them)."""
    for name in names:
        for other in OTHER_ROBOTS:
            assert f".{other}." not in name or other == robot_module, name
        leaf = name.rsplit(".", 1)[1]
        assert not leaf.endswith(("_par", "_dc")), name
        assert leaf not in ("k_block", "k_env_blocks", "k_env_block", "k_step1", "k_deriv1",
                            "deriv_one_dc"), name


def test_quick_coldstart_compiles_only_the_env_kernels():
    """The quick path of the benchmark on one cheap robot (DiffDrive, goal)."""
    (kw,) = coldstart.combinations(["DiffDrive"], ("goal",), quick=True)
    row = coldstart.measure(kw, rev=None)
    names = _compiled(row)
    assert "wheelgym.envs.robots.kinematic.k_env_step" in names
    assert "wheelgym.tasks.kernels.k_goal" in names
    _assert_only_own(names, "kinematic")
    assert row["notice"] == ["wheelgym: compiling the kinematic robots' kernels (first use only, "
                             "~6 s)"]
    assert row["warm_compiled"] == 0  # the second process loads everything from the cache
    assert not row["warm_notice"]
    table = coldstart.table([row])
    assert "DiffDrive" in table and "**total** (1)" in table


@pytest.mark.slow
def test_threewheel_velocity_coldstart():
    """ThreeWheel, goal, velocity (the costliest single env): its row kernel and its
    controller, no block, threaded or DC kernel, no other robot's; one notice, none warm."""
    row = coldstart.measure({"id": "wheelgym/ThreeWheel-v0", "task": "goal",
                             "action_mode": "velocity"}, rev=None)
    names = _compiled(row)
    assert "wheelgym.envs.robots.three_wheel.k_env_step" in names
    assert "wheelgym.control.controllers._k_tw_twist" in names
    _assert_only_own(names, "three_wheel")
    assert not any("controllers._k_ss" in n or "controllers._k_ca" in n for n in names)
    assert len(row["notice"]) == 1 and "ThreeWheel" in row["notice"][0]
    assert row["warm_compiled"] == 0 and not row["warm_notice"]
