"""Pick the faster of two step kernels that give the same bits, by timing them in use.

The threaded step kernel (``k_env_step_par``) is up to ~2x faster than the serial one on an
idle 2-core machine, but OpenMP's waiting makes it several times slower when other processes
hold the cores (measured: DiffDrive at N = 1024, 1.85M -> 0.13M env-steps/s). Both kernels
write the same bits, so which one runs never changes a result: :class:`FasterKernel` runs the
one measured faster and now and then times the other, backing off while it keeps losing.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import Any

__all__ = ["FasterKernel"]


class FasterKernel:
    """Call ``kernels[best]``; every ``probe`` calls time the other one instead.

    Args:
        serial, parallel: kernels with the same signature and the same outputs.
        probe_min, probe_max: calls between probes of the losing kernel: ``probe_min`` after a
            switch, doubling (up to ``probe_max``) each time a probe loses again.
        clock: seconds counter (``time.perf_counter``; injectable for tests).

    The first call of each kernel (compilation, thread start-up) is not timed; the time of the
    running kernel is a moving average (weight 1/4 on the newest call), the probed one's is its
    last probe.
    """

    def __init__(self, serial: Callable[..., Any], parallel: Callable[..., Any], *,
                 probe_min: int = 16, probe_max: int = 1024,
                 clock: Callable[[], float] = time.perf_counter) -> None:
        self.kernels = (serial, parallel)
        self.cost = [0.0, 0.0]  # seconds a call; 0: not measured yet
        self.calls = [0, 0]
        self.best = 1  # start threaded; the first probe times the serial kernel
        self.probe_min = probe_min
        self.probe_max = probe_max
        self.interval = probe_min
        self.countdown = 3  # calls 1-2 run (and time) the threaded kernel, 3-4 the serial
        self.clock = clock

    def __call__(self, *args: Any) -> Any:
        self.countdown -= 1
        probing = self.countdown <= 0
        k = 1 - self.best if probing else self.best
        t0 = self.clock()
        out = self.kernels[k](*args)
        dt = self.clock() - t0
        self.calls[k] += 1
        if self.calls[k] == 1:  # compile / thread start-up: not representative
            if probing:
                self.countdown = 1
            return out
        c = self.cost[k]
        self.cost[k] = dt if (probing or c == 0.0) else 0.75 * c + 0.25 * dt
        if probing:
            other = self.cost[1 - k]
            if other == 0.0 or dt < other:  # the probed kernel wins: switch
                self.best = k
                self.interval = self.probe_min
            else:
                self.interval = min(2 * self.interval, self.probe_max)
            self.countdown = self.interval
        return out
