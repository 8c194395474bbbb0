"""Inverse dynamics, computed-torque controllers and closed-loop tracking (TW-6, SS-3/SS-4)."""

import copy

import numpy as np
import pytest

from tests.kernel_signatures import read_only_arrays
from wheelgym.control import (
    TrackingController,
    TwistController,
    inverse_dynamics,
    make_controller,
    min_norm,
    null_space_projector,
    tracked_point,
    within_limits,
)
from wheelgym.integrators import rk4
from wheelgym.kinematics.references import Circle, FigureEight
from wheelgym.models import CasterAGV, SkidSteer, ThreeWheel

TW_SCALED = ("m_b", "I_b", "m_w", "I_wy", "I_wz", "mu_r", "mu_p", "b_drive", "b_steer")
SS_SCALED = ("m", "I", "mu_s", "mu_l")
CA_SCALED = ("m_b", "I_b", "m_w", "I_wy", "I_wz", "m_c", "I_cy", "I_cz", "mu_r", "mu_p",
             "b_drive", "b_caster")
SCALED = {ThreeWheel: TW_SCALED, SkidSteer: SS_SCALED, CasterAGV: CA_SCALED}


def scaled(model_cls, factor):
    """Plant with every mass, inertia and friction parameter scaled by ``factor``."""
    p = model_cls().params
    names = SCALED[model_cls]
    return model_cls(p.replace(**{n: getattr(p, n) * factor for n in names}))


def random_tw_states(rng, n):
    x = np.zeros((n, 12))
    x[:, :3] = rng.normal(size=(n, 3))
    x[:, 3:6] = rng.normal(size=(n, 3)) * [0.4, 0.4, 0.8]
    x[:, 6:9] = rng.uniform(-np.pi, np.pi, (n, 3))
    return x


@pytest.mark.parametrize("mode", ["min_norm", "weighted", "within_limits"])
def test_inverse_dynamics_round_trip_through_forward_model(mode):
    """Torques from Q_d = M udot + c - Q_f make the forward model accelerate at udot."""
    rng = np.random.default_rng(0)
    model = ThreeWheel()
    x = random_tw_states(rng, 64)
    udot = rng.normal(size=(64, 3)) * [0.3, 0.3, 0.6]
    Q, J = inverse_dynamics(model, x, udot)
    np.testing.assert_allclose(J, model.jacobian(x[:, 6:9]), atol=1e-14)
    tmax = model.params.tau_max
    if mode == "min_norm":
        tau = min_norm(J, Q)
        ok = np.ones(64, bool)
    else:
        from wheelgym.control import distribute

        tau, status = distribute(J, Q, mode, tmax)
        ok = status >= 0
    res = np.einsum("nij,ni->nj", J, tau) - Q
    assert np.all(np.linalg.norm(res, axis=1)[ok] <= 1e-12 * np.linalg.norm(Q, axis=1)[ok])
    acc = model.derivative(x, tau)[:, 3:6]
    np.testing.assert_allclose(acc[ok], udot[ok], rtol=0, atol=1e-10)


def test_null_space_torques_change_no_simulated_motion():
    rng = np.random.default_rng(1)
    model = ThreeWheel()
    x0 = random_tw_states(rng, 8)
    Q, J = inverse_dynamics(model, x0, rng.normal(size=(8, 3)) * 0.2)
    tau = min_norm(J, Q)
    eps = rng.normal(size=(8, 6)) * 2.0

    def with_internal(x, u):
        # an internal force along the null space of the current J (recomputed at every stage)
        P = null_space_projector(model.jacobian(x[:, 6:9]))
        return model.derivative(x, u + np.einsum("nij,nj->ni", P, eps))

    internal = np.einsum("nij,nj->ni", null_space_projector(J), eps)
    assert np.abs(internal).max() > 1.0
    xa = model.step(x0, tau, 1.0, 500)
    xb = rk4(with_internal, x0, tau, 1.0, 500)
    assert np.abs(xa - x0).max() > 0.1
    np.testing.assert_allclose(xb, xa, rtol=0, atol=1e-10)


