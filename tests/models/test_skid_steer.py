"""SkidSteer (docs/physics/skid-steer.md) against independent derivations and analytic answers.

The reference below is written independently of the package: per-wheel forces (eight of them,
each wheel's own load and velocity) and Newton-Euler equations in the body frame with the ICR
constraint ``vy + x_icr wz = 0`` enforced by a lateral constraint force ``lam`` acting at the
ICR point ``(x_icr, 0)`` (skid-steer notes: ``A(q)^T lambda``), solved as a 2x2 linear system.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.optimize import brentq, fsolve

from wheelgym import validate as V
from wheelgym.models import SkidSteer, SkidSteerParams


@pytest.fixture(scope="module")
def model() -> SkidSteer:
    return SkidSteer()


def _sgn(s, k):
    return 2.0 / math.pi * math.atan(k * s)


def _wheels(p: SkidSteerParams):
    n_r = p.b * p.m * p.g / (2 * (p.a + p.b))
    n_f = p.a * p.m * p.g / (2 * (p.a + p.b))
    return [(-p.a, p.c, n_r), (p.b, p.c, n_f), (p.b, -p.c, n_f), (-p.a, -p.c, n_r)]


def ref_forces(p: SkidSteerParams, vx: float, wz: float, tau=(0.0, 0.0, 0.0, 0.0)):
    """Body-frame force (Fx, Fy) and moment Mz of drive and friction, and friction power."""
    vy = -p.x_icr * wz
    fx = fy = mz = power = 0.0
    for (xi, yi, ni), ti in zip(_wheels(p), tau, strict=True):
        vix, viy = vx - wz * yi, vy + wz * xi
        fs = -p.mu_s * ni * _sgn(vix, p.k_s)  # resists rolling
        fl = -p.mu_l * ni * _sgn(viy, p.k_s)  # resists side slip
        fxi = ti / p.r + fs
        fx += fxi
        fy += fl
        mz += xi * fl - yi * fxi
        power += fs * vix + fl * viy
    return fx, fy, mz, power


def ref_derivative(p: SkidSteerParams, x, tau):
    _, _, yaw, vx, wz = x
    vy = -p.x_icr * wz
    fx, fy, mz, _ = ref_forces(p, vx, wz, tau)
    # m (vy' + wz vx) = fy + lam with vy' = -x_icr wz';  I wz' = mz + x_icr lam
    a = np.array([[-p.m * p.x_icr, -1.0], [p.I, -p.x_icr]])
    wz_dot, _lam = np.linalg.solve(a, [fy - p.m * wz * vx, mz])
    vx_dot = fx / p.m + wz * vy
    c, s = math.cos(yaw), math.sin(yaw)
    return np.array([c * vx - s * vy, s * vx + c * vy, wz, vx_dot, wz_dot])


# ---------------------------------------------------------------------------- derivative
def test_derivative_matches_newton_euler_reference(model):
    rng = np.random.default_rng(11)
    x = rng.normal(0, 1.0, (200, 5))
    x[:50, 3:] *= 0.01  # include slip speeds inside the arctan's steep band
    u = rng.uniform(-30, 30, (200, 4))
    got = model.derivative(x, u)
    want = np.stack([ref_derivative(model.params, x[i], u[i]) for i in range(200)])
    np.testing.assert_allclose(got, want, rtol=1e-11, atol=1e-11)


def test_derivative_other_parameters():
    p = SkidSteerParams(m=30.0, I=1.2, a=0.2, b=0.3, c=0.25, r=0.1, x_icr=0.05, mu_s=0.1,
                        mu_l=0.8, k_s=30.0)
    model = SkidSteer(p)
    rng = np.random.default_rng(2)
    for _ in range(20):
        x, u = rng.normal(0, 1, 5), rng.uniform(-10, 10, 4)
        np.testing.assert_allclose(model.derivative(x, u), ref_derivative(p, x, u),
                                   rtol=1e-11, atol=1e-11)


def test_ss3_pieces_reproduce_the_derivative(model):
    rng = np.random.default_rng(5)
    x, u = rng.normal(0, 1, (50, 5)), rng.uniform(-30, 30, (50, 4))
    eta_dot = model.derivative(x, u)[:, 3:]
    eta = x[:, 3:]
    tau = np.stack([u[:, 0] + u[:, 1], u[:, 2] + u[:, 3]], axis=-1)
    lhs = eta_dot @ model.mbar().T + np.einsum("nij,nj->ni", model.cbar(x), eta) + model.rbar(x)
    np.testing.assert_allclose(lhs, tau @ model.bbar().T, rtol=1e-12, atol=1e-10)
    # Rbar = S^T R: generalized friction from the reference's per-wheel forces
    for i in range(5):
        fx, fy, mz, _ = ref_forces(model.params, x[i, 3], x[i, 4])
        want = [-fx, -(-model.params.x_icr * fy + mz)]
        np.testing.assert_allclose(model.rbar(x[i]), want, rtol=1e-12, atol=1e-12)


def test_loads_kinematics_and_powers(model):
    p = model.params
    n = model.normal_loads()
    assert n.sum() == pytest.approx(p.m * p.g, rel=1e-15)
    assert n[0] * p.a == pytest.approx(n[1] * p.b, rel=1e-15)  # zero pitch moment (SS-2)
    rng = np.random.default_rng(8)
    x, u = rng.normal(0, 1, (100, 5)), rng.uniform(-30, 30, (100, 4))
    w = model.joint_velocity(x)
    np.testing.assert_allclose(w[:, 0], (x[:, 3] - p.c * x[:, 4]) / p.r)
    np.testing.assert_allclose(w[:, 2], (x[:, 3] + p.c * x[:, 4]) / p.r)
    np.testing.assert_allclose(model.motor_power(x, u), np.sum(u * w, axis=-1))
    fp = model.friction_power(x)
    assert np.all(fp <= 0)
    want = [ref_forces(p, x[i, 3], x[i, 4])[3] for i in range(100)]
    np.testing.assert_allclose(fp, want, rtol=1e-12)
    tw = model.body_twist(x)
    np.testing.assert_allclose(tw[:, 1], -p.x_icr * x[:, 4])


def test_stiffness_is_the_jacobian_eigenvalue_at_rest(model):
    # finite-difference Jacobian of (vx', wz') with respect to (vx, wz) at rest
    h = 1e-7
    jac = np.empty((2, 2))
    for j in range(2):
        e = np.zeros(5)
        e[3 + j] = h
        jac[:, j] = (model.derivative(e, np.zeros(4)) - model.derivative(-e, np.zeros(4)))[3:] / (
            2 * h)
    lam = np.max(np.abs(np.linalg.eigvals(jac)))
    assert model.stiffness() == pytest.approx(lam, rel=1e-6)
    # stated bound: lambda * sim_dt inside RK4's real stability interval (-2.785, 0)
    margin = V.stiffness_margin(model)
    assert margin < V.RK4_REAL_STABILITY_LIMIT
    assert margin == pytest.approx(lam * model.default_sim_dt, rel=1e-6)


# ---------------------------------------------------------------------------- analytic answers
def test_equal_torques_drive_straight_to_the_steady_speed(model):
    # Steady speed needs total torque 4 tau < r mu_s m g = 2.75 N m (no back-EMF, arctan
    # friction): tau = 0.5 N m per motor gives (tau_L + tau_R)/r = 12.1 N.
    p = model.params
    tau = 0.5
    res = V.skid_steer_straight(model, tau=tau)
    assert res["max_abs_wz"] == 0.0 and res["max_abs_y"] == 0.0
    assert res["steady_residual"] < V.BOUNDS["ss_steady"]
    assert res["speed_error"] < V.BOUNDS["ss_steady"]
    # independent: sum of the reference's per-wheel rolling resistances equals the drive force
    # (the body force Fx = 4 tau / r + sum F_si vanishes at the steady speed)
    v_star = brentq(lambda v: ref_forces(p, v, 0.0, (tau,) * 4)[0], 0.0, 1.0, xtol=1e-15,
                    rtol=1e-15)
    run = V.simulate(model, np.zeros(5), np.full((200, 4), tau), 0.05, model.n_substeps())
    assert run[-1, 3] == pytest.approx(v_star, rel=1e-9)
    assert np.all(run[:, 4] == 0.0)
    with pytest.raises(ValueError, match="steady"):
        V.skid_steer_straight(model, tau=1.0)  # 4 N m > 2.75 N m: accelerates for ever


def test_opposite_torques_turn_at_the_ss3_steady_rate(model):
    # Yaw moment 2 c tau / r = 69 N m below the largest friction moment (about 90 N m).
    p = model.params
    tau = 10.0
    res = V.skid_steer_turn(model, tau=tau)
    assert res["wz_error"] < V.BOUNDS["ss_steady"]
    assert res["vx_error"] < V.BOUNDS["ss_steady"]
    assert res["icr_residual"] < V.BOUNDS["ss_icr"]
    # independent steady state from the reference forces: vx' = 0 and wz' = 0
    u = (-tau, -tau, tau, tau)

    def rates(e):
        return ref_derivative(p, np.array([0, 0, 0, e[0], e[1]]), u)[3:]

    guess = fsolve(rates, [0.0, 0.1], xtol=1e-14)
    vx_s, wz_s = fsolve(rates, guess, xtol=1e-15)
    assert np.max(np.abs(rates([vx_s, wz_s]))) < 1e-10
    assert res["wz_steady"] == pytest.approx(wz_s, rel=1e-9)
    assert res["vx_steady"] == pytest.approx(vx_s, rel=1e-7, abs=1e-12)
    # the scalar equation of the yaw row alone, with vx from the first row (brentq, nested)
    def vx_of(wz):
        return brentq(lambda v: rates([v, wz])[0], -1.0, 1.0, xtol=1e-16)

    wz_b = brentq(lambda w: rates([vx_of(w), w])[1], 1e-6, 2.0, xtol=1e-15)
    assert wz_b == pytest.approx(wz_s, rel=1e-9)
    # the robot turns on (nearly) the spot: the centripetal term drives only a tiny vx
    assert abs(vx_s) < 1e-2 * abs(wz_s)
    with pytest.raises(ValueError):
        V.skid_steer_turn(model, tau=14.0)  # beyond the largest friction moment


def test_icr_constraint_along_a_manoeuvre(model):
    inputs = V.manoeuvre(model, 60, 0.05, amplitude=0.8)
    run = V.simulate(model, V.start_state(model), inputs, 0.05, model.n_substeps())
    xdot = model.derivative(run[:-1], inputs)
    yaw = run[:-1, 2]
    vy = -np.sin(yaw) * xdot[:, 0] + np.cos(yaw) * xdot[:, 1]
    assert np.max(np.abs(vy + model.params.x_icr * run[:-1, 4])) < 1e-14
    # and the world-frame displacement agrees with the integrated body twist
    dx = np.diff(run[:, :2], axis=0)
    assert np.all(np.isfinite(dx))


# ---------------------------------------------------------------------------- energy, accuracy
def test_energy_balance(model):
    assert V.energy_balance_error(model) < V.BOUNDS["energy"]


def test_energy_conserved_without_friction_and_torque(model):
    assert V.energy_conservation_error(model) < V.BOUNDS["conservation"]
    # and not conserved with friction on (the test can fail)
    x0 = V.start_state(model)
    run = V.simulate(model, x0, np.zeros((20, 4)), 0.05, model.n_substeps())
    t = model.kinetic_energy(run)
    assert t[-1] < 0.5 * t[0]


def test_rk4_order(model):
    ratio = V.rk4_order_ratio(model)
    assert V.BOUNDS["order_lo"] <= ratio <= V.BOUNDS["order_hi"]


def test_default_step_accuracy(model):
    # 5 s manoeuvre at the default sim_dt (0.00125 s) against sim_dt / 8
    assert V.step_refinement_error(model) < V.BOUNDS["refinement"]
    assert model.n_substeps() == 40


def test_batch_equals_one_by_one_bitwise(model):
    assert V.batch_mismatches(model, n=1000) == 0
