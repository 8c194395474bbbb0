"""The env keyword ``motor="dc"``: DC motors inside the env step (wheelgym.models.motor)."""

from __future__ import annotations

import copy

import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

from tests.envs.conftest import make
from tests.vector.conftest import assert_same
from tests.vector.test_vector_env import NEXT, make_pair, rollout_equal
from wheelgym.envs.core import WheelCore
from wheelgym.integrators import LANES

# ThreeWheel's DC env kernel takes ~280 s to compile on a fresh checkout (SkidSteer's DC block
# path ~70 s): those cases are slow tests (make test-slow); the default run keeps the others
DC_ROBOTS = (pytest.param("ThreeWheel", marks=pytest.mark.slow), "SkidSteer", "CasterAGV")


@pytest.mark.parametrize("robot", DC_ROBOTS)
def test_check_env_clean(robot):
    env = make(robot, motor="dc")
    check_env(env.unwrapped, skip_render_check=True)
    env.close()


@pytest.mark.parametrize("robot", DC_ROBOTS)
def test_vector_matches_single_env(robot):
    vec, ref = make_pair(robot, 3, NEXT, task="goal", motor="dc", max_episode_steps=6)
    rollout_equal(vec, ref, 14)


@pytest.mark.slow
@pytest.mark.parametrize("robot", ["ThreeWheel", "SkidSteer"])
def test_vector_matches_single_env_in_blocks(robot):
    """The DC block kernels (LANES rows and more) give the single env's bits."""
    vec, ref = make_pair(robot, LANES + 3, NEXT, task="goal", motor="dc", max_episode_steps=7)
    rollout_equal(vec, ref, 12, bang=0.3)


def test_vector_matches_single_env_randomized():
    vec, ref = make_pair("SkidSteer", 3, NEXT, task="goal", motor="dc",
                         randomize={"motor": (0.9, 1.1), "mass": (0.9, 1.1)},
                         max_episode_steps=5)
    rollout_equal(vec, ref, 12)


def _forward(motor: str, steps: int) -> tuple[WheelCore, list[float], list[dict]]:
    """SkidSteer at full forward torque from rest (the core ignores the episode's end)."""
    core = WheelCore("SkidSteer", num=1, task="goal", motor=motor)
    core.reset(None, [np.random.default_rng(0)])
    vx, infos = [], []
    a = np.ones((1, 4))
    for _ in range(steps):
        core.step(a)
        vx.append(float(core.twist[0, 0]))
        infos.append({"energy": float(core.energy[0]), "pel": float(core.pel[0])})
    return core, vx, infos


def test_dc_speed_saturates_below_no_load_speed():
    core, vx, _ = _forward("dc", 200)
    r = core.base_params.r
    v0 = float(core.model.no_load_speed()[0]) * r  # the body speed at the no-load wheel speed
    assert vx[-1] < v0
    assert abs(vx[-1] - vx[-20]) < 1e-3 * abs(vx[-1])  # settled: the envelope acts
    _, vx_ideal, _ = _forward("ideal", 200)
    assert vx_ideal[-1] > vx[-1] * 1.05  # ideal motors keep the full torque


def test_electrical_power_and_energy():
    core, _, infos = _forward("dc", 200)
    # energy is the sum of the steps' electrical_power * ctrl_dt
    total = sum(i["pel"] for i in infos) * core.dt
    assert infos[-1]["energy"] == pytest.approx(total, rel=1e-9)
    # at the settled speed: electrical power exceeds the mechanical power (copper loss)
    x = core.X[0]
    u = core.U[0]
    mech = float(np.dot(core.model.applied_torque(x, u), core.jv[0]))
    assert mech > 0
    assert infos[-1]["pel"] > mech * 1.01
    assert float(core.model.copper_loss(x, u)) > 0


def test_electrical_power_ideal_is_mean_motor_power():
    core, _, infos = _forward("ideal", 20)
    total = sum(i["pel"] for i in infos) * core.dt
    assert infos[-1]["energy"] == pytest.approx(total, rel=1e-9)


def test_info_key_in_single_and_vector_env():
    env = make("CasterAGV", motor="dc")
    _, info = env.reset(seed=0)
    assert info["electrical_power"] == 0.0
    _, _, _, _, info = env.step(np.ones(2, dtype=np.float32))
    assert info["electrical_power"] > 0.0
    env.close()


def test_randomize_motor_draws_and_changes_motion():
    env = make("SkidSteer", motor="dc", randomize={"motor": (0.9, 1.1)})
    _, info = env.reset(seed=1)
    assert set(info["params"]) == {"k_t", "R_w", "V_s"}
    assert info["params"]["k_t"] != env.unwrapped.core.base_params.k_t
    a = np.ones(4, dtype=np.float32)
    for _ in range(60):
        env.step(a)
    v_rand = float(env.unwrapped.core.twist[0, 0])
    nom = make("SkidSteer", motor="dc")
    nom.reset(seed=1)
    for _ in range(60):
        nom.step(a)
    assert v_rand != float(nom.unwrapped.core.twist[0, 0])


def test_randomize_motor_refused_with_ideal_motors():
    with pytest.raises(ValueError, match="motor='dc'"):
        make("SkidSteer", randomize={"motor": (0.9, 1.1)})


def test_bad_motor_values():
    with pytest.raises(ValueError, match="motor must be one of"):
        make("SkidSteer", motor="stepper")
    with pytest.raises(ValueError, match="no motor model"):
        make("DiffDrive", motor="dc")
    with pytest.raises(ValueError, match="motor= keyword"):
        make("SkidSteer", params={"motor": "dc"})


@pytest.mark.parametrize("robot, kwargs", [("SkidSteer", {"motor": "dc"}),
                                           ("CasterAGV", {"action_mode": "voltage"})])
def test_deepcopy_exact(robot, kwargs):
    env = make(robot, **kwargs)
    env.reset(seed=3)
    n = env.action_space.shape[0]
    rng = np.random.default_rng(0)
    for _ in range(3):
        env.step(rng.uniform(-1, 1, n).astype(np.float32))
    twin = copy.deepcopy(env)
    assert twin.unwrapped.core.dc
    assert twin.unwrapped.core.voltage == (kwargs.get("action_mode") == "voltage")
    for _ in range(30):
        a = rng.uniform(-1, 1, n).astype(np.float32)
        assert_same(env.step(a), twin.step(a), "step")
