"""The ``wheelgym`` command: dispatch, argument errors, train -> evaluate through the CLI."""

from __future__ import annotations

import subprocess
import sys
import types

import pytest
import yaml

from wheelgym.cli import main

ENV_ID = "wheelgym/ThreeWheel-v0"


def _config(tmp_path, **block):
    data = {
        ENV_ID: {"policy": "MlpPolicy", "n_envs": 2, "n_timesteps": 512, "normalize": True,
                 "n_steps": 128, "batch_size": 128, "n_epochs": 1,
                 "policy_kwargs": {"net_arch": [16]}, **block},
        "wheelgym": {"algo": "ppo", "env_kwargs": {"task": "goal", "action_mode": "velocity"},
                     "vec_env": "native"},
    }
    p = tmp_path / "c.yml"
    p.write_text(yaml.safe_dump(data))
    return p


def test_help_lists_commands(capsys):
    with pytest.raises(SystemExit) as e:
        main(["--help"])
    assert e.value.code == 0
    out = capsys.readouterr().out
    for cmd in ("main", "train", "evaluate", "benchmark", "demo", "validate"):
        assert cmd in out


def test_argument_errors_exit_2(capsys, tmp_path):
    assert main(["train"]) == 2
    assert "CONFIG" in capsys.readouterr().err
    assert main(["train", str(tmp_path / "missing.yml")]) == 2
    assert "not found" in capsys.readouterr().err
    with pytest.raises(SystemExit) as e:
        main(["train", "x.yml", "--total-timesteps", "-5"])
    assert e.value.code == 2
    assert main(["evaluate", str(tmp_path)]) == 2
    assert "not a run folder" in capsys.readouterr().err
    assert main(["demo", "NoSuchRobot-v0"]) == 2
    assert "valid ids" in capsys.readouterr().err


def test_bad_config_key_named_by_cli(capsys, tmp_path):
    p = _config(tmp_path, n_epoch=3)
    assert main(["train", str(p)]) == 2
    assert "n_epoch" in capsys.readouterr().err


def test_train_then_evaluate(capsys, tmp_path):
    pytest.importorskip("stable_baselines3")
    p = _config(tmp_path)
    run = tmp_path / "run"
    assert main(["train", str(p), "--run-dir", str(run), "--seed", "4", "--no-progress",
                 "--total-timesteps", "256"]) == 0
    assert "finished: 256 steps" in capsys.readouterr().out
    assert yaml.safe_load((run / "config.yml").read_text())["wheelgym"]["seed"] == 4
    assert main(["train", "--resume", str(run), "--total-timesteps", "512", "--no-progress"]) == 0
    assert "finished: 512 steps" in capsys.readouterr().out
    assert main(["evaluate", str(run), "--episodes", "1", "--out", str(tmp_path / "ev")]) == 0
    out = capsys.readouterr().out
    assert "| agent (PPO) |" in out and "| baseline |" in out and "| random |" in out
    assert (tmp_path / "ev" / "results.csv").is_file()


def test_demo_saves_a_gif(capsys, tmp_path):
    out = tmp_path / "demo.gif"
    assert main(["demo", "ThreeWheel-v0", "--task", "goal", "--action-mode", "velocity",
                 "--out", str(out)]) == 0
    assert out.read_bytes()[:3] == b"GIF"
    assert "success True" in capsys.readouterr().out


def test_validate_dispatches(monkeypatch):
    calls = []
    fake = types.ModuleType("wheelgym.validate")
    fake.main = lambda argv: calls.append(argv) or 0
    monkeypatch.setitem(sys.modules, "wheelgym.validate", fake)
    assert main(["validate", "--quick"]) == 0
    assert calls == [["--quick"]]


# --------------------------------------------------------------------------------------------
# every error is one line on stderr with a nonzero status (issue 14, item 14)
# --------------------------------------------------------------------------------------------


def _run_main(argv) -> int:
    try:
        return main(argv)
    except SystemExit as e:  # argparse
        return e.code if isinstance(e.code, int) else 1


