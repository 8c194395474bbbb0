"""Tests of the three-wheel model (docs/physics/three-wheel.md, TW-1..TW-5).

The central check is an independent second formulation: Lagrange's equations in the full
coordinates ``q = (x, y, yaw, psi_1..3, theta_1..3)`` with multipliers for the six rolling and
skid constraints, derived here with sympy from the kinetic energy of the bodies (no reduction to
the body twist, no shared code with the package except the parameter values).
"""

from __future__ import annotations

import dataclasses
import functools
import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from wheelgym.models import ThreeWheel, ThreeWheelParams
from wheelgym.models.noc_reference import noc_terms
from wheelgym.models.three_wheel import RK4_REAL_STABILITY_LIMIT

TIGHT = {"method": "DOP853", "rtol": 1e-12, "atol": 1e-12}


def torque_profile(t: float) -> np.ndarray:
    """Smooth, varying motor torques (N·m) in motor order: speeds up to 2.5 m/s, the platform
    turns at up to 5 rad/s and the steering torques spin the casters round several times."""
    drive = np.array([0.8 + 0.6 * math.sin(1.3 * t), 0.6 + 0.5 * math.cos(0.9 * t + 0.4),
                      0.4 + 0.8 * math.sin(0.7 * t + 1.0)])
    steer = np.array([0.2 * math.sin(2.1 * t), -0.15 * math.cos(1.7 * t + 0.3),
                      0.25 * math.sin(1.1 * t + 2.0)])
    return np.concatenate([drive, steer])


def moving_start() -> np.ndarray:
    """A moving state: pose, twist (0.4, -0.15, 0.5), steering off the rolling direction."""
    return np.array([0.3, -0.1, 0.7, 0.4, -0.15, 0.5, 0.3, -0.5, 1.2, 0.0, 0.1, -0.2])


