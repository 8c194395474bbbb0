"""Fixed-step integration (docs/physics/conventions.md).

Two entry points share one algorithm, the classic four-stage Runge-Kutta method
(three-wheel paper 3.3):

* :func:`rk4_inplace` is the compiled body that every model's kernels inline: it advances one
  state ``n`` substeps of length ``h`` with the input held constant, calling the model's
  per-state derivative ``f(x, u, p, out)``.
* :func:`rk4_block` is the same arithmetic for a block of up to :data:`LANES` robots held in
  a local array with the robots on the last axis, for a derivative written as a tuple
  function ``ft(x, u, p) -> xdot`` without branches (ThreeWheel): the compiler then evaluates
  four robots per instruction (AVX2), 4.2x faster per robot than a row at a time, and each
  robot still gets the bits of the one-state arithmetic (lanes never mix).
* :func:`llvm_inline` marks the compiled pieces of the models (the derivatives and what
  they call): compiled once each, inlined by LLVM into every kernel that calls them (numba's
  ``inline="always"``, which inlines in numba's own IR at every call site, stays only on
  bodies that take a function argument, such as the RK4 bodies here).
* :func:`entry_point` is a kernel's compiled entry point for fixed argument types (calls
  that skip numba's type resolution, ~0.2 us each; the single env's step).
* :func:`rk4` is the same scheme for any Python callable ``f(x, u) -> xdot`` on arrays; the
  tests and validation use it for augmented systems (energy integrals, reference formulations).

Single-state kernels (the fast path of :meth:`wheelgym.models.Model.step`) have the one
signature :data:`STEP1_SIG` / :data:`DERIV1_SIG` each (any other argument types raise
``TypeError``), compiled on their first call (:func:`first_call`), and report problems through
the ``STATUS_*`` codes below (checked inside the kernel, so a valid call costs no Python-side
scan).
"""

from __future__ import annotations

import dataclasses
import math
import sys
import types as types_
from collections.abc import Callable
from typing import Any

import numpy as np
from llvmlite import ir
from numba import njit, prange, typeof, types
from numba.extending import intrinsic, overload

__all__ = [
    "rk4",
    "rk4_inplace",
    "rk4_power",
    "rk4_block",
    "fma",
    "block_rows",
    "LANES",
    "all_finite",
    "check_one",
    "finite_status",
    "n_substeps",
    "check_substeps",
    "STEP1_SIG",
    "DERIV1_SIG",
    "ModelKernels",
    "model_kernels",
    "first_call",
    "llvm_inline",
    "entry_point",
    "kernel_array",
]

#: ``_k_step1(x, u, p, dt, n) -> status``: advance the 1-D state ``x`` in place.
STEP1_SIG = "int64(float64[::1], float64[::1], float64[::1], float64, int64)"
#: ``_k_deriv1(x, u, p, out) -> status``: derivative of one state into ``out``.
DERIV1_SIG = "int64(float64[::1], float64[::1], float64[::1], float64[::1])"

# Status codes of the single-state kernels (0: success).
STATUS_OK = 0
STATUS_X_SHAPE = 1
STATUS_U_SHAPE = 2
STATUS_X_NONFINITE = 3
STATUS_U_NONFINITE = 4
STATUS_BAD_DT = 5
STATUS_BAD_N = 6
STATUS_DIVERGED = 7


def llvm_inline(fn=None, *, cache: bool = True):
    """Compile ``fn`` as a piece that LLVM inlines into every caller: ``njit(cache=True,
    forceinline=True, error_model="numpy")``.

    numba's own ``inline="always"`` inlines a function in numba's IR, before type inference,
    at every call site, re-running the untyped passes for each (nested: an RK4 stage inlines
    the derivative, which inlines the pieces), and that was most of the compile time of the
    models (ThreeWheel's derivative: 83% in the ``inline_inlinables`` pass). A piece decorated
    here is compiled once per signature as an ordinary function whose LLVM function carries
    the ``alwaysinline`` attribute (numba's ``forceinline`` option); numba links its module
    into the caller's and LLVM's module inliner inlines it at every call during the caller's
    final optimisation, before the loop and SLP vectorisers, so the machine code is that of
    the inlined source (same bits; the block kernels still vectorise) for a fraction of the
    compile.

    ``error_model="numpy"``: a division by zero gives inf/NaN instead of raising, so no
    exception branch enters the vectorised loops of the block kernels (and one compiled copy
    serves callers of either error model; the callers check finiteness).

    The piece's arguments must not be functions (a dispatcher in a signature pickles with a
    per-process id, so its cache entry would never load): pieces that take a function stay
    ``inline="always"``. Its cache entry lives next to its own file, and a kernel's cached
    object embeds the piece's code, so the kernel's module lists that file in its
    ``_numba_cache.guard`` as before. ``cache=False``: no disk cache (tests).
    """
    deco = njit(cache=cache, forceinline=True, error_model="numpy")
    return deco if fn is None else deco(fn)


