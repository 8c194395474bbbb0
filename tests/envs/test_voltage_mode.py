"""``action_mode="voltage"``: the DC motors' terminal voltages as the action.

The mode reuses the DC env kernels with the model's ``motor="dc_voltage"`` mode code
(``wheelgym.models.motor``): action ``a_k`` applies ``a_k V_s`` volts to motor k. The figures
checked here come from an independent calculation: the no-load and viscous steady states of
the motor law solved by hand, and a NumPy re-statement of the law driving the ideal-motor
model through the same RK4 stages.
"""

from __future__ import annotations

import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

from tests.envs.conftest import make
from tests.vector.test_vector_env import NEXT, make_pair, rollout_equal
from wheelgym.envs.baseline import baseline, voltage_for_torque
from wheelgym.envs.config import EnvConfig
from wheelgym.envs.core import WheelCore
from wheelgym.envs.robots import get_spec
from wheelgym.integrators import LANES, rk4
from wheelgym.models.motor import MOTOR_DC_VOLTAGE

# ThreeWheel's DC kernels take minutes to compile on a fresh checkout (test_motor_env.py):
# its cases are slow tests (make test-slow)
DC_ROBOTS = (pytest.param("ThreeWheel", marks=pytest.mark.slow), "SkidSteer", "CasterAGV")
#: CasterAGV without friction: the motors drive no load but the inertia
FREE = {"mu_r": 0.0, "mu_p": 0.0, "b_drive": 0.0, "b_caster": 0.0}


def _core(robot: str, num: int = 1, **kw) -> WheelCore:
    core = WheelCore(robot, num=num, task="goal", action_mode="voltage", **kw)
    core.reset(None, [np.random.default_rng(i) for i in range(num)])
    return core


def _run(core: WheelCore, a: float | np.ndarray, steps: int) -> list[float]:
    """Hold the action ``a`` (the core ignores the episode's end); the electrical powers."""
    A = np.broadcast_to(np.asarray(a, dtype=np.float64), core.A.shape).copy()
    pel = []
    for _ in range(steps):
        core.step(A)
        pel.append(float(core.pel[0]))
    return pel


def _voltage_law(v_cmd: np.ndarray, omega: np.ndarray, t: dict[str, np.ndarray]
                 ) -> tuple[np.ndarray, np.ndarray]:
    """Joint torques (N·m) and electrical powers (W) of DC motors at terminal voltages
    ``v_cmd`` and joint speeds ``omega``: models/motor.py's documented law, written out again
    in NumPy (drive voltage limit, then the current limit, then the supply's window; the gear
    loses ``1 - eta`` of the power in the direction it flows)."""
    K = t["gear_ratio"] * t["k_t"]
    R, vs, eta = t["R_w"], t["V_s"], t["gear_efficiency"]
    e = K * omega
    i = (np.clip(v_cmd, -vs, vs) - e) / R
    i = np.clip(i, -t["I_max"], t["I_max"])
    i = np.clip(i, (-vs - e) / R, (vs - e) / R)
    tau = K * i * np.where(i * omega >= 0.0, eta, 1.0 / eta)
    return tau, i * (R * i + e)


# ---------------------------------------------------------------------------- keywords
def test_voltage_mode_implies_dc_motors():
    cfg = EnvConfig("SkidSteer", action_mode="voltage")
    assert cfg.motor == "dc"
    assert cfg == EnvConfig("SkidSteer", action_mode="voltage", motor="dc")
    assert EnvConfig("SkidSteer").motor == "ideal"  # the other modes keep ideal motors
    assert EnvConfig("SkidSteer", action_mode="torque", motor="dc").motor == "dc"
    core = WheelCore(cfg, 2)
    assert core.dc and core.voltage and core.model.params.motor == "dc_voltage"
    from wheelgym.models.kernels.skid_steer import P_MOTOR

    assert np.all(core.P[:, P_MOTOR] == MOTOR_DC_VOLTAGE)  # the DC kernels' voltage law
    np.testing.assert_array_equal(core.HI, np.full((2, 4), 24.0))  # +-1 = +-V_s
    np.testing.assert_array_equal(core.LO, np.full((2, 4), -24.0))
    assert core.action_dim == 4
    env = make("CasterAGV", action_mode="voltage", params={"V_s": 12.0})
    assert env.action_space.shape == (2,)
    np.testing.assert_array_equal(env.unwrapped.core.HI, [[12.0, 12.0]])