# ------------------------------------------------------------------ independent reference
class FullCoordinateReference:
    """Lagrange equations with multipliers in ``q = (x, y, yaw, psi_1..3, theta_1..3)``.

    Kinetic energy: platform ``m_b, I_b``; module i a point mass ``m_w`` at the wheel centre
    ``P_i = (x, y) + R(yaw) a_i - d (cos(yaw + psi_i), sin(yaw + psi_i))`` with yaw inertia
    ``I_wz`` about it (angle ``yaw + psi_i``); wheel spin inertia ``I_wy`` (angle ``theta_i``).
    ``M_q = d2T/dqdot2`` and the velocity-product terms
    ``C = d(dT/dqdot)/dq qdot - dT/dq`` are exact symbolic derivatives. Constraints ``A qdot = 0``:
    the wheel centre moves along ``e_i`` at ``r thetadot_i`` (rolling) and not along ``n_i``
    (skid). Generalized forces by virtual work: motor torques act on their joint angles, the
    rolling resistance ``-mu_r N_i sgn_s(e_i . Pdot_i)`` along ``e_i`` at ``P_i``, the scrub
    moment ``-mu_p N_i sgn_s(rho (yawdot + psidot_i))`` on the wheel's heading, viscous joint
    torques on ``psi_i`` and ``theta_i``; ``N_i`` from a linear solve of the static balance.
    """

    def __init__(self, p: ThreeWheelParams):
        import sympy as sp

        self.p = p
        q = sp.symbols("x y b s1 s2 s3 t1 t2 t3")
        qd = sp.symbols("xd yd bd s1d s2d s3d t1d t2d t3d")
        x, y, b = q[:3]
        qv = sp.Matrix(q)
        qdv = sp.Matrix(qd)
        half = sp.Rational(1, 2)
        T = half * p.m_b * (qd[0] ** 2 + qd[1] ** 2) + half * p.I_b * qd[2] ** 2
        a_rows = []
        roll_rows = []
        for i in range(3):
            ax, ay = p.axes[i]
            phi = b + q[3 + i]
            P = sp.Matrix([x + sp.cos(b) * ax - sp.sin(b) * ay - p.d * sp.cos(phi),
                           y + sp.sin(b) * ax + sp.cos(b) * ay - p.d * sp.sin(phi)])
            JP = P.jacobian(qv)  # 2 x 9
            Pd = JP * qdv
            T += sp.Rational(1, 2) * p.m_w * (Pd[0] ** 2 + Pd[1] ** 2)
            T += sp.Rational(1, 2) * p.I_wz * (qd[2] + qd[3 + i]) ** 2
            T += sp.Rational(1, 2) * p.I_wy * qd[6 + i] ** 2
            e = sp.Matrix([[sp.cos(phi), sp.sin(phi)]])
            n = sp.Matrix([[-sp.sin(phi), sp.cos(phi)]])
            roll = e * JP
            roll_rows.append(roll)
            theta_row = sp.zeros(1, 9)
            theta_row[6 + i] = p.r
            a_rows.append(roll - theta_row)  # rolling: e . Pdot = r thetadot
            a_rows.append(n * JP)  # no skid: n . Pdot = 0
        Tv = sp.Matrix([T])
        dT_dqd = Tv.jacobian(qdv).T
        Mq = dT_dqd.jacobian(qdv)
        C = dT_dqd.jacobian(qv) * qdv - Tv.jacobian(qv).T
        A = sp.Matrix.vstack(*a_rows)
        Adot_qd = (A * qdv).jacobian(qv) * qdv
        G = sp.Matrix.vstack(*roll_rows)
        args = (q, qd)
        self._M = sp.lambdify(args, Mq, "numpy", cse=True)
        self._C = sp.lambdify(args, C, "numpy", cse=True)
        self._A = sp.lambdify(args, A, "numpy", cse=True)
        self._Ad = sp.lambdify(args, Adot_qd, "numpy", cse=True)
        self._G = sp.lambdify(args, G, "numpy", cse=True)
        self.k_s = p.k_s

    def sgn(self, s):
        return (2.0 / np.pi) * np.arctan(self.k_s * s)

    def loads(self, psi: np.ndarray) -> np.ndarray:
        p = self.p
        a = np.asarray(p.axes, dtype=float)
        c = a - p.d * np.stack([np.cos(psi), np.sin(psi)], axis=1)
        lhs = np.vstack([np.ones(3), c[:, 0], c[:, 1]])
        return np.linalg.solve(lhs, [(p.m_b + 3 * p.m_w) * p.g, 0.0, 0.0])

    def forces(self, q, qd, tau) -> np.ndarray:
        p = self.p
        Q = np.zeros(9)
        Q[6:9] += tau[:3] - p.b_drive * qd[6:9]
        Q[3:6] += tau[3:] - p.b_steer * qd[3:6]
        N = self.loads(q[3:6])
        G = np.asarray(self._G(q, qd), dtype=float)  # rows e_i . dP_i/dq
        v_roll = G @ qd
        Q -= G.T @ (p.mu_r * N * self.sgn(v_roll))
        pivot = qd[2] + qd[3:6]
        scrub = p.mu_p * N * self.sgn(p.rho * pivot)
        Q[2] -= scrub.sum()
        Q[3:6] -= scrub
        return Q

    def rhs(self, t, z, tau_fn) -> np.ndarray:
        q, qd = z[:9], z[9:]
        M = np.asarray(self._M(q, qd), dtype=float)
        C = np.asarray(self._C(q, qd), dtype=float).ravel()
        A = np.asarray(self._A(q, qd), dtype=float)
        Ad = np.asarray(self._Ad(q, qd), dtype=float).ravel()
        K = np.block([[M, A.T], [A, np.zeros((6, 6))]])
        rhs = np.concatenate([self.forces(q, qd, tau_fn(t)) - C, -Ad])
        qdd = np.linalg.solve(K, rhs)[:9]
        return np.concatenate([qd, qdd])

    def initial(self, x: np.ndarray) -> np.ndarray:
        """Full-coordinate state from the model's: joint rates solved from A qdot = 0."""
        q = np.concatenate([x[:3], x[6:12]])
        cy, sy = math.cos(x[2]), math.sin(x[2])
        base = np.array([cy * x[3] - sy * x[4], sy * x[3] + cy * x[4], x[5]])
        A = np.asarray(self._A(q, np.zeros(9)), dtype=float)
        joints = np.linalg.solve(A[:, 3:], -A[:, :3] @ base)
        return np.concatenate([q, base, joints])

    def to_model_state(self, z: np.ndarray) -> np.ndarray:
        q, qd = z[:9], z[9:]
        cy, sy = math.cos(q[2]), math.sin(q[2])
        vx = cy * qd[0] + sy * qd[1]
        vy = -sy * qd[0] + cy * qd[1]
        return np.concatenate([q[:3], [vx, vy, qd[2]], q[3:9]])

    def constraint_residual(self, z: np.ndarray) -> float:
        A = np.asarray(self._A(z[:9], z[9:]), dtype=float)
        return float(np.max(np.abs(A @ z[9:])))


