"""The vector layer's compiled bookkeeping against the NumPy expressions it replaced."""

from __future__ import annotations

import numpy as np
import pytest

from wheelgym.vector._kernels import k_info_copy, k_step_ends, k_zero_rows


@pytest.mark.parametrize("max_steps", [-1, 5])
@pytest.mark.parametrize("any_rr", [False, True])
def test_step_ends_matches_numpy(max_steps: int, any_rr: bool) -> None:
    rng = np.random.default_rng(3)
    N = 64
    reward = rng.normal(size=N)
    term = rng.random(N) < 0.2
    elapsed = rng.integers(0, 6, N)
    rr = (rng.random(N) < 0.3) if any_rr else np.zeros(N, dtype=np.bool_)
    # the old NumPy expressions
    e_ref = elapsed + 1
    trunc_ref = e_ref >= max_steps if max_steps >= 1 else np.zeros(N, dtype=np.bool_)
    r_ref = reward.copy()
    t_ref = term.copy()
    r_ref[rr] = 0.0
    t_ref[rr] = False
    trunc_ref[rr] = False
    done_ref = t_ref | trunc_ref
    rows_ref = np.flatnonzero(rr) if any_rr else np.flatnonzero(done_ref)

    R = np.empty(N)
    TT = np.empty((2, N), dtype=np.bool_)
    done = np.empty(N, dtype=np.bool_)
    idx = np.empty(N, dtype=np.int64)
    n = k_step_ends(reward, term, elapsed, max_steps, rr, any_rr, R, TT, done, idx)
    np.testing.assert_array_equal(elapsed, e_ref)
    np.testing.assert_array_equal(R, r_ref)
    np.testing.assert_array_equal(TT[0], t_ref)
    np.testing.assert_array_equal(TT[1], trunc_ref)
    np.testing.assert_array_equal(done, done_ref)
    np.testing.assert_array_equal(idx[:n], rows_ref)
    if max_steps >= 1:
        assert trunc_ref.any()  # the case is exercised


def test_zero_rows_info_copy() -> None:
    rng = np.random.default_rng(4)
    N = 10
    a = rng.normal(size=(N, 3))
    rows = np.zeros(N, dtype=np.bool_)
    rows[[1, 7]] = True
    out = np.full((N, 3), np.nan)
    k_zero_rows(a, rows, out)
    ref = a.copy()
    ref[rows] = 0.0
    np.testing.assert_array_equal(out, ref)

    B = rng.normal(size=(N, 8))
    F = rng.random((N, 5)) < 0.5
    terms = rng.normal(size=(N, 7))
    tidx = np.array([0, 2, 3, 6], dtype=np.int64)
    reset = np.array([2, 5], dtype=np.int64)
    Bo = np.empty_like(B)
    Fo = np.empty((3, N), dtype=np.bool_)
    To = np.empty((tidx.size, N))
    k_info_copy(B, F, terms, tidx, reset, 0, 3, 1, Bo, Fo, To)
    np.testing.assert_array_equal(Bo, B)
    np.testing.assert_array_equal(Fo, np.stack([F[:, 0], F[:, 3], ~F[:, 1]]))
    t_ref = terms.T[tidx].copy()
    t_ref[:, reset] = 0.0
    np.testing.assert_array_equal(To, t_ref)

