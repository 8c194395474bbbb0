"""The car's kinematic model over a batch of plans, scored against a reference (compiled).

The car-like ``track`` baseline (:class:`wheelgym.envs.baseline._CarTrackSearch`) simulates
several hundred ``H``-step plans of speed and steering angle per robot and control step and
starts the one closest to the reference; this is that simulation. Per robot a compiled loop
over its plans side by side (vectorised), one argument reduction for each sine and cosine pair
(:func:`wheelgym.models.elementwise.sincos_wide`, the body of
:data:`~wheelgym.models.elementwise.sin` and ``cos``), no temporaries, and a table of plans
that every robot scores passed once, not copied per robot: the same bits as the same
arithmetic in element-wise NumPy on those ufuncs (``tests/kinematics/test_car_rollout.py``),
and the baseline labels states off the reference several times as fast as with NumPy
(``benchmarks/car_track.py``, docs/baselines.md).

The model (``docs/physics/kinematic.md``): ``yawdot = v tan(psi) / l`` with the steering
``psi = delta`` (Bicycle) or turned toward ``delta`` at ``rate`` rad/s at most (Ackermann),
integrated over each control step at the step's midpoint heading.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from wheelgym import _numba_cache
from wheelgym import integrators as _integrators
from wheelgym.integrators import llvm_inline
from wheelgym.models import elementwise as _elementwise
from wheelgym.models import friction as _friction
from wheelgym.models.elementwise import REDUCE_MAX, sincos_wide
from wheelgym.models.friction import sincos

__all__ = ["plan_costs"]

_numba_cache.guard(__file__, _friction.__file__, _integrators.__file__, _elementwise.__file__)


@llvm_inline
def _advance(S, j, vdt, a, wheelbase, rx, ry, wide):  # pragma: no cover - compiled
    """Plan ``j`` (column of ``S``) one step at speed x step ``vdt`` (m) and steering ``a``;
    ``wide``: libm's sine and cosine beyond ``REDUCE_MAX`` (False in the vectorised pass)."""
    s, co = sincos_wide(a) if wide else sincos(a)
    dth = vdt * (s / co / wheelbase)
    th_mid = S[2, j] + 0.5 * dth
    s, co = sincos_wide(th_mid) if wide else sincos(th_mid)
    x = S[0, j] + vdt * co
    y = S[1, j] + vdt * s
    S[0, j] = x
    S[1, j] = y
    S[2, j] = S[2, j] + dth
    ex = x - rx
    ey = y - ry
    S[4, j] = S[4, j] + (ex * ex + ey * ey)
    S[5, j] = max(S[5, j], max(abs(a), abs(th_mid)))


@llvm_inline
def _row(S, start, V, D, ref_xy, dt, wheelbase, rate, wide):  # pragma: no cover - compiled
    """One row's ``K`` plans side by side in ``S``: the state in fixed rows and no branch in
    the loop over plans (with ``wide`` False), so that loop vectorises (as
    :func:`wheelgym.integrators.rk4_block`'s)."""
    H, K = V.shape
    lim = rate * dt
    for r in range(4):
        S[r, :] = start[r]
    S[4, :] = 0.0
    S[5, :] = 0.0
    for k in range(H):
        rx, ry = ref_xy[k, 0], ref_xy[k, 1]
        if rate < 0.0:  # Bicycle: the steering angle is the plan's
            for j in range(K):
                _advance(S, j, V[k, j] * dt, D[k, j], wheelbase, rx, ry, wide)
        else:  # Ackermann: the steering turns toward it at the rate limit at most
            for j in range(K):
                turn = D[k, j] - S[3, j]
                turn = -lim if turn < -lim else turn
                turn = lim if turn > lim else turn
                a = S[3, j] + 0.5 * turn
                S[3, j] = S[3, j] + turn
                _advance(S, j, V[k, j] * dt, a, wheelbase, rx, ry, wide)


@njit(cache=True, error_model="numpy")
def _k_plan_costs(start, V, D, ref_xy, TV, TD, dt, wheelbase, rate, cost):  # pragma: no cover
    """Per row the ``Ks`` shared plans ``TV, TD`` (``cost[:, :Ks]``), then the row's own
    ``V, D`` (``cost[:, Ks:]``), each by :func:`_row` in the scratch array ``S``; where an
    angle reaches ``REDUCE_MAX``, again with libm's sine and cosine beyond it (as
    :mod:`wheelgym.models.elementwise`)."""
    n, _, K = V.shape
    Ks = TV.shape[1]
    S = np.empty((6, max(K, Ks)))  # x, y, yaw, steering angle, cost, largest |angle|
    for i in range(n):
        for shared in (True, False):
            P, Q, c0, m = (TV, TD, 0, Ks) if shared else (V[i], D[i], Ks, K)
            if m == 0:
                continue
            _row(S, start[i], P, Q, ref_xy[i], dt, wheelbase, rate, False)
            far = False
            for j in range(m):
                far |= S[5, j] >= REDUCE_MAX
            if far:
                _row(S, start[i], P, Q, ref_xy[i], dt, wheelbase, rate, True)
            for j in range(m):
                cost[i, c0 + j] = S[4, j]


def plan_costs(start: np.ndarray, V: np.ndarray, D: np.ndarray, ref_xy: np.ndarray,
               dt: float, wheelbase: float, rate: float | None,
               shared: tuple[np.ndarray, np.ndarray] | None = None) -> np.ndarray:
    """Sum over the horizon of the squared distance to the reference, for ``K`` plans a row
    (and ``S`` plans shared by every row).

    | argument     | shape       | unit            | meaning                                    |
    |--------------|-------------|-----------------|--------------------------------------------|
    | ``start``    | (n, 4)      | m, m, rad, rad  | each row's ``(x, y, yaw, psi)``             |
    | ``V``        | (n, H, K)   | m/s             | each plan's speed per control step          |
    | ``D``        | (n, H, K)   | rad             | each plan's steering angle per control step |
    | ``ref_xy``   | (n, H, 2)   | m               | the reference positions after each step     |
    | ``dt``       | -           | s               | control step                                |
    | ``wheelbase``| -           | m               | ``l``                                       |
    | ``rate``     | -           | rad/s           | steering-rate limit (Ackermann), or None    |
    | ``shared``   | 2 x (H, S)  | m/s, rad        | speeds and steering angles of plans that    |
    |              |             |                 | every row also scores (not copied per row)  |

    ``psi`` (the current steering angle) is read with ``rate`` only. Returns ``(n, S + K)``
    (m^2): the shared plans' costs first (``S = 0`` without ``shared``).
    """
    V = np.ascontiguousarray(V, dtype=np.float64)
    n, H, K = V.shape
    if shared is None:
        TV = TD = np.empty((H, 0))
    else:
        TV, TD = (np.ascontiguousarray(t, dtype=np.float64) for t in shared)
    cost = np.empty((n, TV.shape[1] + K))
    _k_plan_costs(np.ascontiguousarray(start, dtype=np.float64), V,
                  np.ascontiguousarray(D, dtype=np.float64),
                  np.ascontiguousarray(ref_xy, dtype=np.float64), TV, TD, float(dt),
                  float(wheelbase), -1.0 if rate is None else float(rate), cost)
    return cost