@functools.cache
def reference(p: ThreeWheelParams) -> FullCoordinateReference:
    return FullCoordinateReference(p)


def integrate_model(model: ThreeWheel, x0: np.ndarray, t_end: float, tau_fn, t_eval):
    return solve_ivp(lambda t, x: model.derivative(x, tau_fn(t)), (0.0, t_end), x0,
                     t_eval=t_eval, **TIGHT)


# ------------------------------------------------------------------ tests
def test_against_full_coordinate_lagrange_formulation():
    """docs/physics/three-wheel.md TW-3: same trajectories as Lagrange multipliers in full
    coordinates, 1e-8."""
    model = ThreeWheel()
    ref = reference(model.params)
    x0 = moving_start()
    z0 = ref.initial(x0)
    # the joint rates solved from the constraints equal TW-1's J u
    np.testing.assert_allclose(
        np.concatenate([z0[15:18], z0[12:15]]), model.joint_velocity(x0), rtol=0, atol=1e-12
    )
    t_eval = np.linspace(0.0, 3.0, 31)
    sol_m = integrate_model(model, x0, 3.0, torque_profile, t_eval)
    sol_r = solve_ivp(ref.rhs, (0.0, 3.0), z0, t_eval=t_eval, args=(torque_profile,), **TIGHT)
    assert sol_m.success and sol_r.success
    xr = np.array([ref.to_model_state(z) for z in sol_r.y.T])
    err = np.max(np.abs(xr - sol_m.y.T))
    assert err < 1e-8, err
    # the motion is not trivial: it moved, turned and steered
    assert np.ptp(sol_m.y[2]) > 0.3 and np.min(np.ptp(sol_m.y[6:9], axis=1)) > 0.1
    assert max(ref.constraint_residual(z) for z in sol_r.y.T) < 1e-9


def test_noc_matches_closed_form():
    """NOC (three-wheel paper (24)-(29)) reduces to TW-3's closed form, to 1e-12."""
    model = ThreeWheel()
    rng = np.random.default_rng(1)
    for _ in range(20):
        psi = rng.uniform(-np.pi, np.pi, 3)
        u = rng.normal(size=3)
        yaw = rng.uniform(-np.pi, np.pi)
        i_d = rng.uniform(0.0, model.params.I_wz)
        M, c, parts = noc_terms(model.params, psi, u, yaw=yaw, wheel_diametral_inertia=i_d)
        Mk = model.mass_matrix(psi)
        ck = model.bias(psi, u)
        assert np.max(np.abs(M - Mk)) <= 1e-12 * np.max(np.abs(Mk))
        assert np.max(np.abs(c - ck)) <= 1e-12 * max(1.0, np.max(np.abs(ck)))
        # T is an orthogonal complement of the constraints (paper (23)): every wheel's
        # contact point, centre velocity + omega x (-r k), is at rest for any u
        t = parts["T"] @ u
        for i in range(3):
            w = t[6 * (4 + i):6 * (4 + i) + 3]
            v = t[6 * (4 + i) + 3:6 * (4 + i) + 6]
            contact = v + np.cross(w, [0.0, 0.0, -model.params.r])
            assert np.max(np.abs(contact)) < 1e-13 * max(1.0, np.max(np.abs(u)) / 0.04)


def test_energy_balance():
    """Kinetic energy change = motor work + friction work (1e-9 relative)."""
    model = ThreeWheel()

    def aug(t, z):
        x, tau = z[:12], torque_profile(t)
        return np.concatenate([model.derivative(x, tau),
                               [model.motor_power(x, tau), model.friction_power(x)]])

    x0 = moving_start()
    sol = solve_ivp(aug, (0.0, 3.0), np.concatenate([x0, [0.0, 0.0]]), **TIGHT)
    assert sol.success
    xe, w_motor, w_fric = sol.y[:12, -1], sol.y[12, -1], sol.y[13, -1]
    d_ke = model.kinetic_energy(xe) - model.kinetic_energy(x0)
    scale = abs(w_motor) + abs(w_fric)
    assert w_fric < 0 and abs(w_fric) > 0.1 * abs(w_motor)  # both terms matter
    assert abs(d_ke - w_motor - w_fric) < 1e-9 * scale, (d_ke, w_motor, w_fric)