def _bad_invocations(tmp_path):
    cfg = str(_config(tmp_path))
    afile = tmp_path / "afile"
    afile.write_text("x")
    bomb = tmp_path / "bomb.yml"
    lines = ["a0: &a0 [1, 2, 3, 4, 5, 6, 7, 8, 9]"]
    lines += [f"a{i}: &a{i} [" + ", ".join([f"*a{i - 1}"] * 9) + "]" for i in range(1, 10)]
    bomb.write_text("\n".join(lines) + "\nwheelgym: {algo: ppo}\n")
    norun = tmp_path / "norun"  # a run folder without a model
    norun.mkdir()
    (norun / "config.yml").write_text(open(cfg).read())
    broken = tmp_path / "broken"  # a run folder with a damaged model
    broken.mkdir()
    (broken / "config.yml").write_text(open(cfg).read())
    (broken / "model.zip").write_text("not a zip")
    gifdir = tmp_path / "dir.gif"  # a folder named like the output file
    gifdir.mkdir()
    return [
        ["train", cfg, "--total-timesteps", "1e400"],
        ["train", cfg, "--total-timesteps", "inf"],
        ["train", cfg, "--total-timesteps", "nan"],
        ["train", cfg, "--total-timesteps", "1.5"],
        ["train", cfg, "--total-timesteps", "0"],
        ["train", cfg, "--seed", "1e400"],
        ["train", cfg, "--seed", "-1"],
        ["train", cfg, "--seed", str(2**40)],
        ["train", cfg, "--verbose", "7"],
        ["train", cfg, "--runs-root", str(afile)],
        ["train", cfg, "--run-dir", str(afile)],
        ["train", cfg, "--run-dir", str(afile / "sub")],
        ["train", str(tmp_path)],
        ["train", str(bomb)],
        ["train", "--resume", str(tmp_path / "missing")],
        ["train", "--resume", str(norun)],
        ["train", "--resume", str(norun), cfg],
        ["train", cfg, "--bogus"],
        ["main", "--config", cfg, "--runs-root", str(afile), "--total-timesteps", "64"],
        ["main", "--config", str(tmp_path / "missing.yml")],
        ["main", "--episodes", "1e400"],
        ["evaluate", str(afile)],
        ["evaluate", str(norun)],
        ["evaluate", str(broken)],
        ["evaluate", str(norun), "--best"],
        ["evaluate", str(norun), "--episodes", "0"],
        ["evaluate", str(norun), "--seed", "1e400"],
        ["benchmark", str(tmp_path / "missing.yml")],
        ["benchmark", cfg, "--out", str(tmp_path)],
        ["benchmark", cfg, "--out", str(afile / "t.md")],
        ["benchmark", cfg, "--runs-root", str(afile), "--budget", "64"],
        ["benchmark", str(bomb)],
        ["demo", "NoSuchRobot-v0"],
        ["demo", "ThreeWheel-v0", "--task", "fly"],
        ["demo", "ThreeWheel-v0", "--action-mode", "warp"],
        ["demo", "ThreeWheel-v0", "--out", str(tmp_path / "no" / "such" / "x.gif")],
        ["demo", "ThreeWheel-v0", "--out", str(gifdir)],
        ["demo", "ThreeWheel-v0", "--out", str(afile)],
        ["demo", "ThreeWheel-v0", "--episodes", "-1"],
        [],
        ["bogus"],
        ["--debug"],
    ]


def test_every_error_is_one_line(capsys, tmp_path):
    pytest.importorskip("stable_baselines3")
    for argv in _bad_invocations(tmp_path):
        capsys.readouterr()
        rc = _run_main(argv)
        cap = capsys.readouterr()
        err = cap.err.strip().splitlines()
        assert rc != 0, (argv, cap.out, cap.err)
        assert len(err) == 1 and err[0].startswith("wheelgym"), (argv, cap.err)
        assert "Traceback" not in cap.err + cap.out, argv
    assert not any((tmp_path / "afile").parent.glob("*/run.lock"))


def test_debug_shows_the_exception(tmp_path):
    with pytest.raises(ValueError, match="not found"):
        main(["--debug", "train", str(tmp_path / "missing.yml")])
    with pytest.raises(ValueError, match="not found"):
        main(["train", str(tmp_path / "missing.yml"), "--debug"])


def test_entry_point_errors_are_one_line(tmp_path):
    """The real command in a fresh process: the two cases of the issue."""
    cfg = _config(tmp_path)
    afile = tmp_path / "afile"
    afile.write_text("x")
    for args in (["train", str(cfg), "--total-timesteps", "1e400"],
                 ["train", str(cfg), "--runs-root", str(afile)]):
        proc = subprocess.run([sys.executable, "-m", "wheelgym.cli", *args],
                              capture_output=True, text=True, timeout=300)
        assert proc.returncode == 2, proc.stderr
        lines = proc.stderr.strip().splitlines()
        assert len(lines) == 1 and "Traceback" not in proc.stderr, proc.stderr
        assert ("1e400" in lines[0]) or ("not a folder" in lines[0]), lines
