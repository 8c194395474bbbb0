"""Fixed-step integration (physics.md section 1).

Two entry points share one algorithm, the classic four-stage Runge-Kutta method
(three-wheel paper 3.3):

* :func:`rk4_inplace` is the compiled body that every model's kernels inline: it advances one
  state ``n`` substeps of length ``h`` with the input held constant, calling the model's
  per-state derivative ``f(x, u, p, out)``.
* :func:`rk4` is the same scheme for any Python callable ``f(x, u) -> xdot`` on arrays; the
  tests and validation use it for augmented systems (energy integrals, reference formulations).
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from numba import njit

__all__ = ["rk4", "rk4_inplace", "all_finite", "n_substeps"]


@njit(cache=True, inline="always")
def rk4_inplace(f, x, u, p, h, n, work):  # pragma: no cover - compiled
    """Advance ``x`` in place by ``n`` RK4 steps of length ``h`` (``u`` held constant).

    ``work`` is scratch of shape ``(5, len(x))``. ``f(x, u, p, out)`` writes the derivative.
    """
    m = x.shape[0]
    k1 = work[0]
    k2 = work[1]
    k3 = work[2]
    k4 = work[3]
    tmp = work[4]
    half = 0.5 * h
    sixth = h / 6.0
    for _ in range(n):
        f(x, u, p, k1)
        for j in range(m):
            tmp[j] = x[j] + half * k1[j]
        f(tmp, u, p, k2)
        for j in range(m):
            tmp[j] = x[j] + half * k2[j]
        f(tmp, u, p, k3)
        for j in range(m):
            tmp[j] = x[j] + h * k3[j]
        f(tmp, u, p, k4)
        for j in range(m):
            x[j] += sixth * (k1[j] + 2.0 * k2[j] + 2.0 * k3[j] + k4[j])


@njit(cache=True, inline="always")
def all_finite(a):  # pragma: no cover - compiled
    """True when every entry of the 2-D array ``a`` is finite."""
    for i in range(a.shape[0]):
        for j in range(a.shape[1]):
            if not np.isfinite(a[i, j]):
                return False
    return True


def rk4(
    f: Callable[[np.ndarray, np.ndarray], np.ndarray],
    x: np.ndarray,
    u: np.ndarray,
    dt: float,
    n_substeps: int = 1,
) -> np.ndarray:
    """Classic RK4 over ``n_substeps`` substeps of ``dt / n_substeps`` with ``u`` held constant.

    Args:
        f: derivative ``f(x, u) -> xdot`` (any leading batch shape).
        x: state, shape ``(..., n)``.
        u: input, broadcastable against ``f``'s expectations.
        dt: total time to advance (s).
        n_substeps: number of RK4 substeps.

    Returns:
        The state after ``dt``; a new array.
    """
    n = check_substeps(n_substeps)
    h = float(dt) / n
    x = np.array(x, dtype=np.float64, copy=True)
    for _ in range(n):
        k1 = f(x, u)
        k2 = f(x + 0.5 * h * k1, u)
        k3 = f(x + 0.5 * h * k2, u)
        k4 = f(x + h * k3, u)
        x = x + (h / 6.0) * (k1 + 2.0 * k2 + 2.0 * k3 + k4)
    return x


def check_substeps(n_substeps: int) -> int:
    """Validate a substep count (a positive integer) and return it as ``int``."""
    if isinstance(n_substeps, bool) or not isinstance(n_substeps, (int, np.integer)):
        raise TypeError(f"n_substeps must be a positive int, got {type(n_substeps).__name__}")
    if n_substeps < 1:
        raise ValueError(f"n_substeps must be >= 1, got {n_substeps}")
    return int(n_substeps)


def n_substeps(ctrl_dt: float, sim_dt: float) -> int:
    """Number of physics substeps in one control step (physics.md section 1).

    Raises:
        ValueError: if either step is not a positive finite number, or if ``ctrl_dt`` is not a
            whole multiple of ``sim_dt`` (to 1e-9 relative).
    """
    for name, value in (("ctrl_dt", ctrl_dt), ("sim_dt", sim_dt)):
        if not np.isfinite(value) or value <= 0:
            raise ValueError(f"{name} must be a positive finite number of seconds, got {value!r}")
    ratio = ctrl_dt / sim_dt
    n = int(round(ratio))
    if n < 1 or abs(ratio - n) > 1e-9 * max(1.0, ratio):
        raise ValueError(
            f"ctrl_dt ({ctrl_dt}) must be a whole multiple of sim_dt ({sim_dt}); "
            f"the ratio is {ratio:.6g}"
        )
    return n