def test_energy_conserved_without_friction_and_torque():
    model = ThreeWheel().frictionless()
    assert (model.params.mu_r, model.params.mu_p, model.params.b_drive,
            model.params.b_steer) == (0.0, 0.0, 0.0, 0.0)
    x0 = moving_start()
    sol = solve_ivp(lambda t, x: model.derivative(x, np.zeros(6)), (0.0, 3.0), x0, **TIGHT)
    ke = model.kinetic_energy(sol.y.T)
    assert np.ptp(sol.y[6:9], axis=1).min() > 0.1  # the casters swing: M(psi) changes
    assert np.max(np.abs(ke - ke[0])) < 1e-9 * ke[0]
    assert np.all(model.friction_power(sol.y.T) == 0.0)


def _wheel_centre_velocity(p: ThreeWheelParams, x: np.ndarray, xdot: np.ndarray):
    """World velocity of each wheel centre from pose and steering rates (geometry only)."""
    yaw, psi = x[2], x[6:9]
    a = np.asarray(p.axes, dtype=float)
    R = np.array([[math.cos(yaw), -math.sin(yaw)], [math.sin(yaw), math.cos(yaw)]])
    phi = yaw + psi
    phid = xdot[2] + xdot[6:9]
    E = np.stack([np.cos(phi), np.sin(phi)], axis=1)
    N = np.stack([-np.sin(phi), np.cos(phi)], axis=1)
    Rp = R @ np.array([[0.0, -1.0], [1.0, 0.0]])  # dR/dyaw
    v = xdot[:2] + xdot[2] * (a @ Rp.T) - p.d * phid[:, None] * N
    return v, E, N


def test_no_slip_along_a_run():
    """TW-1: integrated wheel rates give the wheel-centre motion (rolling), no lateral skid."""
    model = ThreeWheel()
    p = model.params
    x = moving_start()
    worst_roll = worst_skid = 0.0
    for k in range(100):  # 2 s of RK4 at the default steps
        tau = torque_profile(0.02 * k)
        x = model.step(x, tau, 0.02, 10)
        xdot = model.derivative(x, tau)
        v, E, N = _wheel_centre_velocity(p, x, xdot)
        speed = np.max(np.abs(v)) + 1e-300
        worst_roll = max(worst_roll, np.max(np.abs(np.sum(v * E, 1) - p.r * xdot[9:12])) / speed)
        worst_skid = max(worst_skid, np.max(np.abs(np.sum(v * N, 1))) / speed)
    assert worst_roll < 1e-14 and worst_skid < 1e-14, (worst_roll, worst_skid)

    # integrated: the distance rolled r * (theta(T) - theta(0)) equals the path of the centre
    def aug(t, z):
        x, tau = z[:12], torque_profile(t)
        xdot = model.derivative(x, tau)
        v, E, N = _wheel_centre_velocity(p, x, xdot)
        return np.concatenate([xdot, np.sum(v * E, 1), np.sum(v * N, 1)])

    x0 = moving_start()
    sol = solve_ivp(aug, (0.0, 2.0), np.concatenate([x0, np.zeros(6)]), **TIGHT)
    z = sol.y[:, -1]
    rolled = p.r * (z[9:12] - x0[9:12])
    np.testing.assert_allclose(z[12:15], rolled, rtol=1e-10, atol=1e-12)
    assert np.max(np.abs(z[15:18])) < 1e-12
    assert np.min(np.abs(rolled)) > 0.1


def test_rk4_order():
    """RK4's global error falls 16x (+-25%) when the step halves (docs/physics/conventions.md)."""
    model = ThreeWheel()
    x0 = moving_start()
    x0[3] = 1.0
    tau = np.array([3.0, 2.5, 2.0, 0.3, -0.2, 0.4])
    t_end = 1.0
    # the casters align on a time scale d / |v| = 40 ms, so the asymptotic regime starts
    # near h = 5 ms
    ref = model.step(x0, tau, t_end, 12800)
    errs = [np.max(np.abs(model.step(x0, tau, t_end, n) - ref)) for n in (200, 400, 800)]
    ratios = [errs[0] / errs[1], errs[1] / errs[2]]
    assert all(12.0 <= r <= 20.0 for r in ratios), (errs, ratios)