@intrinsic
def fma(typingctx, a, b, c):
    """``a * b + c`` with one rounding (LLVM's ``llvm.fma``; one instruction on x86-64 CPUs
    with FMA, a libm call elsewhere: the same bits either way). Compiled code only.

    Written out where it is wanted rather than left to the compiler (numba's ``fastmath``
    ``contract``), which fuses differently in vectorised and scalar loops: explicit fusions
    give every row the same bits in every batch size."""
    if not all(isinstance(t, (types.Float, types.Integer)) for t in (a, b, c)):
        return None
    f64 = types.float64

    def codegen(context, builder, sig, args):
        xs = [context.cast(builder, v, t, f64) for v, t in zip(args, sig.args, strict=True)]
        d = ir.DoubleType()
        fn = builder.module.declare_intrinsic("llvm.fma", [d], ir.FunctionType(d, [d, d, d]))
        return builder.call(fn, xs)

    return f64(a, b, c), codegen


@njit(cache=True, inline="always")
def no_power(x, k, u, p):  # pragma: no cover - compiled
    """Power function of :func:`rk4_power` when no work is integrated."""
    return 0.0


@njit(cache=True, inline="always")
def rk4_power(f, pw, x, u, p, h, n, work):  # pragma: no cover - compiled
    """Advance ``x`` in place by ``n`` RK4 steps of length ``h`` (``u`` held constant) and
    return the RK4 integral of the power ``pw(x, k, u, p)`` on the same stages (the motor
    work of the environments: RK4 of the state augmented with ``E' = u . qdot``, exact to the
    integrator's order).

    ``work`` is scratch of shape ``(5, len(x))``. ``f(x, u, p, out)`` writes the derivative;
    ``pw`` gets each stage's state and derivative ``k``, so a model whose derivative holds its
    joint rates reads them there instead of recomputing them.
    """
    m = x.shape[0]
    k1 = work[0]
    k2 = work[1]
    k3 = work[2]
    k4 = work[3]
    tmp = work[4]
    half = 0.5 * h
    sixth = h / 6.0
    acc = 0.0
    for _ in range(n):
        f(x, u, p, k1)
        e1 = pw(x, k1, u, p)
        for j in range(m):
            tmp[j] = fma(half, k1[j], x[j])
        f(tmp, u, p, k2)
        e2 = pw(tmp, k2, u, p)
        for j in range(m):
            tmp[j] = fma(half, k2[j], x[j])
        f(tmp, u, p, k3)
        e3 = pw(tmp, k3, u, p)
        for j in range(m):
            tmp[j] = fma(h, k3[j], x[j])
        f(tmp, u, p, k4)
        e4 = pw(tmp, k4, u, p)
        for j in range(m):
            x[j] = fma(sixth, k1[j] + 2.0 * k2[j] + 2.0 * k3[j] + k4[j], x[j])
        acc = fma(sixth, e1 + 2.0 * e2 + 2.0 * e3 + e4, acc)
    return acc


@njit(cache=True, inline="always")
def rk4_inplace(f, x, u, p, h, n, work):  # pragma: no cover - compiled
    """Advance ``x`` in place by ``n`` RK4 steps of length ``h`` (``u`` held constant):
    :func:`rk4_power` without a power. ``work`` is scratch of shape ``(5, len(x))``;
    ``f(x, u, p, out)`` writes the derivative."""
    rk4_power(f, no_power, x, u, p, h, n, work)


