"""The env's overspeed limit and the DC motors agree (docs/topics/motors.md): under a full
drive command a robot with ``motor="dc"`` settles below its no-load speed, which lies below
the env's speed limit ``v_max``, so no episode ends on ``overspeed``.

The no-load body speed is computed here from the motor constants alone (``r V_s / (k_e n)``,
``k_e = k_t``), not from the model's own ``no_load_speed``."""

from __future__ import annotations

import numpy as np
import pytest

from tests.envs.conftest import make
from wheelgym.envs.robots import ROBOT_MODULES, get_spec

# ThreeWheel's DC env kernel takes minutes to compile on a fresh checkout (test_motor_env.py):
# its rollout is a slow test (make test-slow); the limit check below is not.
DC_ROBOTS = (pytest.param("ThreeWheel", marks=pytest.mark.slow), "SkidSteer", "CasterAGV")

#: Drive-motor fields per robot: (gear ratio, torque constant).
DRIVE = {"ThreeWheel": ("gear_ratio_drive", "k_t_drive"), "SkidSteer": ("gear_ratio", "k_t"),
         "CasterAGV": ("gear_ratio", "k_t")}


def _no_load_body_speed(params) -> float:
    """``r V_s / (k_e n)`` (m/s): the wheel-rim speed at which the back-EMF equals the supply
    voltage, the fastest a DC-driven wheel turns without being pushed."""
    n_field, k_field = DRIVE[type(params).__name__.removesuffix("Params")]
    return params.r * params.V_s / (getattr(params, k_field) * getattr(params, n_field))


def test_every_dc_robot_is_listed():
    dc = {name for name in ROBOT_MODULES if get_spec(name).has_dc_motors}
    assert dc == set(DRIVE)


@pytest.mark.parametrize("robot", sorted(DRIVE))
def test_no_load_speed_below_the_overspeed_limit(robot):
    spec = get_spec(robot)
    params = spec.model_cls(motor="dc").params
    v0 = _no_load_body_speed(params)
    # at least 10 % of headroom, so the transient and a few % of parameter spread stay inside
    assert 1.1 * v0 <= spec.v_max, (robot, v0, spec.v_max)


@pytest.mark.parametrize("robot", DC_ROBOTS)
def test_full_drive_command_settles_below_the_limit(robot):
    env = make(robot, motor="dc", max_episode_steps=400)
    env.reset(seed=0)
    spec = env.unwrapped.core.spec
    a = np.zeros(env.action_space.shape, dtype=np.float32)
    a[: spec.n_motor - spec.n_steer_motor] = 1.0  # every drive motor full forward
    speeds = []
    for k in range(400):
        _, _, terminated, truncated, info = env.step(a)
        assert info["reward_terms"]["overspeed"] == 0.0, (k, speeds[-3:])
        assert not terminated, (k, info["reward_terms"])
        speeds.append(float(np.hypot(*info["twist"][:2])))
    env.close()
    assert truncated
    v0 = _no_load_body_speed(env.unwrapped.core.base_params)
    settled = speeds[-1]
    assert abs(settled - speeds[-20]) < 1e-6 * v0  # settled: constant over the last second
    assert max(speeds) <= v0 and 0.9 * v0 < settled < spec.v_max