def test_default_step_is_stable_and_accurate():
    """stiffness * sim_dt sits >= 20x inside RK4's real stability limit 2.785; the default step's
    error over a 5 s manoeuvre is below 1e-6 of the state's scale against 1/8 of the step.

    The manoeuvre (the model's validation_manoeuvre, from rest) drives forward. Reversing
    makes pushed casters flip, an unstable motion that amplifies any perturbation at a rate
    of about |v| / d (tens of 1/s), so there the difference between two step sizes measures
    that sensitivity rather than RK4's accuracy.
    """
    model = ThreeWheel()
    lam = model.stiffness()
    assert lam * model.default_sim_dt < RK4_REAL_STABILITY_LIMIT / 20.0, lam

    n = model.n_substeps()
    ctrl = model.default_ctrl_dt
    steps = int(round(5.0 / ctrl))
    x = xf = np.zeros(12)
    traj = [x]
    taus = np.array([model.validation_manoeuvre(k * ctrl) for k in range(steps)])
    for k in range(steps):
        tau = taus[k]
        x = model.step(x, tau, ctrl, n)
        xf = model.step(xf, tau, ctrl, 8 * n)
        traj.append(xf)
    traj = np.array(traj)
    scale = np.maximum(1.0, np.max(np.abs(traj), axis=0))
    err = np.max(np.abs(x - xf) / scale)
    assert err < 1e-6, err
    assert np.all(np.abs(taus) <= model.input_high)
    # the manoeuvre is a real one: over 1.5 m/s, turning both ways, always rolling forward
    assert np.max(traj[:, 3]) > 1.5 and np.min(traj[10:, 3]) > 0.1
    assert np.max(traj[:, 5]) > 0.5 and np.min(traj[:, 5]) < -0.3


def test_stiffness_matches_linearisation_and_rk4_limit():
    """stiffness(psi) is the friction eigenvalue of the linearised ODE at rest; RK4 at 0.9 of
    the stated limit decays a small disturbance and at 1.1 of it amplifies it."""
    model = ThreeWheel()
    psi = np.array([0.2, -0.4, 0.9])
    lam = model.stiffness(psi)
    x0 = np.zeros(12)
    x0[6:9] = psi
    h = 1e-7
    jac = np.empty((3, 3))
    for j in range(3):
        dx = np.zeros(12)
        dx[3 + j] = h
        rate = model.derivative(x0 + dx, np.zeros(6)) - model.derivative(x0 - dx, np.zeros(6))
        jac[:, j] = rate[3:6] / (2 * h)
    eig = np.linalg.eigvals(jac)
    assert np.all(eig.real < 0)
    assert abs(np.max(np.abs(eig)) - lam) < 1e-5 * lam
    # the stiffest mode: the eigenvector of the largest eigenvalue
    w, V = np.linalg.eig(jac)
    v = np.real(V[:, np.argmax(np.abs(w))])
    for factor, grows in ((0.9, False), (1.1, True)):
        dt = factor * RK4_REAL_STABILITY_LIMIT / lam
        x = x0.copy()
        x[3:6] = 1e-9 * v / np.max(np.abs(v))
        x1 = model.step(x, np.zeros(6), 20 * dt, 20)
        ratio = np.max(np.abs(x1[3:6])) / np.max(np.abs(x[3:6]))
        assert (ratio > 1.0) == grows, (factor, ratio)


def test_batched_equals_one_by_one():
    model = ThreeWheel()
    rng = np.random.default_rng(7)
    X = rng.normal(size=(1000, 12)) * np.array([5, 5, 3, 1, 1, 2, 3, 3, 3, 10, 10, 10])
    U = rng.uniform(-6, 6, size=(1000, 6))
    D = model.derivative(X, U)
    S = model.step(X, U, 0.05, 25)  # the parallel kernel
    psi, tw = X[:, 6:9], X[:, 3:6]
    J, M, c, Q, N = (model.jacobian(psi), model.mass_matrix(psi), model.bias(psi, tw),
                     model.friction(psi, tw), model.normal_loads(psi))
    for k in range(1000):
        assert np.array_equal(D[k], model.derivative(X[k], U[k]))
        assert np.array_equal(S[k], model.step(X[k], U[k], 0.05, 25))
        assert np.array_equal(J[k], model.jacobian(psi[k]))
        assert np.array_equal(M[k], model.mass_matrix(psi[k]))
        assert np.array_equal(c[k], model.bias(psi[k], tw[k]))
        assert np.array_equal(Q[k], model.friction(psi[k], tw[k]))
        assert np.array_equal(N[k], model.normal_loads(psi[k]))
    Jt, Mt, ct, Qt = model.dynamics_terms(psi, tw)
    assert all(np.array_equal(a, b) for a, b in ((Jt, J), (Mt, M), (ct, c), (Qt, Q)))
    # leading shapes pass through
    assert model.derivative(X.reshape(10, 100, 12), U.reshape(10, 100, 6)).shape == (10, 100, 12)
    assert np.array_equal(model.derivative(X.reshape(10, 100, 12), U.reshape(10, 100, 6)),
                          D.reshape(10, 100, 12))
    assert model.jacobian(psi.reshape(2, 500, 3)).shape == (2, 500, 6, 3)


