"""The three-wheel paper's simulation (its section 5, docs/physics/three-wheel.md TW-7), as a
function.

Inverse dynamics along the paper's trajectory gives the motor torques; forward dynamics run
open loop with those torques must reproduce the joint angles of the inverse-kinematics
integration. The paper reports 1e-2 to 1e-3 rad of error; here it is about 1e-9 rad.

How the torques are sampled. The torque is a function of time. Holding it constant over each
RK4 step would make the scheme first order in the torque (error ~ h |dtau/dt|). Instead the
robot and the inverse-kinematics reference are integrated together as one ODE, with
``z = (x_robot, psi_ref, theta_ref)``: at every RK4 stage the torque is recomputed by inverse
dynamics from the reference's stage values (its steering angles and the trajectory's twist and
twist rate at the stage time), so the whole scheme stays fourth order. The robot never sees
its own state in the torque: the run is open loop.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numba import njit

from wheelgym import _numba_cache
from wheelgym import integrators as _integrators
from wheelgym.control import controllers as _controllers
from wheelgym.control import distribution as _distribution
from wheelgym.control.controllers import _tw_force
from wheelgym.control.distribution import _wls_one
from wheelgym.kinematics.references import QuinticCircle
from wheelgym.models import elementwise as _elementwise
from wheelgym.models import friction as _friction
from wheelgym.models.kernels import three_wheel as _tw
from wheelgym.models.three_wheel import ThreeWheel

__all__ = ["paper_experiment"]

_numba_cache.guard(__file__, _controllers.__file__, _distribution.__file__, _tw.__file__,
             _friction.__file__, _integrators.__file__, _elementwise.__file__)


@njit(cache=True)
def _ik_rates(psi, u, p, out):  # pragma: no cover - compiled
    """TW-1: joint rates ``J(psi) u`` into out[0:3] (steer) and out[3:6] (drive)."""
    cs = _tw.trig(psi[0], psi[1], psi[2])
    for i in range(3):
        g, h = _tw.gh(cs, i, p)
        jd, js = _tw.jacobian_rows(g, h, p)
        out[i] = js[0] * u[0] + js[1] * u[1] + js[2] * u[2]
        out[3 + i] = jd[0] * u[0] + jd[1] * u[1] + jd[2] * u[2]


@njit(cache=True)
def _ref_torque(psi, u, ud, p, J, Q, tau):  # pragma: no cover - compiled
    """Minimum-norm torques of TW-6 for the reference state (steering angles psi, twist u)."""
    xs = np.zeros(12)
    xs[3] = u[0]
    xs[4] = u[1]
    xs[5] = u[2]
    xs[6] = psi[0]
    xs[7] = psi[1]
    xs[8] = psi[2]
    _tw_force(xs, ud[0], ud[1], ud[2], u[0], u[1], u[2], p, J, Q)
    _wls_one(J, Q, np.ones(6), tau)


@njit(cache=True)
def _run(z0, TW, TR, p_plant, p_ctrl, h, out_z):  # pragma: no cover - compiled
    """RK4 on ``z = (x_robot[12], psi_ref[3], theta_ref[3])``; TW, TR at half-step times."""
    nz = z0.shape[0]
    n_steps = out_z.shape[0] - 1
    z = z0.copy()
    out_z[0] = z
    k = np.empty((4, nz))
    zs = np.empty(nz)
    J = np.empty((6, 3))
    Q = np.empty(3)
    tau = np.empty(6)
    rates = np.empty(6)
    for n in range(n_steps):
        for s in range(4):
            if s == 0:
                for j in range(nz):
                    zs[j] = z[j]
                idx = 2 * n
            elif s == 3:
                for j in range(nz):
                    zs[j] = z[j] + h * k[2, j]
                idx = 2 * n + 2
            else:
                for j in range(nz):
                    zs[j] = z[j] + 0.5 * h * k[s - 1, j]
                idx = 2 * n + 1
            _ref_torque(zs[12:15], TW[idx], TR[idx], p_ctrl, J, Q, tau)
            _tw.deriv_one(zs[0:12], tau, p_plant, k[s, 0:12])
            _ik_rates(zs[12:15], TW[idx], p_ctrl, rates)
            for j in range(6):
                k[s, 12 + j] = rates[j]
        for j in range(nz):
            z[j] += h / 6.0 * (k[0, j] + 2.0 * k[1, j] + 2.0 * k[2, j] + k[3, j])
        out_z[n + 1] = z


def paper_experiment(
    model: ThreeWheel | None = None,
    dt: float = 0.002,
    reference: Any = None,
    psi0: Any = (0.0, 0.0, 0.0),
) -> dict[str, np.ndarray]:
    """Run the paper's experiment (TW-7).

    Args:
        model: the robot (default parameters if None); it is both plant and controller model.
        dt: RK4 step (s); the default is the model's ``sim_dt``.
        reference: trajectory (default :class:`~wheelgym.kinematics.references.QuinticCircle`, the
            paper's 1 m circle in 60 s).
        psi0: initial steering angles (rad); the robot starts at rest at the reference's pose.

    Returns:
        A dict of arrays over the time grid ``t`` (s): ``x`` robot states ``(n, 12)``;
        ``psi_ref``, ``theta_ref`` the inverse-kinematics joint angles ``(n, 3)``; ``pose``,
        ``twist``, ``twist_rate`` of the reference; ``tau`` minimum-norm motor torques
        ``(n, 6)``; ``Q`` generalized force ``(n, 3)``; ``J`` ``(n, 6, 3)``;
        ``theta_error`` and ``psi_error`` ``(n, 3)`` (robot minus inverse kinematics, rad).
    """
    model = ThreeWheel() if model is None else model
    if not isinstance(model, ThreeWheel):
        raise TypeError(f"model must be a ThreeWheel, got {type(model).__name__}")
    reference = QuinticCircle() if reference is None else reference
    if not (np.isfinite(dt) and dt > 0):
        raise ValueError(f"dt must be positive and finite, got {dt!r}")
    n = int(round(reference.duration / dt))
    if n < 1 or abs(n * dt - reference.duration) > 1e-9 * reference.duration:
        raise ValueError(f"dt ({dt}) must divide the reference duration ({reference.duration})")
    psi0 = np.asarray(psi0, dtype=np.float64)
    if psi0.shape != (3,) or not np.all(np.isfinite(psi0)):
        raise ValueError(f"psi0 must be 3 finite angles, got {psi0!r}")
    th = np.arange(2 * n + 1) * (0.5 * dt)
    pose_h, tw_h, tr_h = reference.evaluate(th)
    z0 = np.zeros(18)
    z0[0:3] = pose_h[0]
    z0[3:6] = tw_h[0]
    z0[6:9] = psi0
    z0[12:15] = psi0
    out = np.empty((n + 1, 18))
    _run(z0, np.ascontiguousarray(tw_h), np.ascontiguousarray(tr_h), model.packed, model.packed,
         float(dt), out)
    from wheelgym.control.controllers import inverse_dynamics
    from wheelgym.control.distribution import min_norm

    x = out[:, :12]
    psi_ref = out[:, 12:15]
    theta_ref = out[:, 15:18]
    twist = tw_h[::2]
    rate = tr_h[::2]
    xr = np.zeros((n + 1, 12))
    xr[:, 3:6] = twist
    xr[:, 6:9] = psi_ref
    Q, J = inverse_dynamics(model, xr, rate)
    tau = min_norm(J, Q)
    return {
        "t": th[::2],
        "x": x,
        "psi_ref": psi_ref,
        "theta_ref": theta_ref,
        "pose": pose_h[::2],
        "twist": twist,
        "twist_rate": rate,
        "tau": tau,
        "Q": Q,
        "J": J,
        "theta_error": x[:, 9:12] - theta_ref,
        "psi_error": x[:, 6:9] - psi_ref,
    }