# ---------------------------------------------------------------------------- blocks of robots
#: Robots per block of :func:`rk4_block` (four AVX2 vectors of doubles; 16 measured 2% faster
#: than 8 in the ThreeWheel vector env at N = 1024).
LANES = 16


def _generated(args: str, lines: list[str]):
    """Compile the source of a small generated implementation (``fma`` in scope): loops over
    a tuple unrolled, so that the compiled code indexes it by constants (a tuple indexed by a
    loop variable becomes a switch, which stops vectorisation)."""
    scope: dict = {"fma": fma}
    body = "\n".join(f"    {ln}" for ln in lines) or "    pass"
    exec(f"def impl({args}):\n{body}\n", scope)
    return scope["impl"]


def _n(t) -> int:
    return len(t.types) if isinstance(t, types.BaseTuple) else 0


def col(S, o, l, n):  # noqa: E741 - l is the lane
    """``(S[o, l], ..., S[o + n - 1, l])`` as a tuple; ``n`` a literal int."""
    return tuple(S[o + j, l] for j in range(n))


@overload(col, inline="always", prefer_literal=True)
def _col(S, o, l, n):  # noqa: E741
    k = n.literal_value if isinstance(n, types.IntegerLiteral) else 0
    return _generated("S, o, l, n", ["return (" + "".join(f"S[o + {j}, l], " for j in range(k))
                                     + ")"])


def put(S, o, l, t):  # noqa: E741
    """``S[o + j, l] = t[j]`` for each entry of the tuple ``t``."""
    for j, v in enumerate(t):
        S[o + j, l] = v


@overload(put, inline="always")
def _put(S, o, l, t):  # noqa: E741
    return _generated("S, o, l, t", [f"S[o + {j}, l] = t[{j}]" for j in range(_n(t))])


def put_axpy(S, o, xo, l, c, t):  # noqa: E741
    """``S[o + j, l] = S[xo + j, l] + c * t[j]`` (fused) for each entry of the tuple ``t``."""
    for j, v in enumerate(t):
        S[o + j, l] = S[xo + j, l] + c * v


@overload(put_axpy, inline="always")
def _put_axpy(S, o, xo, l, c, t):  # noqa: E741
    return _generated("S, o, xo, l, c, t",
                      [f"S[o + {j}, l] = fma(c, t[{j}], S[xo + {j}, l])" for j in range(_n(t))])


def put_rk4(S, xo, k1, k2, k3, l, c, t):  # noqa: E741
    """``S[xo + j, l] += c * (k1_j + 2 k2_j + 2 k3_j + t[j])`` (fused), rk4_power's update."""
    for j, v in enumerate(t):
        S[xo + j, l] += c * (S[k1 + j, l] + 2.0 * S[k2 + j, l] + 2.0 * S[k3 + j, l] + v)


@overload(put_rk4, inline="always")
def _put_rk4(S, xo, k1, k2, k3, l, c, t):  # noqa: E741
    return _generated("S, xo, k1, k2, k3, l, c, t", [
        f"S[xo + {j}, l] = fma(c, S[k1 + {j}, l] + 2.0 * S[k2 + {j}, l] + 2.0 * S[k3 + {j}, l] "
        f"+ t[{j}], S[xo + {j}, l])" for j in range(_n(t))])


@njit(cache=True, inline="always")
def block_rows(nx, m, npar):  # pragma: no cover - compiled
    """Rows of the block array of :func:`rk4_block`: state, input, parameters, stage state,
    three stage derivatives, and four power slots (the work integral and e1..e3)."""
    return 5 * nx + m + npar + 4


@njit(cache=True, inline="always")
def _stage(ft, pw, S, nl, xo, ko, eo, c, nx, m, npar):  # pragma: no cover - compiled
    """One of RK4's first three stages of :func:`rk4_block` over the robots of ``S``: the
    derivative ``k`` at the state in rows ``xo..`` into rows ``ko..``, its power into row
    ``eo``, and the next stage state ``x + c k`` (``x`` in rows ``0..``) into the stage rows.
    Inlined with constant offsets, so each call stays its own vectorised loop."""
    t0 = nx + m + npar
    for l in range(nl):  # noqa: E741
        u = col(S, nx, l, m)
        p = col(S, nx + m, l, npar)
        x = col(S, xo, l, nx)
        k = ft(x, u, p)
        S[eo, l] = pw(x, k, u, p)
        put(S, ko, l, k)
        put_axpy(S, t0, 0, l, c, k)


