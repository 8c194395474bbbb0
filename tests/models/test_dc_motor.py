"""DC motor actuators of the dynamic robots (wheelgym.models.motor) against analytic answers.

Every expected figure below is computed here from the standard DC motor equations
(``V = R_w i + k_e n omega``, joint torque ``eta n k_t i`` motoring), independently of the
package's law:

1. a free wheel (friction off) under full positive command settles where the envelope torque
   equals the load: the no-load joint speed ``V_s / (k_e n)`` without load, the load line
   ``omega = eta K V_s / (R_w b + eta K^2)`` (``K = n k_t``) against viscous joint friction b;
2. the stall torque at zero speed is ``n eta k_t min(V_s / R_w, I_max)``;
3. power balance over a random trajectory: electrical energy = shaft work + copper loss (to
   round-off), and the kinetic energy follows the joint work and friction work;
4. ideal motors give the same bits whatever the motor fields hold, and the figures of the
   model before the motor model existed;
5. at every joint speed the applied torque stays inside ``[tau_lo(omega), tau_hi(omega)]`` and
   equals the command wherever the command lies inside.
"""

from __future__ import annotations

import numpy as np
import pytest

from wheelgym.integrators import rk4
from wheelgym.models import CasterAGV, SkidSteer, ThreeWheel, ThreeWheelParams
from wheelgym.models.kernels import caster_agv as k_agv
from wheelgym.models.kernels import skid_steer as k_ss
from wheelgym.models.kernels import three_wheel as k_tw

MODELS = (ThreeWheel, SkidSteer, CasterAGV)


def _table(model) -> dict[str, np.ndarray]:
    return model.params.motor_table()


def _limit(model) -> np.ndarray:
    """Today's ideal torque limit per motor (N·m)."""
    hi = getattr(model, "input_high", None)  # CasterAGV has none: its tau_max
    return np.full(model.input_dim, model.params.tau_max) if hi is None else np.asarray(hi)