def test_fast_sincos_and_atan_match_libm():
    """The kernel's own sin/cos agree with libm to 2 ulp (near their zeros to 1e-31 |x|, the
    accuracy of the three-part pi/2), arctan to 1 ulp."""
    from wheelgym.models.kernels.three_wheel import atan as _atan
    from wheelgym.models.kernels.three_wheel import sgn_s as _sgn_s
    from wheelgym.models.kernels.three_wheel import sincos as _sincos

    rng = np.random.default_rng(5)
    xs = np.concatenate([rng.normal(size=2000) * s for s in (1e-3, 1.0, 4.0, 100.0, 1e5)])
    xs = np.concatenate([xs, [0.0, -0.0, math.pi / 4, math.pi / 2, math.pi, 1e8, -1e8]])
    for x in xs:
        s, c = _sincos(x)
        floor = 1e-31 * max(1.0, abs(x))
        assert abs(s - math.sin(x)) <= 2 * np.spacing(abs(math.sin(x))) + floor
        assert abs(c - math.cos(x)) <= 2 * np.spacing(abs(math.cos(x))) + floor
    for x in np.concatenate([xs * 10.0, [1e300, -1e300, math.inf, -math.inf]]):
        assert abs(_atan(x) - math.atan(x)) <= np.spacing(abs(math.atan(x))) + 1e-300
        assert _sgn_s(x, 100.0) == pytest.approx((2 / math.pi) * math.atan(100.0 * x), rel=1e-15)


def test_pieces_satisfy_their_definitions():
    """J rows, loads balance, derivative = M^-1 (J^T tau + Q_f - c), powers, wheel centres."""
    model = ThreeWheel()
    p = model.params
    rng = np.random.default_rng(11)
    X = rng.normal(size=(50, 12))
    U = rng.uniform(-3, 3, size=(50, 6))
    psi, tw = X[:, 6:9], X[:, 3:6]
    J = model.jacobian(psi)
    M = model.mass_matrix(psi)
    rhs = np.einsum("kji,kj->ki", J, U) + model.friction(psi, tw) - model.bias(psi, tw)
    udot = np.linalg.solve(M, rhs[..., None])[..., 0]
    np.testing.assert_allclose(model.derivative(X, U)[:, 3:6], udot, rtol=1e-10, atol=1e-10)
    np.testing.assert_allclose(model.derivative(X, U)[:, 6:12][:, [3, 4, 5, 0, 1, 2]],
                               model.joint_velocity(X), rtol=1e-12, atol=1e-12)
    # loads: sum m g, no moment about the centre of mass at the wheel centres
    N = model.normal_loads(psi)
    C = model.wheel_centers(psi)
    np.testing.assert_allclose(N.sum(axis=1), p.m_total * p.g, rtol=1e-13)
    np.testing.assert_allclose(np.einsum("ki,kij->kj", N, C), 0.0, atol=1e-12)
    a = np.asarray(p.axes)
    np.testing.assert_allclose(np.linalg.norm(C - a, axis=2), p.d, rtol=1e-13)
    # M is symmetric positive definite; kinetic energy and powers
    assert np.all(np.linalg.eigvalsh(M) > 0)
    np.testing.assert_allclose(model.kinetic_energy(X),
                               0.5 * np.einsum("ki,kij,kj->k", tw, M, tw), rtol=1e-13)
    np.testing.assert_allclose(model.motor_power(X, U), np.sum(U * model.joint_velocity(X), 1),
                               rtol=1e-13)
    assert np.all(model.friction_power(X) <= 0)
    np.testing.assert_array_equal(model.body_twist(X), tw)
    # tau_max in motor order
    np.testing.assert_array_equal(p.tau_max, [6, 6, 6, 3, 3, 3])
    assert p.k_w == pytest.approx(1.0 + 0.0028 / 0.075**2)
    assert p.k_z == pytest.approx(0.005 / 0.04**2)


