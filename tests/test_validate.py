"""The validation report (``python -m wheelgym.validate``)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from wheelgym import validate as V
from wheelgym.models import Model, SkidSteer


def test_report_for_skid_steer_passes(capsys):
    assert V.main(["--model", "SkidSteer"]) == 0
    out = capsys.readouterr().out
    assert out.startswith("| check | model | measured | bound | pass |")
    rows = [line for line in out.splitlines() if line.startswith("| ") and "SkidSteer" in line]
    assert len(rows) == 11 and all(line.endswith("| yes |") for line in rows)


def test_failing_check_gives_exit_code_1(monkeypatch, capsys):
    monkeypatch.setitem(V.BOUNDS, "refinement", 1e-30)
    assert V.main(["--model", "SkidSteer"]) == 1
    assert "| NO |" in capsys.readouterr().out


def test_unknown_model_is_rejected():
    with pytest.raises(SystemExit):
        V.main(["--model", "Hovercraft"])


def test_model_discovery():
    classes = V.model_classes()
    assert SkidSteer in classes and Model not in classes
    assert all(issubclass(c, Model) for c in classes)


def test_bisect_and_stability_limit():
    assert V._bisect(lambda x: x * x - 2.0, 0.0, 2.0) == pytest.approx(math.sqrt(2), rel=1e-15)
    with pytest.raises(ValueError):
        V._bisect(lambda x: x * x + 1.0, -1.0, 1.0)
    # RK4's amplification 1 + z + z^2/2 + z^3/6 + z^4/24 has modulus 1 at z = -limit
    z = -V.RK4_REAL_STABILITY_LIMIT
    assert abs(1 + z + z**2 / 2 + z**3 / 6 + z**4 / 24) == pytest.approx(1.0, abs=1e-12)
    z = -1.01 * V.RK4_REAL_STABILITY_LIMIT
    assert abs(1 + z + z**2 / 2 + z**3 / 6 + z**4 / 24) > 1.0


def test_generic_manoeuvre_shape_and_scale():
    model = SkidSteer()
    u = V.manoeuvre(model, 100, 0.05)
    assert u.shape == (100, 4)
    assert np.max(np.abs(u)) <= 0.5 * model.params.tau_max
    assert np.max(np.abs(u)) > 0.45 * model.params.tau_max