def _hi_lo(model, omega: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Independent envelope: current limits from I_max and from the supply voltage against
    the back-EMF (the voltage limit the hard one), torque eta n k_t i motoring, n k_t i / eta
    driven back."""
    t = _table(model)
    n, eta, kt, R, vs, imax = (t[k] for k in ("gear_ratio", "gear_efficiency", "k_t", "R_w",
                                              "V_s", "I_max"))
    e = kt * n * omega
    i_hi = np.clip(imax, (-vs - e) / R, (vs - e) / R)
    i_lo = np.clip(-imax, (-vs - e) / R, (vs - e) / R)

    def tq(i):
        return n * kt * i * np.where(i * omega >= 0.0, eta, 1.0 / eta)
    return tq(i_lo), tq(i_hi)


# ---------------------------------------------------------------------------- parameters
def test_motor_fields_validated():
    assert ThreeWheelParams().motor == "ideal"
    assert ThreeWheelParams.from_dict({"motor": "dc"}).motor == "dc"
    with pytest.raises(ValueError, match="motor"):
        ThreeWheelParams(motor="servo")
    with pytest.raises(ValueError, match="gear_efficiency"):
        SkidSteer(gear_efficiency=1.2)
    with pytest.raises(ValueError, match="R_w"):
        CasterAGV(R_w=0.0)
    with pytest.raises(ValueError, match="I_max_steer"):
        ThreeWheel(I_max_steer=-1.0)


@pytest.mark.parametrize("cls", MODELS)
def test_default_stall_covers_ideal_limit(cls):
    """The defaults' stall torque is at least today's ideal torque limit tau_max."""
    m = cls()
    assert np.all(m.stall_torque() >= _limit(m))


# ---------------------------------------------------------------------------- 1. free wheel
def test_skidsteer_free_wheel_no_load_speed():
    """Frictionless, all four motors at full command: vx -> r V_s / (k_e n) (12 rad/s,
    1.9812 m/s); the voltage-limited decay rate 4 eta K^2 / (R_w r^2 m) = 27.6 1/s, so 2 s
    converge to round-off."""
    m = SkidSteer(motor="dc", mu_s=0.0, mu_l=0.0)
    p = m.params
    x = m.step(np.zeros(5), np.full(4, p.tau_max), 2.0, 1600)
    assert x[3] == pytest.approx(p.r * p.V_s / (p.k_t * p.gear_ratio), rel=1e-12)
    assert abs(x[4]) < 1e-14
    # the motors then carry no current and draw no power
    assert np.all(np.abs(m.motor_current(x, np.full(4, p.tau_max))) < 1e-9)


def test_caster_free_wheel_no_load_speed():
    """CasterAGV frictionless (``frictionless()``), both motors full: v -> r V_s / (k_e n)
    = 1.8 m/s (decay 2 eta K^2 / (R_w r^2) / m_eff, about 11 1/s: 10 s)."""
    m = CasterAGV(motor="dc").frictionless()
    p = m.params
    x = m.step(np.zeros(9), np.full(2, p.tau_max), 10.0, 5000)
    assert x[3] == pytest.approx(p.r * p.V_s / (p.k_t * p.gear_ratio), rel=1e-10)
    assert abs(x[4]) < 1e-10


def test_three_wheel_load_line():
    """ThreeWheel driving straight (casters trailing) with only the viscous drive-joint
    friction b: each drive wheel settles where eta K (V_s - K omega) / R_w = b omega,
    omega = eta K V_s / (R_w b + eta K^2) = 23.67 rad/s (below the 24 rad/s no-load speed)."""
    m = ThreeWheel(motor="dc", mu_r=0.0, mu_p=0.0, b_steer=0.0)
    p = m.params
    K = p.gear_ratio_drive * p.k_t_drive
    eta = p.gear_efficiency_drive
    omega = eta * K * p.V_s / (p.R_w_drive * p.b_drive + eta * K * K)
    u = np.array([p.tau_drive_max] * 3 + [0.0] * 3)
    x = m.step(np.zeros(12), u, 6.0, 3000)
    np.testing.assert_allclose(m.joint_velocity(x)[:3], omega, rtol=1e-10)
    assert abs(x[4]) < 1e-10 and abs(x[5]) < 1e-10
    # frictionless: the no-load speed itself
    m0 = ThreeWheel(motor="dc").frictionless()
    x = m0.step(np.zeros(12), u, 6.0, 3000)
    np.testing.assert_allclose(m0.joint_velocity(x)[:3], p.V_s / K, rtol=1e-10)


def test_voltage_mode_free_wheel():
    """``motor="dc_voltage"``: full supply voltage on a free wheel gives the same no-load
    speed; at rest the current is min(V / R_w, I_max)."""
    m = SkidSteer(motor="dc_voltage", mu_s=0.0, mu_l=0.0)
    p = m.params
    x = m.step(np.zeros(5), np.full(4, 2.0 * p.V_s), 2.0, 1600)  # clipped to V_s
    assert x[3] == pytest.approx(p.r * p.V_s / (p.k_t * p.gear_ratio), rel=1e-12)
    v = np.array([3.0, -3.0, 24.0, -100.0])
    i = m.motor_current(np.zeros(5), v)
    np.testing.assert_allclose(i, [10.0, -10.0, 20.0, -20.0], rtol=1e-15)


# ---------------------------------------------------------------------------- 2. stall
@pytest.mark.parametrize("cls", MODELS)
@pytest.mark.parametrize("R_scale", [1.0, 5.0])
def test_stall_torque(cls, R_scale):
    """At zero joint speed the largest torque is n eta k_t min(V_s / R_w, I_max) (both signs);
    with R_w x5 the supply voltage, not I_max, sets it."""
    base = cls()
    names = [k for k in base.params.field_names() if k.startswith("R_w")]
    m = cls(motor="dc", **{k: getattr(base.params, k) * R_scale for k in names})
    t = _table(m)
    stall = t["gear_ratio"] * t["gear_efficiency"] * t["k_t"] * np.minimum(
        t["V_s"] / t["R_w"], t["I_max"])
    x = np.zeros(m.state_dim)
    big = 10.0 * stall
    np.testing.assert_allclose(m.applied_torque(x, big), stall, rtol=1e-14)
    np.testing.assert_allclose(m.applied_torque(x, -big), -stall, rtol=1e-14)
    np.testing.assert_allclose(m.stall_torque(), stall, rtol=1e-15)
    # the derivative sees exactly that torque: the ideal model under the stall torque
    ideal = cls(m.params.replace(motor="ideal"))
    np.testing.assert_allclose(m.derivative(x, big), ideal.derivative(x, stall),
                               rtol=1e-13, atol=1e-13)


# ---------------------------------------------------------------------------- 3. power
def _trajectory(m, seed: int, steps: int = 40):
    """RK4 of the state augmented with the electrical, shaft, copper, joint and friction
    energies (the same stages for all), under random commands up to twice the ideal limit."""
    rng = np.random.default_rng(seed)
    x0 = np.zeros(m.state_dim)
    x0[3] = 0.5

    def f(z, u):
        x = z[:-5]
        return np.concatenate([m.derivative(x, u), [m.electrical_power(x, u),
                               m.shaft_power(x, u), m.copper_loss(x, u), m.motor_power(x, u),
                               m.friction_power(x)]])

    z = np.concatenate([x0, np.zeros(5)])
    hi = _limit(m)
    for _ in range(steps):
        u = rng.uniform(-2.0, 2.0, size=hi.shape) * hi
        if isinstance(m, ThreeWheel):
            u[3:] *= 0.2  # moderate steering
        u[:2 if isinstance(m, CasterAGV) else 3] += 0.5 * hi[0]  # mostly forward
        z = rk4(f, z, u, m.default_ctrl_dt, m.n_substeps())
    return x0, z


@pytest.mark.parametrize("cls", MODELS)
def test_power_balance(cls):
    """Over 2 s of random commands: electrical energy = shaft work + copper loss to
    round-off; gear loss = shaft work - joint work >= 0; kinetic energy change = joint work
    + friction work to RK4 accuracy."""
    m = cls(motor="dc")
    x0, z = _trajectory(m, seed=3)
    e_el, e_sh, e_cu, e_j, e_f = z[-5:]
    scale = abs(e_el) + e_cu
    assert e_cu > 0.0 and scale > 1.0
    assert abs(e_el - (e_sh + e_cu)) <= 1e-13 * scale
    assert e_sh - e_j >= -1e-12 * scale
    # RK4's own error at the default step (fourth order: 4x finer steps cut it ~300x); these
    # random commands reverse wheels under the sharp arctan friction: SkidSteer 6.9e-7
    # relative (its ideal motors 5.4e-8 on the same commands), ThreeWheel 1.2e-8, CasterAGV
    # 6.4e-9
    dke = m.kinetic_energy(z[:-5]) - m.kinetic_energy(x0)
    assert abs(dke - (e_j + e_f)) <= 2e-6 * (abs(e_j) + abs(e_f))


def test_power_pointwise():
    """At random states and commands: V i = R_w i^2 + k_t i n omega per motor, and the
    kernels' stage power (what the environments integrate) is the electrical power for DC
    motors (``power_t_dc``) and tau . qdot for ideal ones (``power_t``)."""
    rng = np.random.default_rng(5)
    for cls, kern in ((ThreeWheel, k_tw), (SkidSteer, k_ss), (CasterAGV, k_agv)):
        for motor in ("ideal", "dc", "dc_voltage"):
            m = cls(motor=motor)
            hi = _limit(m)
            for _ in range(20):
                x = rng.normal(size=m.state_dim)
                x[3:5] *= 3.0
                u = rng.uniform(-2.0, 2.0, size=hi.shape) * (
                    m.params.motor_table()["V_s"] if motor == "dc_voltage" else hi)
                s = m.motor_state(x, u)
                t = _table(m)
                if motor != "ideal":
                    np.testing.assert_allclose(
                        s[3] * s[2], t["R_w"] * s[2] ** 2 + t["k_t"] * s[2] * t["gear_ratio"]
                        * s[0], rtol=1e-12, atol=1e-12)
                k = m.derivative(x, u)
                pw = (kern.power_t if motor == "ideal" else kern.power_t_dc)(x, k, u, m.packed)
                if motor == "ideal":  # the DC stage power falls back to the ideal one
                    assert kern.power_t_dc(x, k, u, m.packed) == pw
                assert pw == pytest.approx(float(m.electrical_power(x, u)), rel=1e-12,
                                           abs=1e-12)


# ---------------------------------------------------------------------------- 4. ideal bits
@pytest.mark.parametrize("cls", MODELS)
def test_ideal_bits_ignore_motor_fields(cls):
    """With ``motor="ideal"`` the motor fields change no bit: derivative, single and batched
    steps, and the block kernels' motor work."""
    a = cls()
    odd = {k: 0.5 * getattr(a.params, k) for k in a.params.field_names()
           if k.startswith(("R_w", "V_s", "I_max", "k_t", "gear_ratio"))}
    b = cls(**odd)
    rng = np.random.default_rng(11)
    X = rng.normal(size=(40, a.state_dim)) * 0.5
    X[:, 3] = np.abs(X[:, 3])
    U = rng.uniform(-1.0, 1.0, size=(40, a.input_dim)) * _limit(a)
    assert np.array_equal(a.derivative(X, U), b.derivative(X, U))
    assert np.array_equal(a.step(X, U, 0.05, 25), b.step(X, U, 0.05, 25))
    assert np.array_equal(a.step(X[0], U[0], 0.05, 25), b.step(X[0], U[0], 0.05, 25))
    assert np.array_equal(a.applied_torque(X, U), U)
    assert np.array_equal(a.motor_power(X, U), b.motor_power(X, U))
    kern = {ThreeWheel: k_tw, SkidSteer: k_ss}.get(cls)
    if kern is not None:
        works = []
        for mdl in (a, b):
            out = np.empty((16, a.state_dim))
            w = np.empty(16)
            kern.k_block(X[:16], U[:16], mdl.packed.reshape(1, -1), 0.002, 25, out, w, 0)
            works.append(w)
        assert np.array_equal(works[0], works[1])


# The model before the motor model existed (x86-64 with FMA): one control step from
# x = (0, 0, 0.1, 0.4, 0.05 | 0.2, 0, ...) under the command of _pinned_case, as float.hex.
PINNED = {
    "ThreeWheel": (
        "0x1.67eca30daceacp-6", "0x1.9d210f260d32ap-9", "0x1.8f7517046c47fp-4",
        "0x1.f2804ef290885p-2", "0x1.e323525c94f3bp-11", "-0x1.2a087c4800848p-4",
        "0x1.cbabf17ac5d8ep-6", "0x1.d3295ced9bbe0p-6", "0x1.7df6a83db2e06p-8",
        "0x1.35be4a4f86a39p-2", "0x1.28396dce11c08p-2", "0x1.2ebd68754adb5p-2",
    ),
    "SkidSteer": (
        "0x1.4d3c5f66f1e95p-6", "0x1.0abb5ddceb395p-9", "0x1.981540b9d49a9p-4",
        "0x1.aba51bc3c469fp-2", "-0x1.d8e36be562ac0p-6",
    ),
    "CasterAGV": (
        "0x1.48a23883ea5fcp-6", "0x1.0b21b5e47220bp-9", "0x1.97c1cbc59bd91p-4",
        "0x1.a02dcebc25587p-2", "-0x1.52e20e98dfa01p-3", "-0x1.32e6805956f89p-7",
        "0x1.14800a39d0d31p-2", "0x1.120af7c9d3d26p-2", "0x1.021a5a8864beep-1",
    ),
}


def _pinned_case(cls):
    x = np.zeros(len(cls.state_names))
    x[2] = 0.1
    x[3] = 0.4
    x[4] = 0.05 if cls is ThreeWheel else 0.2
    m = cls()
    u = np.linspace(0.3, -0.2, m.input_dim) * _limit(m)
    return m, x, u


@pytest.mark.parametrize("cls", MODELS)
def test_ideal_matches_model_before_motors(cls):
    expected = PINNED[cls.__name__]
    if expected is None:
        pytest.skip("no pinned figures")
    m, x, u = _pinned_case(cls)
    got = m.step(x, u, 0.05, m.n_substeps())
    np.testing.assert_allclose(got, [float.fromhex(h) for h in expected], rtol=1e-14,
                               atol=1e-15)


# ---------------------------------------------------------------------------- 5. envelope
@pytest.mark.parametrize("cls", MODELS)
def test_envelope(cls):
    """At random joint speeds (beyond the no-load speed too) and commands up to 3x the stall
    torque, the applied torque lies in [tau_lo(omega), tau_hi(omega)], equals the command
    inside, and reaches the bound the command exceeds; tau_hi falls linearly to zero at the
    no-load speed."""
    m = cls(motor="dc")
    rng = np.random.default_rng(2)
    X = rng.normal(size=(500, m.state_dim))
    X[:, 3:5] *= 2.5
    stall = m.stall_torque()
    U = rng.uniform(-3.0, 3.0, size=(500, m.input_dim)) * stall
    s = m.motor_state(X, U)
    omega, tau = s[:, 0], s[:, 1]
    lo, hi = _hi_lo(m, omega)
    tol = 1e-12 * stall
    assert np.all(tau <= hi + tol) and np.all(tau >= lo - tol)
    inside = (U > lo) & (U < hi)
    assert inside.mean() > 0.15 and (U > hi).mean() > 0.1 and (U < lo).mean() > 0.1
    np.testing.assert_allclose(tau[inside], U[inside], rtol=1e-14)
    np.testing.assert_allclose(tau[U >= hi], hi[U >= hi], rtol=1e-13)
    np.testing.assert_allclose(tau[U <= lo], lo[U <= lo], rtol=1e-13)
    mlo, mhi = m.torque_envelope(omega)
    np.testing.assert_allclose(mhi, hi, rtol=1e-14, atol=1e-14)
    np.testing.assert_allclose(mlo, lo, rtol=1e-14, atol=1e-14)
    # the linear fall: tau_hi(omega_0) = 0 and, in the voltage-limited range,
    # tau_hi = eta n k_t (V_s - k_e n omega) / R_w
    w0 = m.no_load_speed()
    t = _table(m)
    K = t["gear_ratio"] * t["k_t"]
    _, h = _hi_lo(m, w0)
    np.testing.assert_allclose(h, 0.0, atol=1e-12)
    w = 0.95 * w0
    _, h = _hi_lo(m, w)
    np.testing.assert_allclose(h, t["gear_efficiency"] * K * (t["V_s"] - K * w) / t["R_w"],
                               rtol=1e-12)
