"""The three-wheel paper's experiment (section 5, docs/physics/three-wheel.md TW-7)."""

import importlib.util
from pathlib import Path

import numpy as np
import pytest

from wheelgym.control.experiment import paper_experiment

EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "paper_circle.py"


@pytest.fixture(scope="module")
def default_run():
    return paper_experiment()  # 2 ms RK4 step, 60 s


def test_open_loop_reproduces_inverse_kinematics(default_run):
    r = default_run
    # the paper reports 1e-2 .. 1e-3 rad; measured 7.7e-12 (theta), 1.7e-12 (psi)
    assert np.abs(r["theta_error"]).max() <= 1e-6
    assert np.abs(r["psi_error"]).max() <= 1e-6
    np.testing.assert_allclose(r["x"][:, :3], r["pose"], atol=1e-6)
    # once around: the wheels turned, the torques are not trivial and stay within limits
    assert r["theta_ref"][-1].min() > 60.0
    assert 0.05 < np.abs(r["tau"]).max() < 6.0
    # the right rear wheel (2) turns further than the left (1), as in the paper's Fig. 4
    assert r["theta_ref"][-1, 1] > r["theta_ref"][-1, 0]


def test_error_converges_at_fourth_order():
    e1 = np.abs(paper_experiment(dt=0.02)["theta_error"]).max()
    e2 = np.abs(paper_experiment(dt=0.01)["theta_error"]).max()
    assert 10.0 < e1 / e2 < 25.0  # 16 for a fourth-order scheme; measured 18


def test_example_writes_figures(tmp_path):
    spec = importlib.util.spec_from_file_location("paper_circle", EXAMPLE)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    out = mod.main(["--out", str(tmp_path), "--low-res"])
    assert out["theta_error"] <= 1e-6
    for f in out["files"]:
        assert f.exists() and f.stat().st_size > 5000
        assert f.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_invalid_arguments():
    with pytest.raises(ValueError, match="dt"):
        paper_experiment(dt=0.007)
    with pytest.raises(TypeError, match="ThreeWheel"):
        paper_experiment(model=object())
