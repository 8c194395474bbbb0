"""Singularity analysis of the caster robots for chosen input joints (docs/physics/three-wheel.md
TW-2, docs/physics/caster-robots.md)."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest

from wheelgym.kinematics.singularity import (
    SingularConfigurationError,
    SingularityAnalysis,
)
from wheelgym.models import CasterAGV, SkidSteer, ThreeWheel

TW_SETS = [
    ("drive_1", "drive_2", "steer_3"),  # the three-wheel paper's choice, its (7)-(11)
    ("drive_1", "drive_2", "drive_3"),
    ("steer_1", "steer_2", "steer_3"),
    ("drive_1", "steer_1", "drive_3"),
]
AGV_SETS = list(itertools.combinations(CasterAGV.joint_names, 2))


def tw1_jacobian(p, psi):
    """TW-1 written out independently: rows g_i / r (drive i), h_i / d - e_3 (steer i)."""
    psi = np.atleast_2d(psi)
    out = np.zeros(psi.shape[:-1] + (6, 3))
    for i, (ax, ay) in enumerate(p.axes):
        c, s = np.cos(psi[..., i]), np.sin(psi[..., i])
        out[..., i, :] = np.stack([c, s, ax * s - ay * c], -1) / p.r
        out[..., 3 + i, :] = np.stack([-s, c, ax * c + ay * s - p.d], -1) / p.d
    return out


def agv_jacobian(p, sigma):
    """Caster AGV joint rates from the wheel-centre velocities, written out independently."""
    sigma = np.atleast_1d(sigma)
    c = p.track_width / 2
    ax, ay = p.caster_axis
    out = np.zeros(sigma.shape + (4, 2))
    out[..., 0, :] = [1 / p.r, -c / p.r]
    out[..., 1, :] = [1 / p.r, c / p.r]
    # wheel centre P = a - d e: velocity (v - w P_y, w P_x) - d sigmadot n must be along e
    px, py = ax - p.d * np.cos(sigma), ay - p.d * np.sin(sigma)
    e = np.stack([np.cos(sigma), np.sin(sigma)], -1)
    n = np.stack([-np.sin(sigma), np.cos(sigma)], -1)
    vel_v = np.stack([np.ones_like(sigma), np.zeros_like(sigma)], -1)  # d vel / d v
    vel_w = np.stack([-py, px], -1)  # d vel / d w
    out[..., 2, 0] = np.sum(vel_v * e, -1) / p.r_c
    out[..., 2, 1] = np.sum(vel_w * e, -1) / p.r_c
    # lateral: vel . n - d sigmadot = 0
    out[..., 3, 0] = np.sum(vel_v * n, -1) / p.d
    out[..., 3, 1] = np.sum(vel_w * n, -1) / p.d
    return out


@pytest.fixture(scope="module")
def tw():
    return ThreeWheel()


@pytest.fixture(scope="module")
def agv():
    return CasterAGV()


def _independent(model, analysis, configs):
    if isinstance(model, ThreeWheel):
        j = tw1_jacobian(model.params, configs)
    else:
        j = agv_jacobian(model.params, configs[..., 0])
    return j[..., analysis.rows, :]


def test_jacobians_match_independent_formulas(tw, agv):
    rng = np.random.default_rng(2)
    psi = rng.uniform(-4, 4, size=(50, 3))
    np.testing.assert_allclose(tw.jacobian(psi), tw1_jacobian(tw.params, psi), atol=1e-12)
    sig = rng.uniform(-4, 4, size=50)
    np.testing.assert_allclose(agv.jacobian(sig), agv_jacobian(agv.params, sig), atol=1e-12)


@pytest.mark.parametrize("which, joints", [("tw", s) for s in TW_SETS]
                         + [("agv", s) for s in AGV_SETS])
def test_reported_singularities_are_singular(which, joints, tw, agv):
    model = tw if which == "tw" else agv
    a = SingularityAnalysis(model, joints)
    scan = a.scan(n=24 if which == "tw" else 72)
    assert not scan.always_singular
    if len(scan):
        j = _independent(model, a, scan.configs)
        scale = np.prod(np.linalg.norm(j, axis=-1), axis=-1)  # Hadamard bound of |det|
        assert np.max(np.abs(np.linalg.det(j)) / scale) < 1e-13
        s = np.linalg.svd(j, compute_uv=False)
        assert np.max(s[:, -1] / s[:, 0]) < 1e-12  # rank loss
        with pytest.raises(SingularConfigurationError, match="singular"):
            a.forward(scan.configs[:1], np.ones(len(joints)))
    # away from them the forward kinematics inverts the inverse kinematics
    rng = np.random.default_rng(4)
    cfg = rng.uniform(-np.pi, np.pi, size=(400, a.n_config))
    ok = a.ratio(cfg) > 1e-3
    u = rng.normal(size=(400, a.n_dof))
    back = a.forward(cfg[ok], a.inverse(cfg[ok], u[ok]))
    np.testing.assert_allclose(back, u[ok], rtol=0, atol=1e-12)
    assert ok.sum() > 300


def test_paper_set_has_singular_surfaces(tw):
    """The paper's S is singular on surfaces of the 3-torus: each grid line over psi_3 that
    brackets one holds a zero of det, and det changes sign across it."""
    a = SingularityAnalysis(tw, ("drive_1", "drive_2", "steer_3"))
    scan = a.scan(n=16)
    assert len(scan) > 50 and scan.active == ("psi_1", "psi_2", "psi_3")
    c = scan.configs[:20]
    step = np.array([0.0, 0.0, 1e-4])
    assert np.all(np.sign(a.det(c - step)) != np.sign(a.det(c + step)))


def test_agv_singularities_analytic(agv):
    p = agv.params
    ax, ay = p.caster_axis
    c = p.track_width / 2
    # (drive_L, caster_drive): det ~ a_x sin s + (c - a_y) cos s = 0
    scan = SingularityAnalysis(agv, ("drive_L", "caster_drive")).scan()
    root = math.atan2(-(c - ay), ax)
    expected = np.sort([root, math.remainder(root + math.pi, 2 * math.pi)])
    np.testing.assert_allclose(np.sort(scan.configs[:, 0]), expected, atol=1e-12)
    # (caster_drive, caster_steer): det = (a_x - d cos s) / (d r_c), never 0 for |a_x| > d
    a = SingularityAnalysis(agv, ("caster_drive", "caster_steer"))
    s = np.linspace(-np.pi, np.pi, 13)
    np.testing.assert_allclose(a.det(s), (ax - p.d * np.cos(s)) / (p.d * p.r_c), rtol=1e-12)
    assert len(a.scan()) == 0
    # (drive_L, drive_R) does not depend on the caster: constant, regular
    a = SingularityAnalysis(agv, ("drive_L", "drive_R"))
    assert a.active() == () and len(a.scan()) == 0
    np.testing.assert_allclose(a.det(0.3), 2 * c / p.r**2)


def test_all_six_joints_never_singular(tw):
    """Redundant sensing with all six joints: J (6x3) has rank 3 for every steering
    configuration when d > 0 (a null twist would need an ICR at distance d from all three
    steering axes, impossible for axes that are not within d of one point)."""
    a = SingularityAnalysis(tw, tw.input_names)
    scan = a.scan(n=24)
    assert len(scan) == 0 and scan.min_ratio > 0.05
    rng = np.random.default_rng(9)
    cfg = rng.uniform(-np.pi, np.pi, size=(5000, 3))
    j = tw1_jacobian(tw.params, cfg)
    s = np.linalg.svd(j, compute_uv=False)
    assert np.min(s[:, -1] / s[:, 0]) > 0.05
    u = rng.normal(size=(5000, 3))
    np.testing.assert_allclose(a.forward(cfg, a.inverse(cfg, u)), u, atol=1e-12)
    # the same machine with S of size 3 is singular somewhere: the redundancy is what helps
    assert len(SingularityAnalysis(tw, ("steer_1", "steer_2", "steer_3")).scan(n=12)) > 0


def test_det_grid_and_condition(tw):
    a = SingularityAnalysis(tw, ("drive_1", "drive_2", "steer_3"))
    ga, gb, det = a.det_grid(axes=(0, 2), n=9, fixed=[0.0, 0.5, 0.0])
    assert det.shape == (9, 9)
    assert det[3, 5] == pytest.approx(float(a.det([ga[3], 0.5, gb[5]])), rel=1e-14, abs=1e-14)
    cfg = np.array([0.1, -0.2, 0.3])
    j = tw1_jacobian(tw.params, cfg)[0][a.rows]
    assert float(a.condition_number(cfg)) == pytest.approx(np.linalg.cond(j), rel=1e-10)
    assert float(a.det(cfg)) == pytest.approx(np.linalg.det(j), rel=1e-12)


def test_bad_arguments(tw, agv):
    with pytest.raises(ValueError, match="valid joints") as err:
        SingularityAnalysis(tw, ("drive_1", "drive_2", "drive_4"))
    assert "steer_3" in str(err.value)
    with pytest.raises(ValueError, match="valid joints"):
        SingularityAnalysis(agv, ("drive_L", "steer"))
    with pytest.raises(ValueError, match="repeat"):
        SingularityAnalysis(tw, ("drive_1", "drive_1", "steer_3"))
    with pytest.raises(ValueError, match="at least 3"):
        SingularityAnalysis(tw, ("drive_1", "drive_2"))
    with pytest.raises(TypeError, match="ThreeWheel or a CasterAGV"):
        SingularityAnalysis(SkidSteer(), ("drive_1",))
    with pytest.raises(TypeError, match="sequence"):
        SingularityAnalysis(agv, "drive_L")
    a = SingularityAnalysis(tw, TW_SETS[0])
    with pytest.raises(ValueError, match="config"):
        a.det(np.zeros(2))
    with pytest.raises(ValueError, match="finite"):
        a.det([0.0, np.nan, 0.0])
    assert issubclass(SingularConfigurationError, ValueError)


def test_singularity_map_example(tmp_path, capsys):
    import runpy
    from pathlib import Path

    script = Path(__file__).resolve().parents[2] / "examples" / "singularity_map.py"
    main = runpy.run_path(str(script))["main"]
    out = tmp_path / "map.png"
    main(["--out", str(out), "--n", "21"])
    assert out.stat().st_size > 10_000
    assert "drive_1', 'drive_2', 'steer_3'" in capsys.readouterr().out