def test_skid_steer_twist_controller_inverts_ss3():
    """With a negligible friction look-ahead the commanded rate is exactly k_v (cmd - eta)."""
    rng = np.random.default_rng(2)
    model = SkidSteer()
    ctl = TwistController(model, gains={"k_v": 5.0}, ctrl_dt=1e-12)
    x = np.zeros((16, 5))
    x[:, 2:] = rng.normal(size=(16, 3)) * [1.0, 0.5, 0.5]
    cmd = rng.normal(size=(16, 2)) * 0.2
    tau, sat = ctl.torques(x, cmd)
    assert not sat.any()
    np.testing.assert_allclose(tau[:, 0], tau[:, 1])  # equal halves (SS-4 min-norm)
    np.testing.assert_allclose(model.derivative(x, tau)[:, 3:5], 5.0 * (cmd - x[:, 3:5]),
                               rtol=0, atol=1e-9)
    loads = TwistController(model, gains={"k_v": 5.0}, ctrl_dt=1e-12, distribution="loads")
    tau_l, _ = loads.torques(x, cmd)
    n = model.normal_loads()
    np.testing.assert_allclose(tau_l[:, 0] / tau_l[:, 1], n[0] / n[1])
    np.testing.assert_allclose(tau_l[:, 0] + tau_l[:, 1], tau[:, 0] + tau[:, 1])


def _reach_time(model, ctl, x0, cmd, idx, horizon=0.4, band=0.02):
    """Time (s) after which the twist stays within ``band`` of the command (substep grid)."""
    x = x0.copy()
    n = model.n_substeps()
    h = model.default_sim_dt
    times, errs = [], []
    for k in range(int(round(horizon / 0.05))):
        tau, _ = ctl.torques(x, cmd)
        for j in range(n):
            x = model.step(x, tau, h, 1)
            times.append((k * n + j + 1) * h)
            errs.append(np.linalg.norm(x[idx] - cmd) / np.linalg.norm(cmd))
    bad = np.nonzero(np.array(errs) > band)[0]
    if len(bad) == 0:
        return times[0]
    return times[bad[-1] + 1] if bad[-1] + 1 < len(times) else np.inf


@pytest.mark.parametrize("cmd", [(0.5, 0.0, 0.0), (0.0, 0.3, 0.0), (0.0, 0.0, 1.0),
                                 (0.3, 0.2, 0.5)])
def test_three_wheel_twist_mode_reaches_command(cmd):
    model = ThreeWheel()
    t = _reach_time(model, TwistController(model), np.zeros(12), np.array(cmd), [3, 4, 5])
    assert t <= 0.2, t  # measured: 0.05-0.15 s to within 2% (0.05-0.12 s to 5%)


@pytest.mark.parametrize("model_cls", [SkidSteer, CasterAGV])
@pytest.mark.parametrize("cmd", [(0.5, 0.0), (1.0, 0.0), (0.0, 1.0), (0.5, 0.5)])
def test_unicycle_twist_mode_reaches_command(model_cls, cmd):
    model = model_cls()
    x0 = np.zeros(model.state_dim)
    t = _reach_time(model, TwistController(model), x0, np.array(cmd), [3, 4])
    assert t <= 0.2, t  # measured 0.05-0.12 s to within 2%


def _start_state(model, ref):
    pose, tw, _ = ref.evaluate(0.0)
    if isinstance(model, ThreeWheel):
        x = np.zeros(12)
        x[:3], x[3:6] = pose, tw
        a = model.params.axes_array  # wheels rolling along their axis' velocity
        x[6:9] = np.arctan2(tw[1] + tw[2] * a[:, 0], tw[0] - tw[2] * a[:, 1])
        return x
    if isinstance(model, CasterAGV):
        x = np.zeros(9)
        x[:3], x[3], x[4] = pose, tw[0], tw[2]
        a = np.asarray(model.params.caster_axis)  # caster rolling along its axis' velocity
        x[5] = np.arctan2(tw[2] * a[0], tw[0] - tw[2] * a[1])
        return x
    xi = model.params.x_icr
    return np.array([pose[0] - xi * np.cos(pose[2]), pose[1] - xi * np.sin(pose[2]), pose[2],
                     tw[0], tw[2]])


def _track(model_cls, ref, factor):
    plant = scaled(model_cls, factor)
    ctl = TrackingController(model_cls())
    x = _start_state(plant, ref)
    n = plant.n_substeps()
    steps = int(round(ref.duration / 0.05))
    t = np.arange(steps + 1) * 0.05
    poses, twists, rates = ref.evaluate(t)
    err = np.empty(steps)
    for k in range(steps):
        tau, _ = ctl.torques(x, poses[k], twists[k], rates[k])
        x = plant.step(x, tau, 0.05, n)
        err[k] = np.hypot(*(tracked_point(plant, x) - poses[k + 1, :2]))
    return float(np.sqrt(np.mean(err**2)))


REFS = {"circle": Circle(radius=1.0, speed=0.5), "figure_eight": FigureEight(1.0, 20.0)}