POSITIVE = ("m_b", "I_b", "m_w", "I_wy", "I_wz", "r", "d", "rho", "k_s", "g",
            "tau_drive_max", "tau_steer_max")
NONNEGATIVE = ("mu_r", "mu_p", "b_drive", "b_steer")


@pytest.mark.parametrize("name", POSITIVE)
@pytest.mark.parametrize("value", [0.0, -1.0])
def test_nonpositive_parameter_raises(name, value):
    with pytest.raises(ValueError, match=name):
        ThreeWheelParams(**{name: value})


@pytest.mark.parametrize("name", NONNEGATIVE)
def test_negative_friction_raises(name):
    with pytest.raises(ValueError, match=name):
        ThreeWheelParams(**{name: -0.01})
    ThreeWheelParams(**{name: 0.0})  # zero is allowed


@pytest.mark.parametrize("name", POSITIVE + NONNEGATIVE)
@pytest.mark.parametrize("value", [math.nan, math.inf])
def test_nonfinite_parameter_raises(name, value):
    with pytest.raises(ValueError, match=name):
        ThreeWheelParams(**{name: value})


@pytest.mark.parametrize(
    "axes",
    [
        ((-0.2, 0.0), (0.0, 0.0), (0.25, 0.0)),  # collinear
        ((0.1, 0.2), (0.1, -0.2), (0.5, 0.0)),  # centre of mass behind the triangle
        ((-0.2, 0.2), (-0.2, -0.2)),  # two axes
        ((-0.2, 0.2, 0.0), (-0.2, -0.2, 0.0), (0.25, 0.0, 0.0)),  # 3-D points
        ((-0.2, 0.2), (-0.2, math.nan), (0.25, 0.0)),  # non-finite
    ],
)
def test_bad_axes_raise(axes):
    with pytest.raises(ValueError, match="axes"):
        ThreeWheelParams(axes=axes)


def test_unknown_parameter_and_bad_params_type():
    with pytest.raises(TypeError):
        ThreeWheelParams(mass=3.0)
    with pytest.raises(TypeError, match="m_b"):
        ThreeWheel({"mass": 3.0})
    with pytest.raises(TypeError):
        ThreeWheel(params=3.0)
    # overrides and from_dict work and validate
    assert ThreeWheel(d=0.05).params.d == 0.05
    m = ThreeWheel({"axes": [[-0.2, 0.2], [-0.2, -0.2], [0.3, 0.0]]})
    assert m.params.axes[2] == (0.3, 0.0)
    assert dataclasses.is_dataclass(ThreeWheelParams())


def test_nonfinite_state_or_input_raises():
    model = ThreeWheel()
    x = moving_start()
    u = np.zeros(6)
    for bad in (math.nan, math.inf):
        xb = x.copy()
        xb[4] = bad
        with pytest.raises(ValueError, match="x"):
            model.step(xb, u, 0.05, 25)
        ub = u.copy()
        ub[5] = bad
        with pytest.raises(ValueError, match="u"):
            model.step(x, ub, 0.05, 25)
        with pytest.raises(ValueError):  # batched, one bad row
            X = np.tile(x, (600, 1))
            X[599, 0] = bad
            model.step(X, np.zeros((600, 6)), 0.05, 25)
    with pytest.raises(ValueError, match="x"):
        model.step(np.zeros(5), u, 0.05)
    for piece in (model.jacobian, model.mass_matrix, model.normal_loads, model.wheel_centers):
        with pytest.raises(ValueError, match="psi"):
            piece(np.array([0.0, math.nan, 0.0]))
    with pytest.raises(ValueError, match="u"):
        model.bias(np.zeros(3), [0.0, math.inf, 0.0])
    with pytest.raises(ValueError, match="x"):
        model.kinetic_energy(np.full(12, math.nan))
    with pytest.raises(ValueError, match="dt"):
        model.step(x, u, -0.1)
