"""Unicycle input modes: a wheel-speed command moves at r phidot, a vehicle-speed command at v;
domain randomisation of the wheel radius acts (or is refused where it cannot)."""

from __future__ import annotations

import numpy as np
import pytest

from tests.envs.conftest import make
from wheelgym.models import Unicycle

WS, VS = "WheelSpeedHeadingRate", "VehicleSpeedHeadingRate"


def _speeds(mode: str, randomize, steps: int = 10, a=(0.5, 0.3)) -> tuple[np.ndarray, dict]:
    env = make("Unicycle", task="goal", action_mode=mode, randomize=randomize)
    _, info = env.reset(seed=0)
    out = []
    for _ in range(steps):
        _, _, term, _, inf = env.step(np.array(a, dtype=np.float32))
        out.append(inf["pose"])
        assert not term
    return np.array(out), info["params"]


def test_model_modes_differ_by_the_radius():
    x = np.zeros(3)
    m_ws = Unicycle(wheel_radius=0.08, input_mode=WS)
    m_vs = Unicycle(wheel_radius=0.08, input_mode=VS)
    assert m_ws.effective_input(x, [5.0, 0.1])[0] == pytest.approx(0.4)  # v = r phidot
    assert m_vs.effective_input(x, [0.5, 0.1])[0] == pytest.approx(0.5)  # v commanded


def test_wheel_speed_mode_drives_at_the_drawn_radius():
    nominal, _ = _speeds(WS, None)
    big, params = _speeds(WS, {"wheel_radius": (1.2, 1.2)})
    assert params["wheel_radius"] == pytest.approx(0.12)
    # same wheel speeds, 1.2 x the radius: 1.2 x the distance (same heading history)
    d_nom = np.hypot(*(nominal[-1, :2] - nominal[0, :2]))
    d_big = np.hypot(*(big[-1, :2] - big[0, :2]))
    assert d_big == pytest.approx(1.2 * d_nom, rel=1e-6)
    np.testing.assert_allclose(big[:, 2] - big[0, 2], nominal[:, 2] - nominal[0, 2],
                               atol=1e-12)  # (the draw shifts the random start)


def test_randomize_true_changes_the_motion_in_wheel_speed_mode():
    a, pa = _speeds(WS, True)
    b, _ = _speeds(WS, None)
    assert pa["wheel_radius"] != 0.1
    assert not np.allclose(a, b)


def test_modes_differ_under_the_same_radius_draw():
    rnd = {"wheel_radius": (0.5, 0.5)}
    ws, _ = _speeds(WS, rnd, a=(0.8, 0.0))
    vs, _ = _speeds(VS, rnd, a=(0.8, 0.0))
    # wheel speed: v = 0.05 * 0.8 * 10 = 0.4; vehicle speed: 0.8 cut by the wheel-speed
    # limit to 0.05 * 15 = 0.75
    assert np.hypot(*ws[-1, :2]) - np.hypot(*ws[0, :2]) != pytest.approx(0.0)
    step_ws = np.hypot(*(ws[1, :2] - ws[0, :2])) / 0.05
    step_vs = np.hypot(*(vs[1, :2] - vs[0, :2])) / 0.05
    assert step_ws == pytest.approx(0.4, rel=1e-6)  # (float32 action)
    assert step_vs == pytest.approx(0.75, rel=1e-6)


@pytest.mark.parametrize("rnd", [True, {"wheel_radius": (0.9, 1.1)}])
def test_vehicle_speed_mode_refuses_randomisation_that_cannot_act(rnd):
    with pytest.raises(ValueError, match="cannot change the motion.*WheelSpeedHeadingRate"):
        make("Unicycle", action_mode=VS, randomize=rnd)


def test_vehicle_speed_mode_without_randomisation_unchanged():
    a, _ = _speeds(VS, None)
    b, _ = _speeds(WS, None)
    np.testing.assert_allclose(a, b, atol=1e-12)  # the nominal radius: one motion
