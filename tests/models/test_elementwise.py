"""The references' compiled sin, cos, arctan2 and hypot: accurate to a few ulp of libm, and an
element's bits independent of the array's layout (NumPy's own loops are not, on AVX-512)."""

import math

import numpy as np
import pytest

from wheelgym.models import elementwise as ew

RNG = np.random.default_rng(7)
X = np.concatenate([RNG.uniform(-10.0, 10.0, 4000), RNG.uniform(-1e4, 1e4, 1000),
                    [0.0, -0.0, math.pi, -math.pi / 2, 1e-300, 5e7, 2e8, -3e9]])


def _ulp_err(got: np.ndarray, want: np.ndarray) -> np.ndarray:
    return np.abs(got - want) / np.spacing(np.maximum(np.abs(want), 1e-300))


@pytest.mark.parametrize("fn,ref", [(ew.sin, math.sin), (ew.cos, math.cos)])
def test_sin_cos_within_ulps_of_libm(fn, ref):
    want = np.array([ref(x) for x in X])
    got = fn(X)
    # 2 ulp of the result, or an absolute 1e-31 |x| near the zeros (the reduction's accuracy)
    err = np.abs(got - want)
    assert np.all((err <= 2 * np.spacing(np.abs(want))) | (err <= 1e-31 * np.abs(X) + 1e-300))


def test_arctan2_within_ulps_and_quadrants():
    y = RNG.uniform(-5, 5, 5000)
    x = RNG.uniform(-5, 5, 5000)
    want = np.array([math.atan2(a, b) for a, b in zip(y, x, strict=True)])
    assert _ulp_err(ew.arctan2(y, x), want).max() <= 4
    special = [(0.0, 1.0), (0.0, -1.0), (-0.0, -1.0), (1.0, 0.0), (-1.0, 0.0), (0.0, 0.0),
               (math.inf, 1.0), (-math.inf, -1.0), (1.0, math.inf), (1.0, -math.inf),
               (math.inf, math.inf), (-math.inf, -math.inf), (1e-300, -1e300)]
    for a, b in special:
        assert ew.arctan2(a, b) == pytest.approx(math.atan2(a, b), rel=1e-15, abs=1e-300)
    assert math.isnan(ew.arctan2(math.nan, 1.0))


def test_hypot_within_an_ulp():
    a, b = RNG.uniform(-3, 3, (2, 5000))
    assert _ulp_err(ew.hypot(a, b), np.hypot(a, b)).max() <= 1


@pytest.mark.parametrize("fn", [ew.sin, ew.cos])
def test_bits_do_not_depend_on_layout(fn):
    big = np.empty((len(X), 3))
    big[:, 1] = X
    strided = big[:, 1]  # stride 24 bytes
    assert not strided.flags.c_contiguous
    contiguous = fn(np.ascontiguousarray(X))
    assert np.array_equal(fn(strided), contiguous)
    assert np.array_equal(fn(X[::-1])[::-1], contiguous)
    assert np.array_equal(fn(X.reshape(-1, 1) + np.zeros((1, 3)))[:, 2], contiguous)
    assert all(fn(float(x)) == c for x, c in zip(X[:50], contiguous[:50], strict=True))


def test_arctan2_bits_do_not_depend_on_layout():
    y, x = RNG.uniform(-5, 5, (2, 999))
    col = ew.arctan2(y[:, None], x[:, None])[:, 0]
    assert np.array_equal(col, ew.arctan2(y, x))
    assert np.array_equal(ew.arctan2(y[::3], x[::3]), ew.arctan2(y, x)[::3])