@njit(cache=True, inline="always")
def rk4_block(ft, pw, S, nl, nx, m, npar, h, n):  # pragma: no cover - compiled
    """Advance the ``nl <= LANES`` robots of block ``S`` by ``n`` RK4 steps of length ``h``.

    ``S`` is ``(block_rows(nx, m, npar), LANES)`` with robot ``l`` in column ``l``: rows
    ``[0, nx)`` the state (advanced in place), ``[nx, nx + m)`` the input (held), the next
    ``npar`` the parameters, then scratch; row ``5 nx + m + npar`` accumulates the RK4 integral
    of ``pw(x, xdot, u, p)`` on the same stages (the motor work). ``ft(x, u, p)`` returns the
    derivative as a tuple; ``nx``, ``m``, ``npar`` must be literal ints.

    One loop over the robots per stage, every row offset a constant: the compiler sees that
    the robots never overlap and vectorises each loop (with a branch-free ``ft``). The
    arithmetic is :func:`rk4_inplace`'s, so each robot gets the one-state bits.
    """
    u0 = nx
    p0 = nx + m
    t0 = p0 + npar
    k1 = t0 + nx
    k2 = k1 + nx
    k3 = k2 + nx
    e0 = k3 + nx
    half = 0.5 * h
    sixth = h / 6.0
    for _ in range(n):
        # k_s into its rows and the next stage state t = x + c k_s; stage 1 reads x itself
        _stage(ft, pw, S, nl, 0, k1, e0 + 1, half, nx, m, npar)
        _stage(ft, pw, S, nl, t0, k2, e0 + 2, half, nx, m, npar)
        _stage(ft, pw, S, nl, t0, k3, e0 + 3, h, nx, m, npar)
        for l in range(nl):  # noqa: E741
            u = col(S, u0, l, m)
            p = col(S, p0, l, npar)
            x = col(S, t0, l, nx)
            k = ft(x, u, p)
            e4 = pw(x, k, u, p)
            put_rk4(S, 0, k1, k2, k3, l, sixth, k)
            S[e0, l] = fma(sixth, S[e0 + 1, l] + 2.0 * S[e0 + 2, l] + 2.0 * S[e0 + 3, l] + e4,
                           S[e0, l])


@njit(cache=True, inline="always")
def rk4_rows(ft, pw, X, U, P, h, n, out, work, b0, nx, m, npar):  # pragma: no cover - compiled
    """Rows ``b0 .. b0 + LANES`` (or to the end) through one :func:`rk4_block`: ``out[i]`` the
    state of ``X[i]`` after ``n`` steps of ``h`` under ``U[i, :m]`` with parameters ``P[i]``
    (``P[0]`` for every row when ``P`` has one row), ``work[i]`` the integral of ``pw``."""
    nl = min(LANES, X.shape[0] - b0)
    S = np.empty((block_rows(nx, m, npar), LANES))
    e0 = 5 * nx + m + npar
    shared = P.shape[0] == 1
    for l in range(nl):  # noqa: E741
        i = b0 + l
        r = 0 if shared else i
        for j in range(nx):
            S[j, l] = X[i, j]
        for j in range(m):
            S[nx + j, l] = U[i, j]
        for j in range(npar):
            S[nx + m + j, l] = P[r, j]
        S[e0, l] = 0.0
    rk4_block(ft, pw, S, nl, nx, m, npar, h, n)
    for l in range(nl):  # noqa: E741
        for j in range(nx):
            out[b0 + l, j] = S[j, l]
        work[b0 + l] = S[e0, l]


def kernel_array(a: Any, dtype: Any = np.float64) -> np.ndarray:
    """``a`` as a C-contiguous, writable array for a compiled kernel.

    numba types a read-only array (a ``np.broadcast_to`` view, a frozen array) apart from a
    writable one and compiles a kernel once more for it (seconds for a model's step); the
    environments pass writable arrays, so a read-only one is copied here."""
    a = np.ascontiguousarray(a, dtype=dtype)
    return a if a.flags.writeable else a.copy()


