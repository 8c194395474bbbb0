"""Load distribution (docs/physics/three-wheel.md TW-6, docs/physics/skid-steer.md SS-4): residuals,
orthogonality, limits against an LP."""

import numpy as np
import pytest
from scipy.optimize import linprog, minimize

from wheelgym.control.distribution import (
    STATUS_INFEASIBLE,
    STATUS_NULL_SPACE,
    STATUS_OK,
    distribute,
    independent_joint_force,
    internal_force,
    min_norm,
    null_space_basis,
    null_space_projector,
    paper_distribution,
    skid_steer_split,
    weighted,
    within_limits,
)

R, D = 0.075, 0.04
AXES = np.array([[-0.20, 0.20], [-0.20, -0.20], [0.25, 0.0]])
TMAX = np.array([6.0, 6.0, 6.0, 3.0, 3.0, 3.0])


def tw_jacobian(psi):
    """docs/physics/three-wheel.md TW-1 written out independently: rows [drive_1..3, steer_1..3]."""
    psi = np.asarray(psi, dtype=float)
    J = np.zeros(psi.shape[:-1] + (6, 3))
    for i in range(3):
        c, s = np.cos(psi[..., i]), np.sin(psi[..., i])
        ax, ay = AXES[i]
        J[..., i, :] = np.stack([c, s, ax * s - ay * c], -1) / R
        J[..., 3 + i, :] = np.stack([-s, c, ax * c + ay * s], -1) / D
        J[..., 3 + i, 2] -= 1.0
    return J


@pytest.fixture(scope="module")
def cases():
    rng = np.random.default_rng(0)
    psi = rng.uniform(-np.pi, np.pi, (200, 3))
    J = tw_jacobian(psi)
    Q = rng.normal(size=(200, 3)) * np.array([40.0, 40.0, 10.0])
    return J, Q


@pytest.mark.parametrize("mode", ["min_norm", "weighted", "within_limits", "paper"])
def test_generalized_force_reproduced(cases, mode):
    J, Q = cases
    if mode == "paper":
        tau = paper_distribution(J, Q)[0]
        ok = np.ones(len(Q), bool)
    else:
        tau, status = distribute(J, Q, mode, TMAX)
        ok = status >= 0
    assert ok.sum() > 50
    res = np.einsum("...ij,...i->...j", J, tau) - Q
    rel = np.linalg.norm(res, axis=-1) / np.linalg.norm(Q, axis=-1)
    assert rel[ok].max() < 1e-12


def test_min_norm_is_pseudo_inverse_and_orthogonal_to_null_space(cases):
    J, Q = cases
    tau = min_norm(J, Q)
    np.testing.assert_allclose(tau, np.einsum("nij,nj->ni", np.linalg.pinv(np.swapaxes(J, 1, 2)),
                                              Q), rtol=1e-9, atol=1e-9)
    N = null_space_basis(J)
    assert N.shape == (200, 6, 3)
    np.testing.assert_allclose(np.swapaxes(N, 1, 2) @ N, np.broadcast_to(np.eye(3), (200, 3, 3)),
                               atol=1e-12)
    assert np.abs(np.einsum("nij,ni->nj", J, N[..., 0])).max() < 1e-10  # J^T N = 0
    assert np.abs(np.einsum("nik,ni->nk", N, tau)).max() < 1e-9 * np.abs(tau).max()
    np.testing.assert_allclose(internal_force(J, tau), 0.0, atol=1e-9)


def test_null_space_additions_change_no_generalized_force(cases):
    J, Q = cases
    rng = np.random.default_rng(1)
    tau = min_norm(J, Q)
    eps = rng.normal(size=tau.shape) * 5.0
    P = null_space_projector(J)
    tau2 = tau + np.einsum("nij,nj->ni", P, eps)  # paper (36) with an arbitrary epsilon
    np.testing.assert_allclose(np.einsum("nij,ni->nj", J, tau2), Q, rtol=0, atol=1e-10)
    np.testing.assert_allclose(internal_force(J, tau2), tau2 - tau, atol=1e-10)
    np.testing.assert_allclose(P @ P, P, atol=1e-12)