@pytest.mark.parametrize("model_cls", [ThreeWheel, SkidSteer, CasterAGV])
@pytest.mark.parametrize("ref", sorted(REFS))
def test_closed_loop_tracking(model_cls, ref):
    """RMS position error over one lap: < 1 cm exact, < 5 cm with the plant 20% off."""
    exact = _track(model_cls, REFS[ref], 1.0)
    assert exact < 0.01
    for factor in (1.2, 0.8):
        assert _track(model_cls, REFS[ref], factor) < 0.05


def test_batched_equals_looped_and_broadcasts():
    rng = np.random.default_rng(3)
    model = ThreeWheel()
    ctl = TrackingController(model, distribution="within_limits")
    x = random_tw_states(rng, 6).reshape(2, 3, 12)
    pose, tw, rate = Circle().evaluate(np.linspace(0, 3, 6).reshape(2, 3))
    tau, sat = ctl.torques(x, pose, tw, rate)
    assert tau.shape == (2, 3, 6) and sat.shape == (2, 3)
    for i in range(2):
        for j in range(3):
            t1, s1 = ctl.torques(x[i, j], pose[i, j], tw[i, j], rate[i, j])
            np.testing.assert_array_equal(t1, tau[i, j])
            assert s1 == sat[i, j]
    for mode in ("min_norm", "weighted", "within_limits"):
        tc = TwistController(model, distribution=mode)
        cmd = np.array([0.1, 0.0, 0.2])
        tau_b, sat_b = tc.torques(x, cmd)  # one command for all states
        assert tau_b.shape == (2, 3, 6)
        for i in range(2):
            for j in range(3):
                t1, s1 = tc.torques(x[i, j], cmd)  # single-state fast path
                np.testing.assert_array_equal(t1, tau_b[i, j])
                assert s1 == sat_b[i, j]


def test_saturation_scales_uniformly_and_reports():
    model = ThreeWheel()
    ctl = TwistController(model)
    x = np.zeros(12)
    tau, sat = ctl.torques(x, np.array([3.0, 0.0, 0.0]))  # 60 m/s² asked
    tmax = model.params.tau_max
    assert sat and np.max(np.abs(tau) / tmax) == pytest.approx(1.0)
    Q, J = inverse_dynamics(model, x, 20.0 * np.array([3.0, 0.0, 0.0]), np.array([3.0, 0, 0]))
    g = J.T @ tau
    np.testing.assert_allclose(g / np.linalg.norm(g), Q / np.linalg.norm(Q), atol=1e-12)
    tau_s, sat_s = ctl.torques(x, np.array([0.01, 0.0, 0.0]))
    assert not sat_s and np.all(np.abs(tau_s) < tmax)
    # no solution within the limits: the limit-respecting mode reports it too
    lim = TwistController(model, distribution="within_limits")
    tau_l, sat_l = lim.torques(x, np.array([3.0, 0.0, 0.0]))
    assert sat_l and np.all(np.abs(tau_l) <= tmax * (1 + 1e-12))


def test_within_limits_mode_avoids_saturation_where_possible():
    rng = np.random.default_rng(4)
    model = ThreeWheel()
    x = random_tw_states(rng, 200)
    udot = rng.normal(size=(200, 3)) * [3.0, 3.0, 6.0]
    Q, J = inverse_dynamics(model, x, udot)
    _, status = within_limits(J, Q, model.params.tau_max)
    # the same Q through the controller path (k_v = 1/ctrl_dt, friction at the target twist)
    for mode in ("min_norm", "within_limits"):
        ctl = TwistController(model, distribution=mode)
        cmd = x[:, 3:6] + udot / 20.0
        _, sat = ctl.torques(x, cmd)
        if mode == "within_limits":
            lim_sat = sat
        else:
            mn_sat = sat
    assert lim_sat.sum() < mn_sat.sum()
    assert np.any(status == 1)


def test_predict_follows_trajectory_and_resets():
    model = ThreeWheel()
    ref = Circle()
    ctl = TrackingController(model, trajectory=ref)
    x = _start_state(model, ref)
    a1, state = ctl.predict(x)
    assert state is None
    a2, _ = ctl.predict(x)
    np.testing.assert_array_equal(a1, ctl.torques(x, *ref.evaluate(0.0))[0])
    np.testing.assert_array_equal(a2, ctl.torques(x, *ref.evaluate(0.05))[0])
    ctl.reset()
    np.testing.assert_array_equal(ctl.predict(x)[0], a1)
    a3, _ = ctl.predict(x, episode_start=np.array(True))
    np.testing.assert_array_equal(a3, a1)
    tw = make_controller(SkidSteer(), "twist")
    obs = np.concatenate([np.zeros(5), [0.3, 0.1]])
    np.testing.assert_array_equal(tw.predict(obs)[0], tw.act(np.zeros(5), [0.3, 0.1]))


