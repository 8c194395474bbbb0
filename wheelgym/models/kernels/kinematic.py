"""Compiled pieces of the kinematic models (docs/physics/kinematic.md), for every layer's kernels.

One set of functions serves Unicycle, Bicycle, DifferentialDrive and Ackermann: the packed
parameter array (:meth:`UnicycleParams.pack` ...) holds the model kind and input mode at
``P_KIND`` and ``P_MODE`` (codes ``K_*`` and ``M_*`` below) and the limits at the other
``P_*`` indices (unused slots 0).

| name            | what                                                              |
|-----------------|-------------------------------------------------------------------|
| ``effective``   | the saturated body command ``(v, w, psidot)``                     |
| ``deriv_one``   | the state derivative of one state into ``out``                    |
| ``state_dim``   | the state size (4 for Ackermann, else 3)                          |
| ``KERNELS``     | the models' batch kernels (integrators.model_kernels)             |

The input modes and saturations are those of :mod:`wheelgym.models.kinematic`.
"""

from __future__ import annotations

import math

from numba import njit

from wheelgym import _numba_cache
from wheelgym import integrators as _integrators
from wheelgym.integrators import model_kernels

# kernels here inline integrators.rk4_inplace
_numba_cache.guard(__file__, _integrators.__file__)

__all__ = [
    "P_KIND", "P_MODE", "P_R", "P_D", "P_L", "P_VLO", "P_VHI", "P_WSLO", "P_WSHI", "P_WMAX",
    "P_PSIMAX", "P_PSIDMAX", "NP", "NU", "K_UNI", "K_BIC", "K_DD", "K_ACK", "M_WSHR", "M_VSHR",
    "M_VSSA", "M_WS", "M_VSSR", "clip", "effective", "deriv_one", "state_dim", "k_effective",
    "KERNELS",
]

#: Indices into the packed parameter array (shared by all kinematic models; unused slots 0).
(P_KIND, P_MODE, P_R, P_D, P_L, P_VLO, P_VHI, P_WSLO, P_WSHI, P_WMAX, P_PSIMAX,
 P_PSIDMAX) = range(12)
NP = 12  # length of the packed array
NU = 2  # input size

#: Model kinds and input modes (integers stored at P_KIND and P_MODE).
K_UNI, K_BIC, K_DD, K_ACK = 0, 1, 2, 3
M_WSHR, M_VSHR, M_VSSA, M_WS, M_VSSR = 0, 1, 2, 3, 4


# ---------------------------------------------------------------------------- compiled pieces
@njit(cache=True, inline="always")
def clip(a, lo, hi):  # pragma: no cover - compiled
    return min(max(a, lo), hi)


@njit(cache=True, inline="always")
def effective(x, u, p):  # pragma: no cover - compiled
    """Saturated body command ``(v, w, psidot)`` (module docstring for the order)."""
    kind = int(p[P_KIND])
    mode = int(p[P_MODE])
    psidot = 0.0
    if kind == K_UNI:
        r = p[P_R]
        phidot = u[0] if mode == M_WSHR else u[0] / r
        phidot = clip(phidot, p[P_WSLO], p[P_WSHI])
        v = clip(r * phidot, p[P_VLO], p[P_VHI])  # reference: v = r phidot
        w = clip(u[1], -p[P_WMAX], p[P_WMAX])
    elif kind == K_DD:
        r, d = p[P_R], p[P_D]
        if mode == M_WS:
            wl, wr = u[0], u[1]
        else:  # diff-drive lecture section 3, inverted
            wl = (u[0] - 0.5 * d * u[1]) / r
            wr = (u[0] + 0.5 * d * u[1]) / r
        wl = clip(wl, p[P_WSLO], p[P_WSHI])
        wr = clip(wr, p[P_WSLO], p[P_WSHI])
        v = clip(0.5 * r * (wl + wr), p[P_VLO], p[P_VHI])  # reference: v = r (L + R) / 2
        w = r * (wr - wl) / d  # reference: w = r (R - L) / d
    elif kind == K_BIC:
        v = clip(u[0], p[P_VLO], p[P_VHI])
        if mode == M_VSSA:
            psi = clip(u[1], -p[P_PSIMAX], p[P_PSIMAX])
            w = v * math.tan(psi) / p[P_L]  # reference: yawdot = v tan(psi) / l
        else:
            wlim = abs(v) * math.tan(p[P_PSIMAX]) / p[P_L]
            w = clip(u[1], -wlim, wlim)
    else:  # Ackermann: reference ODE, psi integrates
        v = clip(u[0], p[P_VLO], p[P_VHI])
        psimax = p[P_PSIMAX]
        psi = clip(x[3], -psimax, psimax)
        w = v * math.tan(psi) / p[P_L]
        psidot = clip(u[1], -p[P_PSIDMAX], p[P_PSIDMAX])
        if (x[3] >= psimax and psidot > 0.0) or (x[3] <= -psimax and psidot < 0.0):
            psidot = 0.0
    return v, w, psidot


@njit(cache=True)
def deriv_one(x, u, p, out):  # pragma: no cover - compiled
    v, w, psidot = effective(x, u, p)
    yaw = x[2]
    out[0] = math.cos(yaw) * v  # reference: xdot = v cos(theta)
    out[1] = math.sin(yaw) * v  # ydot = v sin(theta)
    out[2] = w  # thetadot = w
    if x.shape[0] > 3:
        out[3] = psidot  # Ackermann: psidot


@njit(cache=True)
def k_effective(X, U, p, out):  # pragma: no cover - compiled
    for i in range(X.shape[0]):
        out[i, 0], out[i, 1], out[i, 2] = effective(X[i], U[i], p)


@njit(cache=True, inline="always")
def state_dim(p):  # pragma: no cover - compiled
    """State size: 4 for Ackermann (``psi`` integrates), else 3."""
    return 4 if int(p[P_KIND]) == K_ACK else 3


# ---------------------------------------------------------------------------- batch kernels
#: The models' batch kernels: the generic bodies of wheelgym.integrators with this
#: derivative, a row at a time.
KERNELS = model_kernels(__name__, __file__, deriv_one, state_dim, NU)
