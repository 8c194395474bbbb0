"""The single env's step calls its kernels' compiled entry points (``WheelCore._direct``):
resolved once, they must give the bits of the dispatchers' path (``core.step`` on an array
that is not the core's own ``A``), and be entry points, not dispatchers."""

from __future__ import annotations

import copy

import numpy as np
import pytest

from tests.envs.conftest import make


@pytest.mark.parametrize(("robot", "mode", "task"), [("DiffDrive", None, "goal"),
                                                     ("SkidSteer", "velocity", "goal"),
                                                     ("Bicycle", None, "track")])
def test_direct_step_bits_equal_dispatch(robot, mode, task):
    env = make(robot, task=task, **({"action_mode": mode} if mode else {}))
    env.reset(seed=3)
    twin = copy.deepcopy(env)
    core, tcore = env.unwrapped.core, twin.unwrapped.core
    rng = np.random.default_rng(0)
    for i in range(30):
        a = rng.uniform(-1.2, 1.2, env.action_space.shape).astype(np.float32)
        if env.step(a)[2]:
            env.reset(seed=i)
            twin.reset(seed=i)
        else:
            tcore.step(a[None].astype(np.float64))
        for name in ("X", "B", "F", "obs", "terms", "pel", "steps"):
            assert getattr(core, name).tobytes() == getattr(tcore, name).tobytes(), name
    assert tcore._direct is None  # the twin never stepped on its own A
    ks, kp, ev, ctl = core._direct
    calls = [ks, kp, ev.func, *(ctl or ())]
    assert all(type(f).__name__ == "builtin_function_or_method" for f in calls)
    with pytest.raises(ValueError, match="finite"):
        env.step(np.full(env.action_space.shape, np.nan, dtype=np.float32))