def test_weighted_solution_satisfies_its_optimality_condition(cases):
    J, Q = cases
    tau = weighted(J, Q, TMAX)
    # KKT: tau / tau_max^2 lies in range(J), i.e. is orthogonal to null(J^T)
    N = null_space_basis(J)
    assert np.abs(np.einsum("nik,ni->nk", N, tau / TMAX**2)).max() < 1e-10
    # and beats any other solution
    rng = np.random.default_rng(2)
    other = tau + np.einsum("nik,nk->ni", N, rng.normal(size=(200, 3)))
    assert np.all(np.sum((other / TMAX) ** 2, -1) > np.sum((tau / TMAX) ** 2, -1))


def _lp_margin(J, Q, tmax):
    """max t such that J^T tau = Q and |tau_k| <= (1 - t) tau_max_k (feasible iff t >= 0)."""
    m = len(tmax)
    c = np.zeros(m + 1)
    c[-1] = -1.0
    A_ub = np.block([[np.eye(m), tmax[:, None]], [-np.eye(m), tmax[:, None]]])
    b_ub = np.concatenate([tmax, tmax])
    A_eq = np.hstack([J.T, np.zeros((J.shape[1], 1))])
    res = linprog(c, A_ub=A_ub, b_ub=b_ub, A_eq=A_eq, b_eq=Q, bounds=[(None, None)] * (m + 1),
                  method="highs")
    assert res.status == 0
    return -res.fun


def test_within_limits_agrees_with_linear_program_and_is_optimal():
    rng = np.random.default_rng(3)
    n = 120
    J = tw_jacobian(rng.uniform(-np.pi, np.pi, (n, 3)))
    # scale Q so that about half of the cases saturate the weighted solution
    Q = rng.normal(size=(n, 3)) * np.array([60.0, 60.0, 15.0]) * rng.uniform(0.3, 3.0, (n, 1))
    tau, status = within_limits(J, Q, TMAX)
    tau_w = weighted(J, Q, TMAX)
    counts = {s: int(np.sum(status == s)) for s in (STATUS_OK, STATUS_NULL_SPACE,
                                                    STATUS_INFEASIBLE)}
    assert min(counts.values()) >= 10, counts
    checked = 0
    for i in range(n):
        margin = _lp_margin(J[i], Q[i], TMAX)
        if abs(margin) < 1e-6:
            continue  # on the boundary: either answer is right to round-off
        checked += 1
        assert (status[i] >= 0) == (margin > 0), (i, margin, status[i])
        if status[i] == STATUS_OK:
            np.testing.assert_array_equal(tau[i], tau_w[i])
        if status[i] >= 0:
            assert np.all(np.abs(tau[i]) <= TMAX * (1 + 1e-12))
            np.testing.assert_allclose(J[i].T @ tau[i], Q[i], rtol=1e-10, atol=1e-9)
            # optimality: no solver finds a smaller weighted norm inside the box
            f = np.sum((tau[i] / TMAX) ** 2)
            ref = minimize(lambda t: np.sum((t / TMAX) ** 2), tau_w[i], method="SLSQP",
                           constraints=[{"type": "eq", "fun": lambda t, i=i: J[i].T @ t - Q[i]}],
                           bounds=list(zip(-TMAX, TMAX, strict=True)), options={"ftol": 1e-14,
                                                                    "maxiter": 500})
            if ref.success:
                assert f <= ref.fun + 1e-7
        else:
            # infeasible: uniformly scaled weighted solution (generalized force keeps direction)
            assert np.max(np.abs(tau[i]) / TMAX) == pytest.approx(1.0)
            g = J[i].T @ tau[i]
            np.testing.assert_allclose(g / np.linalg.norm(g), Q[i] / np.linalg.norm(Q[i]),
                                       atol=1e-10)
    assert checked > 100


def test_within_limits_brute_force_small_cases():
    """Grid search over the 3-D null space finds nothing better than the exact solution."""
    rng = np.random.default_rng(4)
    J = tw_jacobian(rng.uniform(-np.pi, np.pi, (5, 3)))
    Q = rng.normal(size=(5, 3)) * np.array([60.0, 60.0, 15.0])
    tau, status = within_limits(J, Q, TMAX)
    g = np.linspace(-1.0, 1.0, 41)
    Z = np.stack(np.meshgrid(g, g, g, indexing="ij"), -1).reshape(-1, 3)
    for i in range(5):
        if status[i] < 0:
            continue
        N = null_space_basis(J[i])
        span = 2.0 * np.max(TMAX)
        cand = tau[i] + (Z * span) @ N.T
        inside = np.all(np.abs(cand) <= TMAX, axis=1)
        f = np.sum((cand[inside] / TMAX) ** 2, axis=1)
        assert np.sum((tau[i] / TMAX) ** 2) <= f.min() + 1e-12


