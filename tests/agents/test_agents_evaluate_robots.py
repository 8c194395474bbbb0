"""``wheelgym evaluate`` on a short run of every robot (issue 14, item 18).

Each robot is trained for a few hundred steps from its own goal config (budget, batch and
episode length cut down), then scored by the documented command. Kinematic robots have no
motors: their input plot shows the commanded inputs and the table leaves out the motor columns;
on ``goal`` the RMS tracking error (a distance to the goal) is left out too.
"""

from __future__ import annotations

import csv
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest
import yaml

pytest.importorskip("stable_baselines3")

from wheelgym.agents.config import configs_dir, parse_config  # noqa: E402
from wheelgym.agents.evaluate import (  # noqa: E402
    applicable_metrics,
    input_channels,
    run_episode,
)
from wheelgym.agents.train import train  # noqa: E402
from wheelgym.cli import main  # noqa: E402

DYNAMIC = ("ThreeWheel", "SkidSteer", "CasterAGV")
KINEMATIC = ("DiffDrive", "Unicycle", "Bicycle", "Ackermann")


def _short_config(robot: str, task: str = "goal"):
    path = sorted(configs_dir().glob(f"{robot}-{task}-*.yml"))[0]
    data = yaml.safe_load(path.read_text())
    env_id = f"wheelgym/{robot}-v0"
    data[env_id].update(n_envs=2, n_timesteps=128, n_steps=64, batch_size=64, n_epochs=1,
                        policy_kwargs={"net_arch": [16]})
    data["wheelgym"].update(vec_env="dummy", eval_freq=0, checkpoint_freq=0)
    stages = [s for s in data["wheelgym"].pop("pipeline", None) or [] if s["stage"] == "rl"]
    if stages:  # the imitate stages need the native vector env; not tested here
        data["wheelgym"]["pipeline"] = stages
    data["wheelgym"]["env_kwargs"]["max_episode_steps"] = 25
    return parse_config(data, source=str(path))


@pytest.mark.parametrize(("robot", "task"), [*((r, "goal") for r in DYNAMIC + KINEMATIC),
                                             ("Bicycle", "track")])
def test_evaluate_every_robot(robot, task, tmp_path, capsys):
    cfg = _short_config(robot, task)
    run = train(cfg, run_dir=tmp_path / "run", progress=False).run_dir
    out = tmp_path / "ev"
    assert main(["evaluate", str(run), "--episodes", "1", "--out", str(out)]) == 0, \
        capsys.readouterr().err
    plot = "torques.png" if robot in DYNAMIC else "inputs.png"
    assert (out / plot).read_bytes()[:4] == b"\x89PNG"
    assert not (out / ("inputs.png" if robot in DYNAMIC else "torques.png")).exists()
    table = (out / "results.md").read_text()
    assert "| agent (PPO) |" in table and "| baseline |" in table and "| random |" in table
    assert ("RMS tracking error" in table) == (task == "track")
    assert ("energy [J]" in table) == (robot in DYNAMIC)
    assert ("peak torque" in table) == (robot in DYNAMIC)
    assert ("internal force" in table) == (robot == "ThreeWheel")
    assert "saturation" in table and "nan" not in table.lower()
    with (out / "results.csv").open() as f:
        header = next(csv.reader(f))
    assert ("energy_mean" in header) == (robot in DYNAMIC)
    assert ("rms_tracking_error_mean" in header) == (task == "track")


@pytest.mark.parametrize(("robot", "mode", "kind", "names"), [
    ("ThreeWheel", "torque", "torque",
     ("drive_1", "drive_2", "drive_3", "steer_1", "steer_2", "steer_3")),
    ("SkidSteer", "velocity", "torque", ("rear_left", "front_left", "front_right", "rear_right")),
    ("CasterAGV", "torque", "torque", ("drive_L", "drive_R")),
    ("Bicycle", "VehicleSpeedHeadingRate", "input", ("v", "w")),
    ("Ackermann", "VehicleSpeedSteeringRate", "input", ("v", "psidot")),
    ("DiffDrive", "WheelSpeeds", "input", ("phidot_L", "phidot_R")),
])
def test_input_channels_are_named(robot, mode, kind, names):
    import wheelgym  # noqa: F401

    env = gym.make(f"wheelgym/{robot}-v0", action_mode=mode)
    try:
        got_kind, got_names, units = input_channels(env)
        assert (got_kind, got_names) == (kind, names)
        assert len(units) == len(names) and "-" not in units
        metrics = applicable_metrics(env)
        assert "rms_tracking_error" not in metrics and "success" in metrics
    finally:
        env.close()


def test_configs_dir_has_every_robot():
    names = {Path(p).name.split("-")[0] for p in configs_dir().glob("*.yml")}
    assert set(DYNAMIC + KINEMATIC) <= names


class _Alternating:
    """A policy whose first action component is ``hi`` on even steps and 0 on odd ones."""

    def __init__(self, space: gym.spaces.Box, hi: float) -> None:
        self.n = 0
        self.hi = hi
        self.shape = space.shape

    def predict(self, obs, state=None, episode_start=None, deterministic=True):
        a = np.zeros(self.shape)
        a[0] = self.hi if self.n % 2 == 0 else 0.0
        self.n += 1
        return a, state


@pytest.mark.parametrize(("env_id", "kwargs"), [
    ("wheelgym/Unicycle-v0", {"action_mode": "VehicleSpeedHeadingRate"}),
    ("wheelgym/SkidSteer-v0", {"action_mode": "torque"}),
])
@pytest.mark.parametrize("hi", [1.0, -1.0, 0.999])
def test_saturation_counts_actions_at_their_bound(env_id, kwargs, hi):
    """SB3's predict clips to the action box, so the env never sees an action beyond it; an
    action at its bound (full torque, full speed) is saturated all the same: every other step
    here, and none when the action stays inside."""
    env = gym.make(env_id, task="goal", max_episode_steps=31, **kwargs)
    ep = run_episode(env, _Alternating(env.action_space, hi), seed=3, record=False)
    env.close()
    assert ep.length == 31  # no early end: 16 of the 31 steps hold the bound
    assert ep.saturation == pytest.approx(16 / 31 if abs(hi) == 1.0 else 0.0, abs=1e-12)


def test_an_episode_keeps_its_rewards_and_how_it_ended():
    """The recorded rewards add up to the return; a time limit is not a termination, and the
    baseline's goal episode ends by the task (success)."""
    from wheelgym.agents.policies import make_baseline

    env = gym.make("wheelgym/Unicycle-v0", task="goal", max_episode_steps=31,
                   action_mode="VehicleSpeedHeadingRate")
    ep = run_episode(env, _Alternating(env.action_space, 0.5), seed=3)
    assert ep.length == 31 and not ep.terminated and ep.rewards.shape == (31,)
    assert ep.ret == pytest.approx(float(np.sum(ep.rewards)), rel=1e-12, abs=1e-12)
    assert run_episode(env, _Alternating(env.action_space, 0.5), seed=3,
                       record=False).rewards is None
    env.close()
    env = gym.make("wheelgym/Unicycle-v0", task="goal", action_mode="VehicleSpeedHeadingRate")
    ep = run_episode(env, make_baseline(env), seed=3)
    env.close()
    assert ep.success and ep.terminated and len(ep.rewards) == ep.length
    assert ep.ret == pytest.approx(float(np.sum(ep.rewards)), rel=1e-12, abs=1e-12)