@njit(cache=True, inline="always")
def all_finite(a):  # pragma: no cover - compiled
    """True when every entry of the 2-D array ``a`` is finite."""
    for i in range(a.shape[0]):
        for j in range(a.shape[1]):
            if not np.isfinite(a[i, j]):
                return False
    return True


@njit(cache=True, inline="always")
def check_one(x, u, nx, nu):  # pragma: no cover - compiled
    """Status code for one state ``x`` (length ``nx``) and input ``u`` (length ``nu``)."""
    if x.shape[0] != nx:
        return STATUS_X_SHAPE
    if u.shape[0] != nu:
        return STATUS_U_SHAPE
    for j in range(nx):
        if not math.isfinite(x[j]):
            return STATUS_X_NONFINITE
    for j in range(nu):
        if not math.isfinite(u[j]):
            return STATUS_U_NONFINITE
    return STATUS_OK


@njit(cache=True, inline="always")
def check_step_args(dt, n):  # pragma: no cover - compiled
    """Status code for a step length ``dt`` (positive, finite) and substep count ``n`` (>= 1)."""
    if not (dt > 0.0 and math.isfinite(dt)):
        return STATUS_BAD_DT
    if n < 1:
        return STATUS_BAD_N
    return STATUS_OK


@njit(cache=True, inline="always")
def finite_status(x):  # pragma: no cover - compiled
    """``STATUS_OK`` when the 1-D result ``x`` is finite, else ``STATUS_DIVERGED``."""
    for j in range(x.shape[0]):
        if not math.isfinite(x[j]):
            return STATUS_DIVERGED
    return STATUS_OK


# ---------------------------------------------------------------------------- model kernels
# The batched kernels of a model (``Model._k_deriv`` ...) are the same bodies for every model
# but for the compiled pieces they call. Each body below is written once, reading those pieces
# from the global slots ``DERIV_ONE`` (``f(x, u, p, out)``), ``DERIV_BLOCK`` (the branch-free
# tuple derivative of rk4_block), ``POWER`` (its motor power), ``STATE_DIM(p)`` and ``NX``
# (the state size), ``NU``, ``NP`` and ``BLOCK`` (the block step); :func:`model_kernels`
# copies each body into the model's kernel module with the slots bound to that model's
# pieces. The slots are globals, not closure variables: numba keys a cached kernel on its code
# and closure contents (a dispatcher in a closure pickles with a fresh uuid in every process,
# so a closure kernel would never load from the cache), and a copy filed under the kernel
# module's own file and name gets its own cache entry there, dropped by that module's
# ``_numba_cache.guard`` like its other kernels. (A compile error in a copy reports the line
# numbers of the body here against the kernel module's file name.)
DERIV_ONE: Any = None
DERIV_BLOCK: Any = None
POWER: Any = None
STATE_DIM: Any = None
BLOCK: Any = None
NX = 0
NU = 0
NP = 0


def _k_deriv(X, U, p, out):  # pragma: no cover - compiled per model
    for i in range(X.shape[0]):
        DERIV_ONE(X[i], U[i], p, out[i])


def _k_deriv1(x, u, p, out):  # pragma: no cover - compiled per model
    """Derivative of one state into ``out``; a ``STATUS_*`` code."""
    status = check_one(x, u, STATE_DIM(p), NU)
    if status == 0:
        DERIV_ONE(x, u, p, out)
    return status


def _k_step1(x, u, p, dt, n):  # pragma: no cover - compiled per model
    """Advance one state ``x`` in place; a ``STATUS_*`` code."""
    nx = STATE_DIM(p)
    status = check_one(x, u, nx, NU)
    if status == 0:
        status = check_step_args(dt, n)
    if status != 0:
        return status
    work = np.empty((5, nx))
    rk4_inplace(DERIV_ONE, x, u, p, dt / n, n, work)
    return finite_status(x)