def test_invalid_combinations_raise():
    with pytest.raises(ValueError, match=r"action_mode='voltage'.*motor='dc'"):
        make("SkidSteer", action_mode="voltage", motor="ideal")
    with pytest.raises(ValueError, match=r"unknown action_mode 'voltage' for DiffDrive"):
        make("DiffDrive", action_mode="voltage")
    with pytest.raises(ValueError, match=r"valid modes: \['torque', 'velocity', 'voltage'\]"):
        make("CasterAGV", action_mode="current")
    with pytest.raises(ValueError, match=r"motor must be one of.*action_mode='voltage'"):
        make("SkidSteer", motor="dc_voltage")
    with pytest.raises(ValueError, match="motor must be one of"):
        make("SkidSteer", action_mode="voltage", motor="stepper")
    with pytest.raises(ValueError, match="motor= keyword"):
        make("SkidSteer", action_mode="voltage", params={"motor": "dc_voltage"})
    # randomize["motor"] needs DC motors, which the voltage mode implies
    make("SkidSteer", action_mode="voltage", randomize={"motor": 0.1}).close()


def test_randomized_supply_voltage_scales_each_row():
    core = _core("SkidSteer", 3, randomize={"motor": (0.8, 1.2)})
    vs = np.array([p.V_s for p in core.params_rows])
    assert len(set(vs)) == 3
    np.testing.assert_array_equal(core.HI, np.repeat(vs[:, None], 4, axis=1))
    np.testing.assert_array_equal(core.LO, -core.HI)


# ---------------------------------------------------------------------------- physics
def test_no_load_speed_under_full_voltage():
    """No load (no friction, straight line): the joints settle where the back-EMF equals the
    supply voltage, V_s / (k_e n) = 24 / (0.05 * 20) = 24 rad/s (1.8 m/s), drawing no
    current."""
    core = _core("CasterAGV", params=FREE)
    pel = _run(core, 1.0, 100)  # 5 s: the current limit, then ~30 time constants
    w0 = 24.0 / (0.05 * 20.0)
    np.testing.assert_allclose(core.jv[0], [w0, w0], rtol=1e-10)
    np.testing.assert_allclose(core.model.no_load_speed(), [w0, w0], rtol=1e-15)
    assert core.twist[0, 0] == pytest.approx(w0 * 0.075, rel=1e-10)
    assert abs(core.twist[0, 2]) < 1e-12
    assert max(pel[:5]) > 50.0 and abs(pel[-1]) < 1e-6  # W: the current has died out
    # reversed: the mirror image
    core = _core("CasterAGV", params=FREE)
    _run(core, -1.0, 100)
    np.testing.assert_allclose(core.jv[0], [-w0, -w0], rtol=1e-10)


@pytest.mark.parametrize("a", [1.0, 0.5, -0.75])
def test_viscous_steady_state(a):
    """Viscous axle friction b only: ``eta K (V - K w) / R = b w`` gives the joint speed
    ``w = eta K V / (eta K^2 + b R)`` and the supply power ``2 V i``, ``i = (V - K w) / R``."""
    b = 0.05
    core = _core("CasterAGV", params={**FREE, "b_drive": b})
    pel = _run(core, a, 100)
    K, eta, R, V = 20 * 0.05, 0.85, 1.2, 24.0 * a
    w = eta * K * V / (eta * K * K + b * R)
    i = (V - K * w) / R
    np.testing.assert_allclose(core.jv[0], [w, w], rtol=1e-10)
    assert pel[-1] == pytest.approx(2.0 * V * i, rel=1e-9)
    # the supply power is the friction's plus the copper and gear losses
    assert pel[-1] == pytest.approx(2.0 * (b * w * w + R * i * i + (1 - eta) * K * i * w),
                                    rel=1e-9)


