"""Load distribution for redundantly actuated platforms (docs/physics/three-wheel.md TW-6,
docs/physics/skid-steer.md SS-4).

A platform with ``k`` degrees of freedom driven by ``m >= k`` motors obeys
``Q = J^T tau`` (three-wheel paper (34)-(35)): ``J`` (m x k) maps the body twist to the joint
rates (``qdot = J u``, TW-1) and by the principle of virtual power its transpose maps motor
torques to the generalized force. Every ``tau`` with ``J^T tau = Q_d`` produces the same motion;
they differ by an internal force in the null space of ``J^T`` (motors pushing against each other
through the ground).

| function                     | solution                                                      |
|------------------------------|---------------------------------------------------------------|
| :func:`min_norm`             | ``tau = J (J^T J)^-1 Q`` (three-wheel paper (36), first term) |
| :func:`weighted`             | min ``sum (tau_k / tau_max_k)^2``: ``W J (J^T W J)^-1 Q``     |
| :func:`within_limits`        | the same within ``abs(tau_k) <= tau_max_k``; exact            |
| :func:`null_space_projector` | ``P = I - J (J^T J)^-1 J^T`` (paper (36), second term)        |
| :func:`internal_force`       | ``P tau``, the part of ``tau`` that moves nothing             |
| :func:`paper_distribution`   | the paper's ``[I : G^T]`` form, joints S, eq. (35)-(36)       |
| :func:`skid_steer_split`     | SS-4: each side's torque over its two motors                  |

(``W = diag(tau_max^2)``.) All functions are batched over leading axes: ``J`` is ``(..., m,
k)``, ``Q`` ``(..., k)``, ``tau`` ``(..., m)``. Each is one compiled per-state function looped
by a compiled kernel; the controllers call the per-state functions directly.

The exact limit-respecting solution (:func:`within_limits`). In the scaled torques ``s = tau /
tau_max`` the problem is ``min |s|^2`` subject to ``A s = Q`` (``A = J^T diag(tau_max)``) and
``-1 <= s <= 1``. Write ``s = s0 + N z`` with ``s0`` the weighted solution and ``N`` an
orthonormal basis of the null space of ``A``; since ``s0`` is orthogonal to that null space,
``|s|^2 = |s0|^2 + |z|^2``, and the problem becomes the projection of the origin onto the
polytope ``{z : -1 - s0 <= N z <= 1 - s0}`` in ``m - k`` dimensions (3 for ThreeWheel). The
projection lies in the relative interior of exactly one face, whose affine hull is cut out by at
most ``m - k`` independent active constraints; enumerating every such set (233 for ThreeWheel),
projecting the origin onto its affine hull and keeping the shortest candidate that satisfies all
constraints is therefore exact. No feasible candidate means no torque vector within the limits
produces ``Q`` (status ``-1``).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numba import njit

from wheelgym import _numba_cache
from wheelgym import integrators as _integrators
from wheelgym.integrators import kernel_array
from wheelgym.models.kernels import three_wheel as _tw
from wheelgym.models.kernels.three_wheel import solve3

# internal_force_one inlines three_wheel.solve3 (and its integrators.fma)
_numba_cache.guard(__file__, _tw.__file__, _integrators.__file__)

__all__ = [
    "min_norm",
    "weighted",
    "within_limits",
    "null_space_projector",
    "null_space_basis",
    "internal_force",
    "internal_force_one",
    "paper_distribution",
    "independent_joint_force",
    "skid_steer_split",
    "distribute",
    "DISTRIBUTIONS",
    "PAPER_INPUT_JOINTS",
    "STATUS_OK",
    "STATUS_NULL_SPACE",
    "STATUS_INFEASIBLE",
]

#: The three-wheel paper's independent joints S = {drive_1, drive_2, steer_3} (its eq. (7),
#: docs/physics/three-wheel.md TW-2), as indices in motor order.
PAPER_INPUT_JOINTS = (0, 1, 5)

#: Distribution modes accepted by :func:`distribute` and the controllers.
DISTRIBUTIONS = ("min_norm", "weighted", "within_limits")

#: :func:`within_limits` status: the weighted solution already respects the limits.
STATUS_OK = 0
#: :func:`within_limits` status: a null-space (internal-force) addition brought it inside.
STATUS_NULL_SPACE = 1
#: :func:`within_limits` status: no torque vector within the limits produces ``Q``.
STATUS_INFEASIBLE = -1

_FEAS_TOL = 1e-9  # constraint tolerance in scaled torque units (fraction of tau_max)


# ---------------------------------------------------------------------------- small linear algebra
@njit(cache=True)
def _solve_inplace(A, b, n):  # pragma: no cover - compiled
    """Solve ``A x = b`` (n x n, partial pivoting); overwrites A, result in b. False if singular."""
    scale = 0.0
    for i in range(n):
        for j in range(n):
            v = abs(A[i, j])
            if v > scale:
                scale = v
    if scale == 0.0:
        return False
    for c in range(n):
        piv = c
        best = abs(A[c, c])
        for r in range(c + 1, n):
            if abs(A[r, c]) > best:
                best = abs(A[r, c])
                piv = r
        if best <= 1e-13 * scale:
            return False
        if piv != c:
            for j in range(n):
                A[c, j], A[piv, j] = A[piv, j], A[c, j]
            b[c], b[piv] = b[piv], b[c]
        inv = 1.0 / A[c, c]
        for r in range(c + 1, n):
            f = A[r, c] * inv
            if f != 0.0:
                for j in range(c, n):
                    A[r, j] -= f * A[c, j]
                b[r] -= f * b[c]
    for c in range(n - 1, -1, -1):
        acc = b[c]
        for j in range(c + 1, n):
            acc -= A[c, j] * b[j]
        b[c] = acc / A[c, c]
    return True


@njit(cache=True, inline="always")
def _gram(J, w, G):  # pragma: no cover - compiled
    """``G = J^T W J`` (``W = diag(w)``), symmetric, into ``G`` (k x k)."""
    m, k = J.shape
    for a in range(k):
        for b in range(a, k):
            acc = 0.0
            for i in range(m):
                acc += J[i, a] * w[i] * J[i, b]
            G[a, b] = acc
            G[b, a] = acc


@njit(cache=True)
def _wls_one(J, Q, w, out):  # pragma: no cover - compiled
    """``out = W J (J^T W J)^-1 Q``, ``W = diag(w)``: min ``sum tau_k^2 / w_k``, ``J^T tau = Q``.

    One step of iterative refinement brings ``J^T out - Q`` to round-off. Returns False when
    ``J^T W J`` is singular (then ``out`` is zero).
    """
    m, k = J.shape
    G = np.empty((k, k))
    lam = np.empty(k)
    res = np.empty(k)
    for it in range(2):
        _gram(J, w, G)
        if it == 0:
            for a in range(k):
                lam[a] = Q[a]
        else:
            for a in range(k):
                acc = Q[a]
                for i in range(m):
                    acc -= J[i, a] * out[i]
                res[a] = acc
            for a in range(k):
                lam[a] = res[a]
        if not _solve_inplace(G, lam, k):
            for i in range(m):
                out[i] = 0.0
            return False
        for i in range(m):
            acc = 0.0
            for a in range(k):
                acc += J[i, a] * lam[a]
            if it == 0:
                out[i] = w[i] * acc
            else:
                out[i] += w[i] * acc
    return True


@njit(cache=True)
def _projector_one(J, w, P):  # pragma: no cover - compiled
    """``P = I - W J (J^T W J)^-1 J^T`` (orthogonal projector onto null(J^T) when W = I)."""
    m, k = J.shape
    G = np.empty((k, k))
    e = np.empty(k)
    _gram(J, w, G)
    Ginv = np.empty((k, k))
    for c in range(k):
        Gc = G.copy()
        for a in range(k):
            e[a] = 1.0 if a == c else 0.0
        if not _solve_inplace(Gc, e, k):
            return False
        for a in range(k):
            Ginv[a, c] = e[a]
    for i in range(m):
        for j in range(m):
            acc = 0.0
            for a in range(k):
                for b in range(k):
                    acc += J[i, a] * Ginv[a, b] * J[j, b]
            P[i, j] = (1.0 if i == j else 0.0) - w[i] * acc
    return True


@njit(cache=True, inline="always")
def internal_force_one(J, tau, out):  # pragma: no cover - compiled
    """``|P tau|`` with ``P tau = tau - J (J^T J)^-1 J^T tau`` for a three-column ``J``.

    The internal force (TW-6, paper (36)): the one formula behind :func:`internal_force` and
    the environments' ``info["internal_force"]``. ``J`` is read as ``J[i][a]``: an ``(m, 3)``
    array or a tuple of ``m`` row tuples (the environment kernel's rows, no array per row);
    ``J^T J`` is solved by cofactors (``three_wheel.solve3``). Writes ``P tau`` into ``out``
    unless ``out`` is None; a singular ``J^T J`` gives non-finite values.
    """
    m00 = m01 = m02 = m11 = m12 = m22 = 0.0
    f0 = f1 = f2 = 0.0
    for k in range(len(J)):
        j = J[k]
        m00 += j[0] * j[0]
        m01 += j[0] * j[1]
        m02 += j[0] * j[2]
        m11 += j[1] * j[1]
        m12 += j[1] * j[2]
        m22 += j[2] * j[2]
        f0 += j[0] * tau[k]
        f1 += j[1] * tau[k]
        f2 += j[2] * tau[k]
    y0, y1, y2 = solve3((m00, m01, m02, m11, m12, m22), f0, f1, f2)
    s = 0.0
    for k in range(len(J)):
        j = J[k]
        e = tau[k] - (j[0] * y0 + j[1] * y1 + j[2] * y2)
        if out is not None:
            out[k] = e
        s += e * e
    return math.sqrt(s)


@njit(cache=True, inline="always")
def _project_out(v, N, c):  # pragma: no cover - compiled
    """Remove from ``v`` its components along the first ``c`` (orthonormal) columns of ``N``."""
    m = v.shape[0]
    for q in range(c):
        d = 0.0
        for i in range(m):
            d += N[i, q] * v[i]
        for i in range(m):
            v[i] -= d * N[i, q]


@njit(cache=True)
def _null_basis_one(A_T, N):  # pragma: no cover - compiled
    """Orthonormal basis ``N`` (m x (m-k)) of null(A) for ``A_T`` = A^T (m x k) of full rank.

    Gram-Schmidt of the unit vectors after projecting out range(A^T); False on rank loss.
    """
    m, k = A_T.shape
    nd = m - k
    ones = np.ones(m)
    P = np.empty((m, m))
    if not _projector_one(A_T, ones, P):
        return False
    # columns of P span the null space; take them in order of decreasing norm
    used = np.zeros(m, dtype=np.bool_)
    v = np.empty(m)
    for c in range(nd):
        best = -1.0
        bi = -1
        for j in range(m):
            if used[j]:
                continue
            for i in range(m):
                v[i] = P[i, j]
            _project_out(v, N, c)
            nn = 0.0
            for i in range(m):
                nn += v[i] * v[i]
            if nn > best:
                best = nn
                bi = j
        if best <= 1e-20:
            return False
        used[bi] = True
        for i in range(m):
            v[i] = P[i, bi]
        for _rep in range(2):  # re-orthogonalise twice for round-off
            _project_out(v, N, c)
        nn = 0.0
        for i in range(m):
            nn += v[i] * v[i]
        inv = 1.0 / np.sqrt(nn)
        for i in range(m):
            N[i, c] = v[i] * inv
    return True


@njit(cache=True, inline="always")
def _row(N, s0, r, m, nd, crow):  # pragma: no cover - compiled
    """Constraint r of ``C z <= d``: r < m is ``N_r z <= 1 - s0_r``, else ``-N_r z <= 1 + s0_r``."""
    if r < m:
        for q in range(nd):
            crow[q] = N[r, q]
        return 1.0 - s0[r]
    i = r - m
    for q in range(nd):
        crow[q] = -N[i, q]
    return 1.0 + s0[i]


@njit(cache=True, inline="always")
def _try_face(N, s0, idx, n_act, m, nd, C, d, G, mu, z, best_z, best):  # pragma: no cover
    """Project the origin onto ``{C_S z = d_S}``; keep it if feasible and shorter than best."""
    for a in range(n_act):
        d[a] = _row(N, s0, idx[a], m, nd, C[a])
    for a in range(n_act):
        for b in range(n_act):
            acc = 0.0
            for q in range(nd):
                acc += C[a, q] * C[b, q]
            G[a, b] = acc
        mu[a] = d[a]
    if not _solve_inplace(G, mu, n_act):
        return best
    nz = 0.0
    for q in range(nd):
        acc = 0.0
        for a in range(n_act):
            acc += C[a, q] * mu[a]
        z[q] = acc
        nz += acc * acc
    if nz >= best:
        return best
    for i in range(m):  # feasibility: |s0_i + N_i z| <= 1
        acc = s0[i]
        for q in range(nd):
            acc += N[i, q] * z[q]
        if abs(acc) > 1.0 + _FEAS_TOL:
            return best
    for q in range(nd):
        best_z[q] = z[q]
    return nz


@njit(cache=True)
def _limits_one(J, Q, tmax, out):  # pragma: no cover - compiled
    """Exact ``min sum (tau/tau_max)^2`` s.t. ``J^T tau = Q``, ``|tau| <= tau_max``.

    Returns the status (module docstring). When infeasible, ``out`` is the weighted solution
    scaled uniformly into the limits (the generalized force keeps its direction).
    """
    m, k = J.shape
    nd = m - k
    w = np.empty(m)
    for i in range(m):
        w[i] = tmax[i] * tmax[i]
    if not _wls_one(J, Q, w, out):
        return STATUS_INFEASIBLE
    worst = 0.0
    for i in range(m):
        v = abs(out[i]) / tmax[i]
        if v > worst:
            worst = v
    if worst <= 1.0 + _FEAS_TOL:
        return STATUS_OK
    if nd == 0 or nd > 3:
        for i in range(m):
            out[i] /= worst
        return STATUS_INFEASIBLE
    # scaled problem: A^T = diag(tmax) J, s0 = out / tmax
    A_T = np.empty((m, k))
    s0 = np.empty(m)
    for i in range(m):
        s0[i] = out[i] / tmax[i]
        for a in range(k):
            A_T[i, a] = tmax[i] * J[i, a]
    N = np.empty((m, nd))
    if not _null_basis_one(A_T, N):
        for i in range(m):
            out[i] /= worst
        return STATUS_INFEASIBLE
    C = np.empty((3, nd))
    d = np.empty(3)
    G = np.empty((3, 3))
    mu = np.empty(3)
    z = np.empty(nd)
    best_z = np.zeros(nd)
    # every set of at most nd constraints, never both bounds of one motor (one call site of
    # _try_face keeps the compiled code small)
    nc = 2 * m
    sets = np.empty((nc + nc * (nc - 1) // 2 + nc * (nc - 1) * (nc - 2) // 6, 3), dtype=np.int64)
    sizes = np.empty(sets.shape[0], dtype=np.int64)
    cnt = 0
    for a in range(nc):
        sets[cnt, 0] = a
        sizes[cnt] = 1
        cnt += 1
        if nd < 2:
            continue
        for b in range(a + 1, nc):
            if b - a == m:
                continue
            sets[cnt, 0] = a
            sets[cnt, 1] = b
            sizes[cnt] = 2
            cnt += 1
            if nd < 3:
                continue
            for c in range(b + 1, nc):
                if c - a == m or c - b == m:
                    continue
                sets[cnt, 0] = a
                sets[cnt, 1] = b
                sets[cnt, 2] = c
                sizes[cnt] = 3
                cnt += 1
    best = np.inf
    for q in range(cnt):
        best = _try_face(N, s0, sets[q], sizes[q], m, nd, C, d, G, mu, z, best_z, best)
    if best == np.inf:
        for i in range(m):
            out[i] /= worst
        return STATUS_INFEASIBLE
    for i in range(m):
        acc = s0[i]
        for q in range(nd):
            acc += N[i, q] * best_z[q]
        acc = min(1.0, max(-1.0, acc))  # remove the 1e-9 tolerance
        out[i] = tmax[i] * acc
    return STATUS_NULL_SPACE


@njit(cache=True)
def _distribute_one(J, Q, tmax, mode, out):  # pragma: no cover - compiled
    """mode 0 min_norm, 1 weighted, 2 within_limits; returns a status (0 unless mode 2)."""
    m = J.shape[0]
    if mode == 2:
        return _limits_one(J, Q, tmax, out)
    w = np.empty(m)
    for i in range(m):
        w[i] = 1.0 if mode == 0 else tmax[i] * tmax[i]
    if not _wls_one(J, Q, w, out):
        return STATUS_INFEASIBLE
    return STATUS_OK


_ONES: dict[int, np.ndarray] = {}


def _fast(J: Any, Q: Any, tau_max: Any, mode: int) -> tuple[np.ndarray, int] | None:
    """The compiled single-configuration path, or None when the inputs need the general one."""
    if not (type(J) is np.ndarray and type(Q) is np.ndarray and J.ndim == 2 and Q.ndim == 1
            and J.dtype == np.float64 and Q.dtype == np.float64 and J.flags.c_contiguous
            and Q.flags.c_contiguous and J.flags.writeable and Q.flags.writeable):
        return None  # (read-only arrays: numba would compile the kernel again for them)
    m = J.shape[0]
    if tau_max is None:
        T = _ONES.get(m)
        if T is None:
            T = _ONES.setdefault(m, np.ones(m))
    elif (type(tau_max) is np.ndarray and tau_max.shape == (m,) and tau_max.dtype == np.float64
          and tau_max.flags.c_contiguous and tau_max.flags.writeable):
        T = tau_max
    else:
        return None
    if Q.shape[0] != J.shape[1] or J.shape[1] > m:
        return None
    out = np.empty((1, m))
    status = np.empty(1, dtype=np.int64)
    if not _k_distribute(J.reshape(1, m, -1), Q.reshape(1, -1), T.reshape(1, m), mode, out,
                         status):
        return None
    if mode != 2 and status[0] < 0:
        return None
    return out[0], int(status[0])


# ---------------------------------------------------------------------------- batch kernels
@njit(cache=True)
def _k_distribute(J, Q, T, mode, out, status):  # pragma: no cover - compiled
    """False (computing nothing) unless J, Q are finite and T positive and finite."""
    N, m, k = J.shape
    for n in range(N):
        for i in range(m):
            if not (np.isfinite(T[n, i]) and T[n, i] > 0.0):
                return False
            for a in range(k):
                if not np.isfinite(J[n, i, a]):
                    return False
        for a in range(k):
            if not np.isfinite(Q[n, a]):
                return False
    for n in range(N):
        status[n] = _distribute_one(J[n], Q[n], T[n], mode, out[n])
    return True


@njit(cache=True)
def _k_projector(J, P, ok):  # pragma: no cover - compiled
    ones = np.ones(J.shape[1])
    for n in range(J.shape[0]):
        ok[n] = _projector_one(J[n], ones, P[n])


@njit(cache=True)
def _k_internal(J, T, out):  # pragma: no cover - compiled
    for n in range(J.shape[0]):
        internal_force_one(J[n], T[n], out[n])


@njit(cache=True)
def _k_null_basis(J, N, ok):  # pragma: no cover - compiled
    for n in range(J.shape[0]):
        ok[n] = _null_basis_one(J[n], N[n])


@njit(cache=True)
def _k_paper(J, Q, S, Pdep, out, qs, ok):  # pragma: no cover - compiled
    """Three-wheel paper (33)-(36) with independent joints S and dependent joints Pdep."""
    k = S.shape[0]
    m = k + Pdep.shape[0]
    nd = m - k
    for n in range(J.shape[0]):
        Jn = J[n]
        # J_S^T Q_S = Q_u  ->  Q_S (generalized force in independent-joint coordinates, paper (30))
        JS_T = np.empty((k, k))
        for a in range(k):
            for b in range(k):
                JS_T[a, b] = Jn[S[b], a]
        q = Q[n].copy()
        if not _solve_inplace(JS_T, q, k):
            ok[n] = False
            continue
        # [G_a^p] = J_p J_S^-1 (paper (9), (33)): rows solve J_S^T g_j = J_p[j]^T
        Gap = np.empty((nd, k))
        good = True
        for j in range(nd):
            JS_T2 = np.empty((k, k))
            for a in range(k):
                for b in range(k):
                    JS_T2[a, b] = Jn[S[b], a]
            g = np.empty(k)
            for a in range(k):
                g[a] = Jn[Pdep[j], a]
            if not _solve_inplace(JS_T2, g, k):
                good = False
                break
            for a in range(k):
                Gap[j, a] = g[a]
        if not good:
            ok[n] = False
            continue
        # [G] = [I : G_a^p^T] (k x m); min-norm [G]^+ Q_S via [G]^T ([G][G]^T)^-1 (paper (36))
        Gt = np.empty((m, k))  # [G]^T, rows in (S, p) order
        for a in range(k):
            for b in range(k):
                Gt[a, b] = 1.0 if a == b else 0.0
        for j in range(nd):
            for b in range(k):
                Gt[k + j, b] = Gap[j, b]
        ones = np.ones(m)
        sol = np.empty(m)
        ok[n] = _wls_one(Gt, q, ones, sol)
        for a in range(k):
            out[n, S[a]] = sol[a]
            qs[n, a] = q[a]
        for j in range(nd):
            out[n, Pdep[j]] = sol[k + j]


# ---------------------------------------------------------------------------- public API
def _check_JQ(J: Any, Q: Any, check_finite: bool = True
              ) -> tuple[np.ndarray, np.ndarray, tuple[int, ...]]:
    J = np.asarray(J, dtype=np.float64)
    Q = np.asarray(Q, dtype=np.float64)
    if J.ndim < 2:
        raise ValueError(f"J must have shape (..., m, k), got {J.shape}")
    m, k = J.shape[-2:]
    if m < k:
        raise ValueError(f"J must have at least as many rows (motors) as columns, got {J.shape}")
    if Q.ndim < 1 or Q.shape[-1] != k:
        raise ValueError(f"Q must have shape (..., {k}) to match J {J.shape}, got {Q.shape}")
    if check_finite and not (np.all(np.isfinite(J)) and np.all(np.isfinite(Q))):
        raise ValueError("J and Q must be finite")
    lead = np.broadcast_shapes(J.shape[:-2], Q.shape[:-1])
    J2 = kernel_array(np.broadcast_to(J, lead + (m, k)).reshape(-1, m, k))
    Q2 = kernel_array(np.broadcast_to(Q, lead + (k,)).reshape(-1, k))
    return J2, Q2, lead


def _check_tmax(tau_max: Any, m: int, lead: tuple[int, ...]) -> np.ndarray:
    T = np.asarray(tau_max, dtype=np.float64)
    if T.ndim == 0:
        T = np.full(m, float(T))
    if T.shape[-1] != m:
        raise ValueError(f"tau_max must be a scalar or have shape (..., {m}), got {T.shape}")
    if not np.all(np.isfinite(T)) or np.any(T <= 0):
        raise ValueError("tau_max must be positive and finite")
    return kernel_array(np.broadcast_to(T, lead + (m,)).reshape(-1, m))


def _run(J: Any, Q: Any, tau_max: Any, mode: int) -> tuple[np.ndarray, np.ndarray]:
    fast = _fast(J, Q, tau_max, mode)
    if fast is not None:
        return fast[0], np.asarray(fast[1])
    J2, Q2, lead = _check_JQ(J, Q, check_finite=False)  # the kernel checks
    m = J2.shape[1]
    T2 = _check_tmax(1.0 if tau_max is None else tau_max, m, lead)
    out = np.empty((J2.shape[0], m))
    status = np.empty(J2.shape[0], dtype=np.int64)
    if not _k_distribute(J2, Q2, T2, mode, out, status):
        raise ValueError("J and Q must be finite")
    if mode != 2 and np.any(status < 0):
        raise ValueError("J^T W J is singular: J has lost rank (a singular configuration)")
    return out.reshape(lead + (m,)), status.reshape(lead)


def min_norm(J: Any, Q: Any) -> np.ndarray:
    """Minimum-norm torques ``tau = J (J^T J)^-1 Q`` (three-wheel paper (36),
    docs/physics/three-wheel.md TW-6).

    Args:
        J: joint-rate Jacobian ``(..., m, k)`` (``qdot = J u``).
        Q: required generalized force ``(..., k)`` (N, N, N·m for a body twist).

    Returns:
        ``tau`` ``(..., m)`` (N·m) with ``J^T tau = Q``, orthogonal to the null space of ``J^T``.
    """
    return _run(J, Q, None, 0)[0]


def weighted(J: Any, Q: Any, tau_max: Any) -> np.ndarray:
    """Torques minimising ``sum (tau_k / tau_max_k)^2`` with ``J^T tau = Q``
    (docs/physics/three-wheel.md TW-6).

    ``tau = W J (J^T W J)^-1 Q`` with ``W = diag(tau_max^2)``: every motor works at a share of
    its own limit. With ``tau_max`` equal to the normal loads this is the load-proportional split.

    Args:
        J: ``(..., m, k)``.  Q: ``(..., k)``.  tau_max: scalar or ``(..., m)`` (N·m), positive.
    """
    return _run(J, Q, tau_max, 1)[0]


def within_limits(J: Any, Q: Any, tau_max: Any) -> tuple[np.ndarray, np.ndarray]:
    """The limit-respecting distribution (exact; see the module docstring).

    Minimises ``sum (tau_k / tau_max_k)^2`` over ``J^T tau = Q`` and ``|tau_k| <= tau_max_k``.

    Returns:
        ``(tau, status)``: ``tau`` ``(..., m)``; ``status`` ``(...,)`` int: ``STATUS_OK`` (0, the
        weighted solution fits), ``STATUS_NULL_SPACE`` (1, an internal force was added to fit),
        ``STATUS_INFEASIBLE`` (-1, no solution within the limits exists; ``tau`` is then the
        weighted solution scaled uniformly into the limits, so ``J^T tau`` is parallel to ``Q``).
    """
    return _run(J, Q, tau_max, 2)


def distribute(J: Any, Q: Any, mode: str = "min_norm", tau_max: Any = None
               ) -> tuple[np.ndarray, np.ndarray]:
    """Dispatch to one of :data:`DISTRIBUTIONS`; returns ``(tau, status)``."""
    if mode not in DISTRIBUTIONS:
        raise ValueError(f"mode must be one of {DISTRIBUTIONS}, got {mode!r}")
    if mode != "min_norm" and tau_max is None:
        raise ValueError(f"mode {mode!r} needs tau_max")
    return _run(J, Q, tau_max, DISTRIBUTIONS.index(mode))


def null_space_projector(J: Any) -> np.ndarray:
    """``P = I - J (J^T J)^-1 J^T`` ``(..., m, m)``: projects onto null(J^T) (paper (36))."""
    J2, _, lead = _check_JQ(J, np.zeros(np.shape(J)[-1]))
    m = J2.shape[1]
    P = np.empty((J2.shape[0], m, m))
    ok = np.empty(J2.shape[0], dtype=np.bool_)
    _k_projector(J2, P, ok)
    if not np.all(ok):
        raise ValueError("J^T J is singular: J has lost rank (a singular configuration)")
    return P.reshape(lead + (m, m))


def null_space_basis(J: Any) -> np.ndarray:
    """Orthonormal basis ``(..., m, m - k)`` of null(J^T): the internal-force directions."""
    J2, _, lead = _check_JQ(J, np.zeros(np.shape(J)[-1]))
    m, k = J2.shape[1:]
    N = np.empty((J2.shape[0], m, m - k))
    ok = np.empty(J2.shape[0], dtype=np.bool_)
    _k_null_basis(J2, N, ok)
    if not np.all(ok):
        raise ValueError("J has lost rank (a singular configuration)")
    return N.reshape(lead + (m, m - k))


def internal_force(J: Any, tau: Any) -> np.ndarray:
    """The null-space component ``P tau`` of a torque vector (``(..., m)``, N·m).

    It produces no generalized force (``J^T P tau = 0``) and so no motion; ``tau - P tau`` is
    the minimum-norm torque producing the same ``J^T tau``. For three columns (a planar body
    twist) it is :func:`internal_force_one`, the environments' formula; otherwise ``P`` of
    :func:`null_space_projector` applied to ``tau``.
    """
    tau = np.asarray(tau, dtype=np.float64)
    if not np.all(np.isfinite(tau)):
        raise ValueError("tau must be finite")
    if np.ndim(J) < 2 or np.shape(J)[-1] != 3:
        P = null_space_projector(J)
        if tau.shape[-1:] != P.shape[-1:]:
            raise ValueError(f"tau must have shape (..., {P.shape[-1]}), got {tau.shape}")
        return np.einsum("...ij,...j->...i", P, tau)
    J2, _, j_lead = _check_JQ(J, np.zeros(3))
    m = J2.shape[1]
    if tau.shape[-1:] != (m,):
        raise ValueError(f"tau must have shape (..., {m}), got {tau.shape}")
    lead = np.broadcast_shapes(j_lead, tau.shape[:-1])
    J3 = kernel_array(np.broadcast_to(J2.reshape(j_lead + (m, 3)), lead + (m, 3))
                      .reshape(-1, m, 3))
    T = kernel_array(np.broadcast_to(tau, lead + (m,)).reshape(-1, m))
    out = np.empty_like(T)
    _k_internal(J3, T, out)
    if not np.all(np.isfinite(out)):
        raise ValueError("J^T J is singular: J has lost rank (a singular configuration)")
    return out.reshape(lead + (m,))


def _check_S(S: Any, m: int, k: int) -> tuple[np.ndarray, np.ndarray]:
    S = np.asarray(S)
    if (S.shape != (k,) or not np.issubdtype(S.dtype, np.integer) or len(set(S.tolist())) != k
            or S.min() < 0 or S.max() >= m):
        raise ValueError(f"S must be {k} distinct motor indices in [0, {m}), got {S!r}")
    Pdep = np.array([i for i in range(m) if i not in set(S.tolist())], dtype=np.int64)
    return np.ascontiguousarray(S, dtype=np.int64), Pdep


def paper_distribution(J: Any, Q: Any, S: Any = PAPER_INPUT_JOINTS
                       ) -> tuple[np.ndarray, np.ndarray]:
    """The three-wheel paper's load distribution in independent-joint coordinates, eq. (33)-(36).

    With independent joints S (paper: drive_1, drive_2, steer_3) and dependent joints p,
    ``qdot_p = [G_a^p] qdot_S`` with ``[G_a^p] = J_p J_S^-1`` (paper (9), (33)). The generalized
    force in S-coordinates is ``Q_S = J_S^-T Q`` (the torques of paper (30), its Fig. 4e), and
    ``[G] [tau_S; tau_p] = Q_S`` with ``[G] = [I : [G_a^p]^T]`` (paper (35)); the minimum-norm
    solution ``[G]^T ([G][G]^T)^-1 Q_S`` (paper (36)) equals :func:`min_norm`
    (docs/physics/three-wheel.md TW-6).

    Args:
        J: ``(..., m, k)``; Q: generalized force in body-twist coordinates ``(..., k)``;
        S: k motor indices.

    Returns:
        ``(tau, Q_S)``: torques in motor order ``(..., m)``, and ``Q_S`` ``(..., k)``.
    """
    J2, Q2, lead = _check_JQ(J, Q)
    m, k = J2.shape[1:]
    S_, Pdep = _check_S(S, m, k)
    out = np.empty((J2.shape[0], m))
    qs = np.empty((J2.shape[0], k))
    ok = np.empty(J2.shape[0], dtype=np.bool_)
    _k_paper(J2, Q2, S_, Pdep, out, qs, ok)
    if not np.all(ok):
        raise ValueError(f"J_S is singular for S = {tuple(S_)}: these joints cannot be inputs here")
    return out.reshape(lead + (m,)), qs.reshape(lead + (k,))


def independent_joint_force(J: Any, Q: Any, S: Any = PAPER_INPUT_JOINTS) -> np.ndarray:
    """``Q_S = J_S^-T Q``: the torques the independent joints S alone would need (paper (30))."""
    return paper_distribution(J, Q, S)[1]


def skid_steer_split(tau_sides: Any, loads: Any = None) -> np.ndarray:
    """Split each side's torque over its two motors (docs/physics/skid-steer.md SS-4).

    Args:
        tau_sides: ``(..., 2)`` = ``(tau_L, tau_R)`` (N·m).
        loads: ``None`` for equal halves (the minimum-norm split), or the four wheels' normal
            loads ``(..., 4)`` (N) to split in proportion to them (equal friction utilisation).

    Returns:
        ``(..., 4)`` motor torques in SS order ``[tau_1 RL, tau_2 FL, tau_3 FR, tau_4 RR]``.
    """
    t = np.asarray(tau_sides, dtype=np.float64)
    if t.ndim < 1 or t.shape[-1] != 2:
        raise ValueError(f"tau_sides must have shape (..., 2), got {t.shape}")
    if not np.all(np.isfinite(t)):
        raise ValueError("tau_sides must be finite")
    if loads is None:
        f = np.array([0.5, 0.5, 0.5, 0.5])
    else:
        n = np.asarray(loads, dtype=np.float64)
        if n.shape[-1:] != (4,) or not np.all(np.isfinite(n)) or np.any(n <= 0):
            raise ValueError(f"loads must be positive finite with shape (..., 4), got {n.shape}")
        f = np.stack([n[..., 0] / (n[..., 0] + n[..., 1]), n[..., 1] / (n[..., 0] + n[..., 1]),
                      n[..., 2] / (n[..., 2] + n[..., 3]), n[..., 3] / (n[..., 2] + n[..., 3])],
                     axis=-1)
    return t[..., [0, 0, 1, 1]] * f
