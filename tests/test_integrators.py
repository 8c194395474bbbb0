"""RK4 and time-step bookkeeping (docs/physics/conventions.md)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from numba import njit
from numba import types as numba_types

from wheelgym.integrators import check_substeps, n_substeps, rk4
from wheelgym.models import SkidSteer


def _decay(x, u):
    return -x + u


def test_rk4_linear_decay_fourth_order():
    # x' = -x, x(0) = 1: exact exp(-t). The global error at t = 1 falls 16x per halving.
    errors = []
    for n in (10, 20, 40, 80):
        x = rk4(_decay, np.array([1.0]), 0.0, 1.0, n)
        errors.append(abs(x[0] - math.exp(-1.0)))
    ratios = [errors[i] / errors[i + 1] for i in range(3)]
    for r in ratios:
        assert 16 * 0.75 <= r <= 16 * 1.25, ratios
    # one step of RK4 on a linear ODE is the 4th-order Taylor polynomial of exp(-h)
    h = 0.1
    one = rk4(_decay, np.array([1.0]), 0.0, h, 1)[0]
    assert one == pytest.approx(1 - h + h**2 / 2 - h**3 / 6 + h**4 / 24, rel=1e-15)


def test_rk4_harmonic_oscillator_and_constant_input():
    def osc(x, u):
        return np.stack([x[..., 1], -x[..., 0] + u], axis=-1)

    x = rk4(osc, np.array([1.0, 0.0]), 0.0, 2 * np.pi, 2000)
    np.testing.assert_allclose(x, [1.0, 0.0], atol=1e-10)
    # a constant input shifts the equilibrium: x = u (1 - cos t) from rest
    x = rk4(osc, np.zeros(2), 0.5, np.pi, 2000)
    assert x[0] == pytest.approx(0.5 * (1 - math.cos(math.pi)), abs=1e-10)


def test_rk4_keeps_input_and_batches():
    x0 = np.array([[1.0], [2.0]])
    x = rk4(_decay, x0, 0.0, 0.5, 5)
    assert x.shape == (2, 1)
    assert x0[0, 0] == 1.0  # not modified in place
    np.testing.assert_allclose(x[1], 2 * x[0], rtol=1e-15)


def test_compiled_step_is_the_python_rk4():
    # The model's compiled kernel (rk4_inplace) and the reference rk4 on model.derivative
    # perform the same operations in the same order.
    model = SkidSteer()
    rng = np.random.default_rng(3)
    for _ in range(5):
        x = rng.normal(0, 0.5, 5)
        u = rng.uniform(-20, 20, 4)
        fast = model.step(x, u, 0.05, 40)
        ref = rk4(model.derivative, x, u, 0.05, 40)
        np.testing.assert_allclose(fast, ref, rtol=1e-14, atol=1e-15)


@pytest.mark.parametrize(
    ("ctrl_dt", "sim_dt", "n"),
    [(0.05, 0.002, 25), (0.05, 0.00125, 40), (0.05, 0.05, 1), (0.1, 0.001, 100), (1, 0.25, 4)],
)
def test_n_substeps_divides(ctrl_dt, sim_dt, n):
    assert n_substeps(ctrl_dt, sim_dt) == n


@pytest.mark.parametrize(
    ("ctrl_dt", "sim_dt", "match"),
    [
        (0.05, 0.003, "whole multiple"),
        (0.05, 0.1, "whole multiple"),
        (0.05, 0.0, "sim_dt"),
        (0.05, -0.001, "sim_dt"),
        (float("nan"), 0.001, "ctrl_dt"),
        (0.05, float("inf"), "sim_dt"),
        (0.0, 0.001, "ctrl_dt"),
    ],
)
def test_n_substeps_rejects(ctrl_dt, sim_dt, match):
    with pytest.raises(ValueError, match=match):
        n_substeps(ctrl_dt, sim_dt)


def test_check_substeps():
    assert check_substeps(3) == 3
    assert check_substeps(np.int64(2)) == 2
    for bad in (1.0, 2.5, True, "2", None):
        with pytest.raises(TypeError, match="n_substeps"):
            check_substeps(bad)
    for bad in (0, -1):
        with pytest.raises(ValueError, match="n_substeps"):
            check_substeps(bad)
    with pytest.raises(ValueError):
        rk4(_decay, np.ones(1), 0.0, 1.0, 0)


@njit(cache=True)
def _decay_one(x, u, p, out):  # pragma: no cover - compiled
    out[0] = u[0] - p[0] * x[0]


def test_single_state_kernels_compile_on_first_call_only():
    """model_kernels builds step1/deriv1 without compiling; first_call compiles their one
    signature (or loads it) and refuses other argument types (None: the general path)."""
    from wheelgym.integrators import first_call, model_kernels

    k = model_kernels(__name__, __file__, _decay_one, 1, 1, suffix="_first_call")
    assert not k.step1.signatures and not k.deriv1.signatures
    x, u, p = np.array([1.0]), np.array([0.5]), np.array([2.0])
    with pytest.raises(TypeError):
        k.step1(x.copy(), u, p, 0.1, 2)
    out = x.copy()
    assert first_call(k.step1, out, u, p, 0.1, 2) == 0
    assert len(k.step1.signatures) == 1
    h = 0.05
    ref = np.array([1.0])
    for _ in range(2):  # RK4 of x' = 0.5 - 2 x by hand
        f = lambda y: 0.5 - 2.0 * y  # noqa: E731
        k1 = f(ref)
        k2 = f(ref + 0.5 * h * k1)
        k3 = f(ref + 0.5 * h * k2)
        k4 = f(ref + h * k3)
        ref = ref + h / 6.0 * (k1 + 2 * k2 + 2 * k3 + k4)
    np.testing.assert_allclose(out, ref, rtol=1e-14)
    assert first_call(k.step1, x.astype(np.float32), u, p, 0.1, 2) is None  # compiled: no
    with pytest.raises(TypeError):  # other types never compile a second signature
        k.step1(x.astype(np.float32), u, p, 0.1, 2)
    assert len(k.step1.signatures) == 1


def _half_inverse(x):  # a piece for the test below
    return 0.5 / x


def test_llvm_inline_piece_is_inlined_by_llvm():
    """An ``llvm_inline`` piece is compiled on its own (one dispatcher, one signature) and
    LLVM inlines it: the caller's optimised IR has no call to it. Its error model is NumPy's:
    a division by zero gives inf (no exception branch in vectorised callers)."""
    import re

    from wheelgym.integrators import llvm_inline

    piece = llvm_inline(_half_inverse, cache=False)

    @njit
    def caller(a):
        s = 0.0
        for i in range(a.shape[0]):
            s += piece(a[i])
        return s

    assert caller(np.array([1.0, 2.0])) == 0.75
    assert piece.signatures == [(numba_types.float64,)]
    mangled = piece.overloads[piece.signatures[0]].fndesc.mangled_name
    assert "alwaysinline" in piece.inspect_llvm(piece.signatures[0])
    ll = caller.inspect_llvm(caller.signatures[0])
    assert not re.search(r"call [^\n]*@\"?" + re.escape(mangled), ll)
    assert math.isinf(caller(np.array([0.0])))


def test_model_derivative_inlines_its_pieces(tmp_path):
    """ThreeWheel's one-state derivative, compiled afresh (an empty cache directory, in a
    fresh process): LLVM inlined its ``llvm_inline`` pieces, no call to them remains; and
    again with the pieces loaded from numba's disk cache (the ``alwaysinline`` attribute
    travels in the cached linking module) and only the derivative recompiled."""
    import os
    import subprocess
    import sys

    code = (
        "import re, numpy as np\n"
        "import wheelgym.models.kernels.three_wheel as K\n"
        "x = np.zeros(K.NX); u = np.zeros(K.NU); out = np.zeros(K.NX)\n"
        "p = np.random.default_rng(0).uniform(0.5, 1.5, K.NP)\n"
        "K.deriv_one(x, u, p, out)\n"
        "ll = K.deriv_one.inspect_llvm(K.deriv_one.signatures[0])\n"
        "names = ('deriv_block', 'trig', 'sincos', 'solve3', 'loads', 'atan', 'sgn_s')\n"
        "called = [n for n in names if re.search(r'call [^\\n]*@\"?_ZN[^\\n]*' + n, ll)]\n"
        "print('CALLED', called, 'loaded', bool(K.deriv_block._cache_hits))\n"
    )
    env = dict(os.environ, NUMBA_CACHE_DIR=str(tmp_path))

    def run() -> str:
        return subprocess.run([sys.executable, "-c", code], env=env, capture_output=True,
                              text=True, check=True).stdout

    out = run()
    assert "CALLED [] loaded False" in out, out
    stale = list(tmp_path.rglob("three_wheel.deriv_one-*"))
    assert stale
    for f in stale:
        f.unlink()
    out = run()
    assert "CALLED [] loaded True" in out, out