def test_paper_formulation_equals_body_twist_formulation(cases):
    J, Q = cases
    tau_paper, Q_S = paper_distribution(J, Q)
    np.testing.assert_allclose(tau_paper, min_norm(J, Q), rtol=1e-9, atol=1e-9)
    # Q_S is the generalized force in the independent joints: Q = J_S^T Q_S
    J_S = J[:, [0, 1, 5], :]
    np.testing.assert_allclose(np.einsum("nij,ni->nj", J_S, Q_S), Q, rtol=1e-10, atol=1e-9)
    np.testing.assert_allclose(independent_joint_force(J, Q), Q_S)
    # other input sets give the same torques (the constraint set is the same, TW-6)
    tau_other, _ = paper_distribution(J, Q, S=(3, 4, 5))
    np.testing.assert_allclose(tau_other, tau_paper, rtol=1e-8, atol=1e-8)


def test_skid_steer_split_matches_distribution():
    r, c = 0.1651, 0.2854
    J = np.array([[1, -c], [1, -c], [1, c], [1, c]]) / r  # qdot = J (vx, wz), SS-1
    rng = np.random.default_rng(5)
    sides = rng.normal(size=(10, 2)) * 10
    Bbar = np.array([[1.0, 1.0], [-c, c]]) / r  # SS-3
    Q = sides @ Bbar.T
    np.testing.assert_allclose(skid_steer_split(sides), min_norm(J, Q), atol=1e-12)
    loads = np.array([150.0, 120.0, 120.0, 150.0])
    split = skid_steer_split(sides, loads)
    np.testing.assert_allclose(split, weighted(J, Q, np.sqrt(loads)), atol=1e-12)
    np.testing.assert_allclose(split[:, 0] / split[:, 1], 150.0 / 120.0)
    np.testing.assert_allclose(split[:, 0] + split[:, 1], sides[:, 0])


def test_invalid_arguments():
    J = tw_jacobian(np.zeros(3))
    with pytest.raises(ValueError, match="Q must have shape"):
        min_norm(J, np.zeros(2))
    with pytest.raises(ValueError, match="mode must be one of"):
        distribute(J, np.zeros(3), "max_norm")
    with pytest.raises(ValueError, match="finite"):
        min_norm(J, np.array([np.nan, 0, 0]))
    with pytest.raises(ValueError, match="tau_max"):
        weighted(J, np.zeros(3), -1.0)
    with pytest.raises(ValueError, match="S must be"):
        paper_distribution(J, np.zeros(3), S=(0, 0, 1))
    with pytest.raises(ValueError, match="singular"):
        paper_distribution(J, np.zeros(3), S=(0, 1, 2))  # three parallel drives: no rotation
    with pytest.raises(ValueError, match="lost rank"):
        min_norm(np.zeros((6, 3)), np.ones(3))
    with pytest.raises(ValueError):
        skid_steer_split(np.zeros(3))


def test_read_only_inputs_reach_the_kernel_as_writable_arrays():
    """Broadcast views and frozen arrays give the same torques through the one compiled
    signature of the writable arrays (numba would compile each kernel again for read-only)."""
    from tests.kernel_signatures import read_only_arrays
    from wheelgym.control import distribution

    rng = np.random.default_rng(4)
    J = rng.normal(size=(6, 3))
    Q = rng.normal(size=3)
    T = np.full(6, 2.0)
    expected = within_limits(J, Q, T)[0]
    frozen = [a.copy() for a in (J, Q, T)]
    for a in frozen:
        a.flags.writeable = False
    np.testing.assert_array_equal(within_limits(*frozen)[0], expected)
    got = within_limits(np.broadcast_to(J, (2, 6, 3)), Q, T)[0]
    np.testing.assert_array_equal(got, [expected, expected])
    np.testing.assert_array_equal(min_norm(np.broadcast_to(J, (2, 6, 3)), Q)[1], min_norm(J, Q))
    kernel = distribution._k_distribute
    assert kernel.signatures and not read_only_arrays(kernel), kernel.signatures
