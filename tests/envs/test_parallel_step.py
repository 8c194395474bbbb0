"""The threaded step kernel (``k_env_step_par``, used from ``PAR_MIN_ROWS`` rows) against the
serial one: every row's bits must be the same, and small batches must stay serial."""

from __future__ import annotations

import subprocess
import sys

import numba
import numpy as np
import pytest

from wheelgym.envs._dispatch import FasterKernel
from wheelgym.envs.core import WheelCore
from wheelgym.envs.robots import available_robots, get_spec
from wheelgym.envs.robots.body import PAR_MIN_ROWS

N = PAR_MIN_ROWS + 7  # above the threshold, not a multiple of the thread count


def _run(kernel, core, A, n_sub):
    Xo = np.full_like(core.X, -7.0)
    B = core.B.copy()
    F = core.F.copy()
    ok = kernel(core.X, A, core.LH, core.P, core.h, n_sub, Xo, B, F)
    return ok, Xo, B, F


def _same_bits(a, b) -> bool:
    return a.shape == b.shape and np.array_equal(a.view(np.uint8), b.view(np.uint8))


@pytest.mark.parametrize("robot, dc", [
    *((r, False) for r in available_robots()),
    # the DC-motor kernels: slow, as make test's warm-up leaves the threaded ones out
    *(pytest.param(r, True, marks=pytest.mark.slow) for r in available_robots()
      if get_spec(r).has_dc_motors)])
def test_parallel_kernel_same_bits_as_serial(robot, dc):
    spec = get_spec(robot)
    core = WheelCore(robot, N, randomize=True if spec.default_randomize else None,
                     **({"motor": "dc"} if dc else {}))
    assert core.dc == dc
    serial, par = spec.step_kernels(dc, N)
    if numba.config.NUMBA_NUM_THREADS > 1:
        assert core._k_step.kernels == (serial, par)
    else:  # NUMBA_NUM_THREADS=1 exported: the core keeps the serial kernel; the bits still
        assert core._k_step is serial  # compare below (threaded on 1 thread)
    core.reset(None, [np.random.default_rng(i) for i in range(N)])
    rng = np.random.default_rng(3)
    core.X[5, 3:] = np.inf  # a row whose step fails: restored, F_OK False
    for step in range(3):
        A = rng.uniform(-1.5, 1.5, (N, core.m))  # inside and outside [-1, 1]
        s = _run(serial, core, A, core.n_sub)
        p = _run(par, core, A, core.n_sub)
        assert s[0] and p[0]
        for a, b in zip(s[1:], p[1:], strict=True):
            assert _same_bits(a, b), f"{robot} step {step}"
        if spec.n_motor and step == 0:
            assert not s[3][5, 1] and s[3][:, 0].any()  # the failure and clipping paths ran
        assert not (s[1] == core.X).all()  # the state moved
        core.X[:] = s[1]
    # a non-finite action: nothing is written, as in the serial kernel
    A[N - 1, 0] = np.nan
    p = _run(par, core, A, core.n_sub)
    assert not p[0] and (p[1] == -7.0).all() and _same_bits(p[2], core.B)


def test_core_dispatch_on_batch_size(monkeypatch):
    spec = get_spec("SkidSteer")
    monkeypatch.setattr(numba.config, "NUMBA_NUM_THREADS", 2)  # whatever the caller exported
    assert WheelCore("SkidSteer", 1)._k_step is spec.k_env_step
    assert WheelCore("SkidSteer", PAR_MIN_ROWS - 1)._k_step is spec.k_env_blocks
    assert isinstance(WheelCore("SkidSteer", PAR_MIN_ROWS)._k_step, FasterKernel)
    monkeypatch.setattr(numba.config, "NUMBA_NUM_THREADS", 1)
    assert WheelCore("SkidSteer", PAR_MIN_ROWS)._k_step is spec.k_env_blocks


def test_single_env_starts_no_numba_threads():
    code = (
        "import gymnasium as gym, numpy as np, wheelgym\n"
        "import numba.np.ufunc.parallel as par\n"
        "env = gym.make('wheelgym/ThreeWheel-v0')\n"
        "env.reset(seed=0)\n"
        "for _ in range(3):\n"
        "    env.step(env.action_space.sample())\n"
        "print(par._is_initialized)\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True, timeout=300)
    assert out.stdout.strip().splitlines()[-1] == "False"


class _Clock:
    """A fake seconds counter that each fake kernel advances by its cost."""

    def __init__(self) -> None:
        self.t = 0.0

    def __call__(self) -> float:
        return self.t


def test_faster_kernel_follows_the_cheaper_kernel():
    clock = _Clock()
    cost = {"serial": 1.0, "parallel": 3.0}
    log = []

    def kernel(name):
        def run(x):
            clock.t += cost[name]
            log.append(name)
            return x + 1

        return run

    fk = FasterKernel(kernel("serial"), kernel("parallel"), probe_min=4, probe_max=32,
                      clock=clock)
    assert [fk(i) for i in range(4)] == [1, 2, 3, 4]  # outputs pass through
    assert log == ["parallel", "parallel", "serial", "serial"]
    assert fk.best == 0  # serial measured cheaper
    log.clear()
    for i in range(200):
        fk(i)
    # probes of the losing threaded kernel back off: 4, 8, 16, 32, 32... calls apart
    assert log.count("parallel") == 8 and fk.interval == 32
    cost["parallel"] = 0.5  # the other cores became free
    log.clear()
    for i in range(40):
        fk(i)
    assert fk.best == 1 and log[-1] == "parallel" and fk.interval > 4  # serial backs off


def test_threaded_body_calls_the_row_kernel_with_an_int64_index():
    """numba types a ``prange`` index int64 when it first types a function and uint64 in the
    threaded loop body; :func:`env_step_body_par` casts it, so the robot's row kernel
    (CasterAGV and the kinematic robots) compiles once, not twice."""
    from numba import njit

    from wheelgym.envs.robots.body import env_step_body_par

    @njit
    def row(i, X, A, LH, P, h, n, Xo, B, F, work):
        Xo[i, 0] = X[i, 0] + i

    @njit(parallel=True)
    def par(X, A, LH, P, h, n, Xo, B, F):
        return env_step_body_par(row, X, A, LH, P, h, n, Xo, B, F)

    X = np.arange(6.0).reshape(3, 2)
    Xo = np.zeros_like(X)
    assert par(X, np.zeros((3, 1)), X, X, 0.1, 1, Xo, X.copy(), np.zeros((3, 1), bool))
    assert (Xo[:, 0] == X[:, 0] + np.arange(3)).all()
    assert [str(sig[0]) for sig in row.signatures] == ["int64"], row.signatures