def test_invalid_arguments():
    with pytest.raises(TypeError, match="model must be"):
        TwistController(object())
    with pytest.raises(ValueError, match="distribution must be one of"):
        TwistController(ThreeWheel(), distribution="loads")
    with pytest.raises(ValueError, match="distribution must be one of"):
        TwistController(SkidSteer(), distribution="weighted")
    with pytest.raises(ValueError, match="distribution must be one of"):
        TwistController(CasterAGV(), distribution="loads")
    with pytest.raises(TypeError, match="unknown TwistGains"):
        TwistController(ThreeWheel(), gains={"kv": 1.0})
    with pytest.raises(ValueError, match="stable sampled loop"):
        TwistController(ThreeWheel(), gains={"k_v": 50.0})
    with pytest.raises(ValueError, match="positive"):
        TrackingController(ThreeWheel(), gains={"k_p": -1.0})
    ctl = TwistController(ThreeWheel())
    with pytest.raises(ValueError, match="twist_cmd must have shape"):
        ctl.torques(np.zeros(12), np.zeros(2))
    with pytest.raises(ValueError, match="finite"):
        ctl.torques(np.full(12, np.nan), np.zeros(3))
    with pytest.raises(ValueError, match="kind must be"):
        make_controller(ThreeWheel(), "pid")
    with pytest.raises(ValueError, match="trajectory"):
        TrackingController(ThreeWheel()).predict(np.zeros(12))


@pytest.mark.parametrize("model_cls", [ThreeWheel, SkidSteer, CasterAGV])
def test_ctrl_dt_argument_and_batch_kernel(model_cls):
    model = model_cls()
    assert TwistController(model).ctrl_dt == model.default_ctrl_dt
    ctl = TwistController(model, ctrl_dt=0.02)
    assert ctl.ctrl_dt == 0.02 and ctl.gains.k_v == 1.0 / 0.02  # deadbeat at that period
    kernel, args = ctl.batch_kernel()
    rng = np.random.default_rng(5)
    X = np.zeros((5, model.state_dim))
    C = rng.normal(size=(5, ctl.command_dim)) * 0.3
    out = np.empty((5, model.input_dim))
    sat = np.empty(5, dtype=np.bool_)
    assert kernel(X, C, *args, out, sat)
    tau, s = ctl.torques(X, C)
    assert np.array_equal(out, tau) and np.array_equal(sat, s)
    twin = copy.deepcopy(ctl)  # the kernel is rebuilt, not copied
    assert np.array_equal(twin.torques(X, C)[0], tau)


def test_ctrl_dt_is_not_a_gain():
    with pytest.raises(TypeError, match="ctrl_dt is not a TwistGains field"):
        TwistController(ThreeWheel(), gains={"k_v": 1.0, "ctrl_dt": 0.05})
    with pytest.raises(ValueError, match="ctrl_dt"):
        TwistController(ThreeWheel(), ctrl_dt=-1.0)
    with pytest.raises(ValueError, match="stable sampled loop"):
        TwistController(ThreeWheel(), gains={"k_v": 20.0}, ctrl_dt=0.1)
    with pytest.raises(ValueError, match="k_w_max < 2 / ctrl_dt"):
        TrackingController(SkidSteer(), ctrl_dt=0.1)  # k_w_max 24 >= 2 / 0.1
    assert TrackingController(SkidSteer(), ctrl_dt=0.02).ctrl_dt == 0.02


@pytest.mark.parametrize("model_cls", [ThreeWheel, SkidSteer])
def test_read_only_inputs_use_the_envs_kernel_signature(model_cls):
    """A read-only state (a broadcast view, a frozen array) is passed to the compiled kernel
    as a writable copy: numba types read-only arrays apart, and would compile the controller
    a second time for them (the environments pass writable arrays)."""
    ctl = TwistController(model_cls())
    kernel = ctl.batch_kernel()[0]
    x = np.zeros(ctl.model.state_dim)
    cmd = np.full(ctl.command_dim, 0.1)
    expected = ctl.torques(x, cmd)
    for xs, cs in ((x, cmd), (np.broadcast_to(x, (3, x.size)), cmd)):
        xs, cs = xs.view(), cs.copy()
        xs.flags.writeable = cs.flags.writeable = False
        tau, _ = ctl.torques(xs, cs)
        np.testing.assert_array_equal(tau.reshape(-1, tau.shape[-1])[0], expected[0])
    ctl.step(np.broadcast_to(x, (2, x.size)), cmd)
    assert kernel.signatures and not read_only_arrays(kernel), kernel.signatures