def _k_step_rows(X, U, p, h, n, out):  # pragma: no cover - compiled per model
    if not (all_finite(X) and all_finite(U)):
        return False
    work = np.empty((5, X.shape[1]))
    for i in range(X.shape[0]):
        out[i] = X[i]
        rk4_inplace(DERIV_ONE, out[i], U[i], p, h, n, work)
    return True


def _k_step_rows_par(X, U, p, h, n, out):  # pragma: no cover - compiled per model
    if not (all_finite(X) and all_finite(U)):
        return False
    for i in prange(X.shape[0]):
        work = np.empty((5, X.shape[1]))
        out[i] = X[i]
        rk4_inplace(DERIV_ONE, out[i], U[i], p, h, n, work)
    return True


def _k_block(X, U, P, h, n, out, work, b0):  # pragma: no cover - compiled per model
    """Rows ``b0 .. b0 + LANES`` as one vectorised block (:func:`rk4_rows`): ``out`` the new
    states, ``work`` the motor work (J); ``U`` is read in its first ``NU`` columns, ``P`` has
    one row (shared) or one per row. Compiled with NumPy's error model: no exception branch
    inside the vectorised loops (a division by zero gives inf/NaN, which the callers'
    finiteness checks catch)."""
    rk4_rows(DERIV_BLOCK, POWER, X, U, P, h, n, out, work, b0, NX, NU, NP)


def _k_step_blocks(X, U, p, h, n, out):  # pragma: no cover - compiled per model
    if not (all_finite(X) and all_finite(U)):
        return False
    P = p.reshape((1, p.shape[0]))
    work = np.empty(X.shape[0])
    for b0 in range(0, X.shape[0], LANES):
        BLOCK(X, U, P, h, n, out, work, b0)
    return True


