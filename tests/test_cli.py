"""The ``wheelgym`` command: dispatch, argument errors, train -> evaluate through the CLI."""

from __future__ import annotations

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