@pytest.mark.parametrize("robot", DC_ROBOTS)
def test_matches_ideal_model_with_the_voltage_law_in_every_stage(robot):
    """Second formulation: the ideal-motor model (the joint gets its input torque) with the
    NumPy voltage law evaluated at every RK4 stage, the supply power integrated alongside, gives
    the env's states and energy to round-off: from rest at full voltage (the current limit
    binds), steering with unequal voltages, then braking at a low voltage (regeneration, the
    driven-back gear branch and the negative current limit)."""
    core = _core(robot)
    spec = get_spec(robot)
    ideal = spec.model_cls()
    t = core.base_params.motor_table()
    vs = t["V_s"]
    zero = np.zeros(spec.n_motor)

    def f(z, v):
        x = z[:-1]
        tau, pel = _voltage_law(v, ideal.motor_state(x, zero)[0], t)
        return np.append(ideal.derivative(x, tau), pel.sum())

    a_fast = np.linspace(1.0, 0.6, spec.n_motor)
    if robot == "ThreeWheel":  # drive motors only; the steering motors at 0 V
        a_fast[3:] = 0.0
    a_slow = 0.2 * a_fast
    z = np.append(core.X[0], 0.0)
    limit_seen = regen_seen = False
    for k in range(40):
        a = a_fast if k < 20 else a_slow
        state = core.model.motor_state(core.X[0], a * vs)
        limit_seen |= bool(np.any(np.abs(state[2]) >= t["I_max"] - 1e-12))
        regen_seen |= bool(np.any(state[2] * state[0] < 0.0))
        core.step(a[None])
        z = rk4(f, z, a * vs, core.dt, core.n_sub)
        np.testing.assert_allclose(core.X[0], z[:-1], rtol=1e-9, atol=1e-11)
        assert core.energy[0] == pytest.approx(z[-1], rel=1e-9, abs=1e-9)
    assert limit_seen and regen_seen


