"""CasterAGV: an independent full-coordinate Lagrange-multiplier model, energy balance,
caster trailing, batching, parameter checks (docs/physics/caster-robots.md)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from wheelgym.integrators import rk4
from wheelgym.models import CasterAGV, CasterAGVParams


# ---------------------------------------------------------------------------- reference model
class FullCoordinates:
    """Lagrange's equations in q = (x, y, yaw, sigma, theta_L, theta_R, theta_c) with five
    multipliers for the rolling and no-skid constraints of the three wheels.

    Written from scratch in world coordinates: every mass point is ``(x, y) + sum_k l_k
    (cos phi_k, sin phi_k)`` with ``phi_k`` linear in q, so its Jacobian and ``Jdot qdot`` are
    exact. Friction acts on the joints (wheel-spin torques, pivot torques on absolute yaw
    angles), not as the reduced model's generalized forces.
    """

    def __init__(self, p: CasterAGVParams):
        self.p = p
        c = 0.5 * p.track_width
        ax, ay = p.caster_axis
        e = np.eye(7)
        yaw, sig = e[2], e[2] + e[3]
        # (mass, [(length, angle coefficients, angle offset), ...])
        self.points = {
            "G": (p.m_b, [(p.x_G, yaw, 0.0)]),
            "L": (p.m_w, [(c, yaw, math.pi / 2)]),
            "R": (p.m_w, [(c, yaw, -math.pi / 2)]),
            "P": (p.m_c, [(ax, yaw, 0.0), (ay, yaw, math.pi / 2), (p.d, sig, math.pi)]),
        }
        rot = np.zeros((7, 7))
        rot[2, 2] = p.I_b + 2 * p.I_wz + p.I_cz
        rot[2, 3] = rot[3, 2] = rot[3, 3] = p.I_cz
        rot[4, 4] = rot[5, 5] = p.I_wy
        rot[6, 6] = p.I_cy
        self.rot = rot

    def kin(self, name, q, qd):
        """Position, Jacobian (2x7) and Jdot qdot of a point."""
        _, terms = self.points[name]
        pos = np.array([q[0], q[1]])
        jac = np.zeros((2, 7))
        jac[0, 0] = jac[1, 1] = 1.0
        jdqd = np.zeros(2)
        for length, alpha, beta in terms:
            phi = alpha @ q + beta
            rate = alpha @ qd
            pos = pos + length * np.array([math.cos(phi), math.sin(phi)])
            jac += length * np.outer([-math.sin(phi), math.cos(phi)], alpha)
            jdqd -= length * np.array([math.cos(phi), math.sin(phi)]) * rate**2
        return pos, jac, jdqd

    def loads(self, q):
        """Static loads of the L, R and caster contacts: force and moment balance, solved."""
        p = self.p
        pts = [self.kin(k, q, np.zeros(7))[0] for k in ("L", "R", "P")]
        masses = [self.points[k][0] for k in ("G", "L", "R", "P")]
        com = sum(m * self.kin(k, q, np.zeros(7))[0] for m, k in zip(masses, "GLRP", strict=True))
        com /= sum(masses)
        a = np.array([[1.0, 1.0, 1.0], [pts[0][0], pts[1][0], pts[2][0]],
                      [pts[0][1], pts[1][1], pts[2][1]]])
        return np.linalg.solve(a, sum(masses) * p.g * np.array([1.0, com[0], com[1]]))

    def constraints(self, q, qd):
        """Rows A (5x7) and b with A qddot + b = 0."""
        p = self.p
        yaw, phi_c = q[2], q[2] + q[3]
        eb = np.array([math.cos(yaw), math.sin(yaw)])
        nb = np.array([-math.sin(yaw), math.cos(yaw)])
        ec = np.array([math.cos(phi_c), math.sin(phi_c)])
        nc = np.array([-math.sin(phi_c), math.cos(phi_c)])
        yawd, phid = qd[2], qd[2] + qd[3]
        origin = (np.eye(2, 7), np.zeros(2))  # the axle midpoint (x, y)
        rows, bs = [], []
        # (point, direction, d/dt direction, spin coordinate, wheel radius)
        for point, dirn, dirn_dot, spin, radius in (
            ("L", eb, yawd * nb, 4, p.r),  # left wheel rolls
            ("R", eb, yawd * nb, 5, p.r),  # right wheel rolls
            (None, nb, -yawd * eb, None, 0.0),  # the axle does not skid
            ("P", ec, phid * nc, 6, p.r_c),  # caster wheel rolls
            ("P", nc, -phid * ec, None, 0.0),  # caster wheel does not skid
        ):
            jac, jdqd = origin if point is None else self.kin(point, q, qd)[1:]
            row = dirn @ jac
            if spin is not None:
                row[spin] -= radius
            rows.append(row)
            bs.append(dirn_dot @ (jac @ qd) + dirn @ jdqd)
        return np.array(rows), np.array(bs)

    def rhs(self, z, tau):
        p = self.p
        q, qd = z[:7], z[7:]
        mass = self.rot.copy()
        bias = np.zeros(7)
        for name, (m, _) in self.points.items():
            _, jac, jdqd = self.kin(name, q, qd)
            mass += m * jac.T @ jac
            bias += m * jac.T @ jdqd
        s = lambda v: (2 / math.pi) * math.atan(p.k_s * v)  # noqa: E731
        n_l, n_r, n_c = self.loads(q)
        force = np.zeros(7)
        force[4] = tau[0] - p.b_drive * qd[4] - p.mu_r * n_l * p.r * s(p.r * qd[4])
        force[5] = tau[1] - p.b_drive * qd[5] - p.mu_r * n_r * p.r * s(p.r * qd[5])
        force[6] = -p.b_caster * qd[6] - p.mu_r * n_c * p.r_c * s(p.r_c * qd[6])
        force[3] -= p.b_caster * qd[3]
        force[2] -= p.mu_p * (n_l + n_r) * s(p.rho * qd[2])  # drive-wheel pivot scrub
        scrub = -p.mu_p * n_c * s(p.rho * (qd[2] + qd[3]))  # caster pivot scrub
        force[2] += scrub
        force[3] += scrub
        a, b = self.constraints(q, qd)
        kkt = np.zeros((12, 12))
        kkt[:7, :7] = mass
        kkt[:7, 7:] = a.T
        kkt[7:, :7] = a
        sol = np.linalg.solve(kkt, np.concatenate([force - bias, -b]))
        return np.concatenate([qd, sol[:7]])

    def initial(self, x):
        """Full state from the reduced one; qdot solved from the constraints independently."""
        q = np.array([x[0], x[1], x[2], x[5], x[6], x[7], x[8]])
        a, _ = self.constraints(q, np.zeros(7))
        rows = np.zeros((7, 7))
        rows[:5] = a
        rows[5, :2] = [math.cos(x[2]), math.sin(x[2])]
        rows[6, 2] = 1.0
        qd = np.linalg.solve(rows, np.array([0, 0, 0, 0, 0, x[3], x[4]]))
        return np.concatenate([q, qd])

    def reduced(self, z):
        q, qd = z[:7], z[7:]
        v = math.cos(q[2]) * qd[0] + math.sin(q[2]) * qd[1]
        return np.array([q[0], q[1], q[2], v, qd[2], q[3], q[4], q[5], q[6]])

    def kinetic_energy(self, z):
        q, qd = z[:7], z[7:]
        t = 0.5 * qd @ self.rot @ qd
        for name, (m, _) in self.points.items():
            _, jac, _ = self.kin(name, q, qd)
            t += 0.5 * m * np.sum((jac @ qd) ** 2)
        return t


def _torques(t: float) -> np.ndarray:
    return np.array([1.5 + 2.0 * math.sin(1.7 * t), 0.5 + 2.5 * math.cos(1.1 * t)])


@pytest.fixture(scope="module")
def model() -> CasterAGV:
    return CasterAGV()


def test_lagrange_multiplier_cross_check(model):
    """Reduced NOC model == full-coordinate Lagrange model with multipliers (1e-8)."""
    ref = FullCoordinates(model.params)
    x = np.array([0.2, -0.1, 0.3, 0.4, 0.3, 1.2, 0.0, 0.0, 0.0])
    z = ref.initial(x)
    np.testing.assert_allclose(ref.reduced(z), x, atol=1e-14)
    assert abs(ref.kinetic_energy(z) - model.kinetic_energy(x)) < 1e-12
    ctrl_dt, n = 0.05, 50
    err = 0.0
    for k in range(30):  # 1.5 s, torques piecewise constant per control step
        tau = _torques(k * ctrl_dt)
        x = model.step(x, tau, ctrl_dt, n)
        z = rk4(lambda s, u: ref.rhs(s, u), z, tau, ctrl_dt, n)
        err = max(err, float(np.max(np.abs(ref.reduced(z) - x))))
    assert abs(x[5] - 1.2) > 0.3  # the caster really swivelled
    assert err < 1e-8, err


@pytest.mark.parametrize("sigma", [0.0, 0.7, 2.5, -1.9])
def test_full_coordinate_pieces(model, sigma):
    """M(sigma) from kinetic energy of the full model; loads from the solved statics."""
    ref = FullCoordinates(model.params)
    rng = np.random.default_rng(3)
    for _ in range(3):
        x = np.concatenate([rng.normal(size=3), rng.normal(size=2), [sigma], np.zeros(3)])
        z = ref.initial(x)
        assert abs(ref.kinetic_energy(z) - model.kinetic_energy(x)) < 1e-12
    q = ref.initial(np.array([0, 0, 0.4, 0, 0, sigma, 0, 0, 0]))[:7]
    np.testing.assert_allclose(model.normal_loads(sigma), ref.loads(q), rtol=1e-12)
    assert np.all(model.normal_loads(sigma) > 0)


def test_energy_balance(model):
    """T(t) - T(0) = integral of motor power + friction power (the friction power is <= 0)."""

    def f(z, u):
        x = z[:9]
        p = model.motor_power(x, u) + model.friction_power(x)
        return np.concatenate([model.derivative(x, u), [p]])

    x0 = np.array([0.0, 0.0, 0.0, 0.3, -0.4, 2.0, 0.0, 0.0, 0.0])
    z = np.concatenate([x0, [0.0]])
    worst = 0.0
    for k in range(40):
        tau = _torques(k * 0.05)
        z = rk4(f, z, tau, 0.05, 25)
        t_now = model.kinetic_energy(z[:9])
        worst = max(worst, abs(t_now - model.kinetic_energy(x0) - z[9]))
        assert model.friction_power(z[:9]) <= 0.0
    assert worst < 1e-9 * max(1.0, float(model.kinetic_energy(z[:9]))), worst


def test_power_terms_match_generalized_forces(model):
    rng = np.random.default_rng(0)
    x = rng.normal(size=(5, 9))
    tau = rng.normal(size=(5, 2))
    u = x[:, 3:5]
    q_motor = tau @ model.input_matrix().T
    np.testing.assert_allclose(model.motor_power(x, tau), np.sum(u * q_motor, -1), rtol=1e-12)
    # energy identity u.c = u^T Mdot u / 2 with Mdot = dM/dsigma sigmadot (finite difference)
    sig = x[:, 5]
    sd = model.joint_velocity(x)[:, 3]
    h = 1e-6
    dm = (model.mass_matrix(sig + h) - model.mass_matrix(sig - h)) / (2 * h)
    lhs = np.sum(u * model.bias(sig, u), -1)
    rhs = 0.5 * np.einsum("ni,nij,nj->n", u, dm, u) * sd
    np.testing.assert_allclose(lhs, rhs, rtol=1e-6, atol=1e-8)


def test_caster_trails_from_skewed_start(model):
    """Driving straight with equal torques, a caster started at 2.5 rad swings behind its axis
    (sigma -> 0 mod 2 pi) and the platform ends up driving straight."""
    x = np.array([0.0, 0.0, 0.0, 0.4, 0.0, 2.5, 0.0, 0.0, 0.0])
    x = model.step(x, np.array([1.0, 1.0]), 4.0, 2000)
    sig = math.remainder(x[5], 2 * math.pi)
    assert abs(sig) < 1e-6
    assert abs(x[4]) < 1e-6
    assert x[3] > 1.0
    # kinematic fact behind it: with w = 0, sigmadot = -v sin(sigma) / d (TW-1)
    d = model.params.d
    j = model.jacobian(np.array([0.3, 2.0]))
    np.testing.assert_allclose(j[:, 3, 0], -np.sin([0.3, 2.0]) / d, rtol=1e-14)


def test_joint_rates_integrate_to_angles(model):
    x0 = np.array([0.0, 0.0, 0.0, 0.5, 0.2, 0.4, 0.0, 0.0, 0.0])
    xd = model.derivative(x0, np.zeros(2))
    np.testing.assert_allclose(xd[[6, 7, 8, 5]], model.joint_velocity(x0), rtol=1e-14)
    np.testing.assert_allclose(model.body_twist(x0), [0.5, 0.0, 0.2])


def test_batched_equals_one_by_one(model):
    rng = np.random.default_rng(7)
    X = rng.normal(size=(600, 9))  # >= PARALLEL_MIN_BATCH: the prange kernel
    U = rng.normal(size=(600, 2))
    batch = model.step(X, U, 0.05, 25)
    small = model.step(X[:7], U[:7], 0.05, 25)
    for i in range(7):
        one = model.step(X[i], U[i], 0.05, 25)
        assert np.array_equal(one, batch[i])
        assert np.array_equal(one, small[i])
    d = model.derivative(X.reshape(20, 30, 9), U.reshape(20, 30, 2))
    assert d.shape == (20, 30, 9)
    assert np.array_equal(d.reshape(600, 9)[5], model.derivative(X[5], U[5]))


def test_stiffness_and_default_step(model):
    lam = model.stiffness()
    assert 0 < lam * model.default_sim_dt < 2.785 / 4
    j = model.friction_jacobian_at_rest(np.linspace(-3, 3, 7))
    assert np.all(np.linalg.eigvalsh(j) < 0)


@pytest.mark.parametrize(
    "kwargs, match",
    [
        ({"m_b": -1.0}, "m_b"),
        ({"d": 0.0}, "d"),
        ({"caster_axis": (0.02, 0.0)}, "caster_axis"),
        ({"caster_axis": (0.3, 0.0, 1.0)}, "caster_axis"),
        ({"x_G": -0.2}, "support triangle"),
        ({"mu_r": float("nan")}, "finite"),
    ],
)
def test_bad_params(kwargs, match):
    with pytest.raises(ValueError, match=match):
        CasterAGV(**kwargs)


def test_unknown_param_lists_valid():
    with pytest.raises(TypeError, match="valid names"):
        CasterAGV({"mass": 3.0})


def test_non_finite_input_raises(model):
    with pytest.raises(ValueError, match="not finite"):
        model.step(np.zeros(9), np.array([np.nan, 0.0]), 0.05, 2)