def _k_step_blocks_par(X, U, p, h, n, out):  # pragma: no cover - compiled per model
    if not (all_finite(X) and all_finite(U)):
        return False
    P = p.reshape((1, p.shape[0]))
    work = np.empty(X.shape[0])
    for b in prange((X.shape[0] + LANES - 1) // LANES):
        BLOCK(X, U, P, h, n, out, work, b * LANES)
    return True


@dataclasses.dataclass(frozen=True)
class ModelKernels:
    """The compiled batch kernels of one model (the ``Model._k_*`` attributes).

    Attributes:
        deriv: ``deriv(X, U, p, out)``, the derivative of each row.
        deriv1: ``deriv1(x, u, p, out) -> status`` for one state (:data:`DERIV1_SIG`;
            compiled on its first call, :func:`first_call`).
        step1: ``step1(x, u, p, dt, n) -> status``, one state in place (:data:`STEP1_SIG`;
            likewise).
        step: ``step(X, U, p, h, n, out) -> bool`` (``False``: a non-finite input).
        step_par: the same over numba's threads (``prange``), the same bits per row.
        block: ``block(X, U, P, h, n, out, work, b0)``, one vectorised block of
            :data:`LANES` rows with the motor work (models with a tuple derivative only).
    """

    deriv: Any
    deriv1: Any
    step1: Any
    step: Any
    step_par: Any
    block: Any = None


def _const_dim(n: int):
    """A compiled ``f(p) -> n`` for the ``STATE_DIM`` slot (inlined: never compiled alone)."""
    def dim(p):  # pragma: no cover - compiled
        return n
    return njit(inline="always")(dim)


def _instance(body, module: str, file: str, name: str, slots: dict, **options):
    """``body`` compiled as ``module.name`` (cached next to ``file``) with ``slots`` bound."""
    scope = dict(body.__globals__)
    scope.update(slots)
    scope["__name__"] = module
    changes: dict = {"co_filename": file, "co_name": name}
    if sys.version_info >= (3, 11):
        changes["co_qualname"] = name
    fn = types_.FunctionType(body.__code__.replace(**changes), scope, name)
    fn.__qualname__ = name
    fn.__doc__ = body.__doc__
    sig = options.pop("sig", None)
    disp = njit(cache=True, **options)(fn)
    if sig is not None:  # one signature, compiled (or loaded) on the first call: first_call
        disp._can_compile = False  # (numba's disable_compile() wants a signature first)
        disp._wheelgym_sig = sig
    return disp


def first_call(kernel: Any, *args: Any) -> Any:
    """Call a single-state kernel of :func:`model_kernels` (``step1``, ``deriv1``) after a
    ``TypeError``: where it has not been compiled yet, compile (or load from the disk cache)
    its one signature and call it again; ``None`` where the arguments do not match that
    signature (the caller's general path then handles them).

    The kernels are built without compiling (importing a model compiles nothing) and take no
    other signature; their callers catch the ``TypeError`` of the first call::

        try:
            status = kernel(*args)
        except TypeError:
            status = first_call(kernel, *args)
    """
    if kernel.signatures:
        return None
    kernel._can_compile = True
    try:
        kernel.compile(kernel._wheelgym_sig)
    finally:
        kernel._can_compile = False
    try:
        return kernel(*args)
    except TypeError:
        return None


def model_kernels(
    module: str,
    file: str,
    deriv_one: Any,
    state_dim: int | Any,
    nu: int,
    deriv_block: Any = None,
    power: Any = None,
    npar: int = 0,
    suffix: str = "",
) -> ModelKernels:
    """Compile the generic kernel bodies above for one model; call from its kernel module.

    Args:
        module: the kernel module's ``__name__``; the kernels appear as its ``k_*`` functions.
        file: its ``__file__``: numba caches the kernels next to it (and the module's
            ``_numba_cache.guard`` drops them with its other kernels).
        deriv_one: compiled ``f(x, u, p, out)``, the derivative of one state.
        state_dim: the state size, or an inline compiled ``f(p) -> int`` where it depends on
            the parameters (the kinematic models).
        nu: the input size.
        deriv_block: compiled branch-free tuple derivative ``ft(x, u, p) -> xdot`` (inline);
            given, the batch steps run in vectorised blocks (:func:`rk4_block`), else a row
            at a time (:func:`rk4_inplace`).
        power: compiled ``pw(x, xdot, u, p)``, the motor power of the blocks' work integral.
        npar: length of the packed parameter array (blocks only).
        suffix: appended to the kernels' names (``k_step_dc``...), for a second set of
            kernels in the same module (its own cache entries).
    """
    dim = _const_dim(state_dim) if isinstance(state_dim, int) else state_dim
    slots = {"DERIV_ONE": deriv_one, "STATE_DIM": dim, "NU": nu}

    def inst(body, name, **options):
        return _instance(body, module, file, name + suffix, slots, **options)

    deriv = inst(_k_deriv, "k_deriv")
    deriv1 = inst(_k_deriv1, "k_deriv1", sig=DERIV1_SIG)
    step1 = inst(_k_step1, "k_step1", sig=STEP1_SIG)
    if deriv_block is None:
        return ModelKernels(deriv, deriv1, step1, inst(_k_step_rows, "k_step"),
                            inst(_k_step_rows_par, "k_step_par", parallel=True))
    if not isinstance(state_dim, int):
        raise TypeError("the block kernels need a constant state size")
    # NX, NU, NP literal ints: rk4_block unrolls its tuples by them
    slots.update(DERIV_BLOCK=deriv_block, POWER=power, NX=state_dim, NP=npar)
    block = inst(_k_block, "k_block", error_model="numpy")
    slots["BLOCK"] = block
    return ModelKernels(deriv, deriv1, step1, inst(_k_step_blocks, "k_step"),
                        inst(_k_step_blocks_par, "k_step_par", parallel=True), block)


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
    """Number of physics substeps in one control step (docs/physics/conventions.md).

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


def entry_point(kernel: Any, *args: Any) -> Callable[..., Any]:
    """``kernel``'s compiled entry point for exactly the types of ``args`` where numba has
    compiled it for them, else ``kernel`` itself.

    The entry point skips the dispatcher's resolution of the argument types (~0.2 us of each
    call at N = 1) and checks no argument, so it is only for calls on arguments of these
    types: the core's and the tasks' own buffers."""
    overloads = getattr(kernel, "overloads", None)
    if overloads is None:  # not a numba dispatcher (e.g. a Python wrapper)
        return kernel
    cres = overloads.get(tuple(typeof(a) for a in args))
    return kernel if cres is None else cres.entry_point