@pytest.mark.parametrize("robot", DC_ROBOTS)
def test_voltage_for_torque_gives_the_dc_modes_torque(robot):
    """The baseline's conversion: at the voltage ``voltage_for_torque`` gives, the DC motor
    driven by voltage applies the torque the current-controlled one (``motor="dc"``) applies
    for that torque command, inside the torque-speed envelope."""
    cls = get_spec(robot).model_cls
    m_dc, m_v = cls(motor="dc"), cls(motor="dc_voltage")
    rng = np.random.default_rng(0)
    x = np.zeros((200, m_dc.state_dim))
    x[:, 3:5] = rng.uniform(-1.5, 1.5, (200, 2))  # speeds: joints on both sides of 0
    if robot == "ThreeWheel":
        x[:, 5] = rng.uniform(-2.0, 2.0, 200)
        x[:, 6:9] = rng.uniform(-np.pi, np.pi, (200, 3))
    m = m_dc.input_dim
    omega = m_dc.motor_state(x, np.zeros((200, m)))[:, 0]
    lo, hi = m_dc.torque_envelope(omega)
    tau = lo + rng.uniform(0.02, 0.98, (200, m)) * (hi - lo)
    t = m_dc.params.motor_table()
    v = voltage_for_torque(tau, omega, t["gear_ratio"], t["gear_efficiency"], t["k_t"],
                           t["R_w"])
    assert np.all(np.abs(v) <= t["V_s"])
    want = m_dc.applied_torque(x, tau)
    np.testing.assert_allclose(want, tau, rtol=1e-12, atol=1e-12)  # inside the envelope
    np.testing.assert_allclose(m_v.applied_torque(x, v), want, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(m_v.motor_voltage(x, v), v, rtol=1e-12, atol=1e-12)


def test_electrical_power_and_energy():
    core = _core("SkidSteer")
    pel = _run(core, 1.0, 60)
    assert core.energy[0] == pytest.approx(sum(pel) * core.dt, rel=1e-9)
    x, u = core.X[0], core.U[0]
    np.testing.assert_array_equal(u, np.full(4, 24.0))  # motor_torque: the commanded volts
    mech = float(np.dot(core.model.applied_torque(x, u), core.jv[0]))
    assert 0.0 < mech < pel[-1]  # the copper and gear losses
    env = make("CasterAGV", action_mode="voltage")
    _, info = env.reset(seed=0)
    assert info["electrical_power"] == 0.0
    _, _, _, _, info = env.step(np.ones(2, dtype=np.float32))
    assert info["electrical_power"] > 0.0 and info["energy"] > 0.0
    np.testing.assert_array_equal(info["motor_torque"], [24.0, 24.0])
    env.close()


# ---------------------------------------------------------------------------- gymnasium
@pytest.mark.parametrize("robot", DC_ROBOTS)
def test_check_env_clean(robot):
    env = make(robot, action_mode="voltage")
    check_env(env.unwrapped, skip_render_check=True)
    env.close()


@pytest.mark.parametrize("task", ["goal", "track", "navigate"])
@pytest.mark.parametrize("robot", DC_ROBOTS)
def test_vector_matches_single_env(robot, task):
    vec, ref = make_pair(robot, 3, NEXT, task=task, action_mode="voltage",
                         max_episode_steps=6)
    rollout_equal(vec, ref, 14)


def test_vector_matches_single_env_randomized():
    vec, ref = make_pair("SkidSteer", 3, NEXT, task="goal", action_mode="voltage",
                         randomize={"motor": (0.9, 1.1), "mass": (0.9, 1.1)},
                         actuator_lag=0.1, max_episode_steps=5)
    rollout_equal(vec, ref, 12)


# deepcopy in voltage mode: tests/envs/test_motor_env.py::test_deepcopy_exact


@pytest.mark.slow
@pytest.mark.parametrize("robot", ["ThreeWheel", "SkidSteer"])
def test_vector_matches_single_env_in_blocks(robot):
    """The DC block kernels (LANES rows and more) with the voltage mode code."""
    vec, ref = make_pair(robot, LANES + 3, NEXT, task="goal", action_mode="voltage",
                         max_episode_steps=7)
    rollout_equal(vec, ref, 12, bang=0.3)


# ---------------------------------------------------------------------------- baseline
def _episode(env, pol, seed):
    obs, _ = env.reset(seed=seed)
    errs = []
    for _ in range(500):
        obs, _, te, tr, info = env.step(pol.predict(obs)[0])
        errs.append(info["tracking_error"])
        if te or tr:
            break
    return info["is_success"], te, float(np.sqrt(np.mean(np.square(errs))))


@pytest.mark.parametrize("robot", DC_ROBOTS)
def test_baseline_drives_voltage_mode(robot):
    env = make(robot, task="goal", action_mode="voltage")
    pol = baseline(env)
    assert all(_episode(env, pol, s)[0] for s in range(100, 104))
    env = make(robot, task="track", action_mode="voltage")
    pol = baseline(env)
    runs = [_episode(env, pol, s) for s in range(100, 103)]
    assert not any(te for _, te, _ in runs)
    assert max(rms for _, _, rms in runs) < 0.05


def test_baseline_batch_equals_single_env():
    """The vector env's baseline actions are the single envs' (bit for bit)."""
    vec, ref = make_pair("CasterAGV", 3, NEXT, task="goal", action_mode="voltage",
                         randomize={"motor": 0.1}, max_episode_steps=40)
    pv = baseline(vec)
    singles = [baseline(e) for e in ref.envs]
    vec.reset(seed=4)
    ref.reset(seed=4)
    for _ in range(60):
        a = pv.predict(None)[0]
        b = np.stack([p.predict(None)[0][0] for p in singles])
        np.testing.assert_array_equal(a, b)
        assert np.any(np.abs(a) > 0.0)
        vec.step(a)
        ref.step(b)
