"""Pool workers of ``wheelgym benchmark`` end with their parent (``grid.end_with_parent``).

Killing the benchmark's process used to leave its spawned workers training on, orphaned, for
rows nobody would write, and slowing whatever ran next. Here a parent that spawns one worker is
killed (SIGKILL: no handler of its own runs); the worker must be gone within seconds, and
without the initializer (the control) it is not."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]

SCRIPT = textwrap.dedent("""
    import multiprocessing as mp
    import os
    import sys
    import time
    from concurrent.futures import ProcessPoolExecutor

    from wheelgym.agents.grid import end_with_parent

    if __name__ == "__main__":
        init = end_with_parent if sys.argv[1] == "on" else None
        pool = ProcessPoolExecutor(1, mp_context=mp.get_context("spawn"), initializer=init)
        print(pool.submit(os.getpid).result(), flush=True)
        time.sleep(120)
""")


def _alive(pid: int) -> bool:
    try:
        state = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
    except (FileNotFoundError, ProcessLookupError):
        return False
    return state not in ("Z", "X")  # a zombie has ended (its reaper may be slow)


def _orphan_alive_after_parent_killed(tmp_path: Path, mode: str) -> bool:
    script = tmp_path / "parent.py"
    script.write_text(SCRIPT)
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(ROOT),
                                                         os.environ.get("PYTHONPATH", "")])}
    parent = subprocess.Popen([sys.executable, str(script), mode], stdout=subprocess.PIPE,
                              text=True, env=env)
    try:
        child = int(parent.stdout.readline())
        assert _alive(child)
    finally:
        parent.send_signal(signal.SIGKILL)
        parent.wait(timeout=30)
    deadline = time.monotonic() + (10.0 if mode == "on" else 3.0)
    while time.monotonic() < deadline and _alive(child):
        time.sleep(0.1)
    alive = _alive(child)
    if alive:
        os.kill(child, signal.SIGKILL)
    return alive


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="PR_SET_PDEATHSIG is Linux's")
def test_a_worker_ends_with_its_parent(tmp_path):
    assert not _orphan_alive_after_parent_killed(tmp_path, "on")


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="the control of the above")
def test_without_it_the_worker_outlives_its_parent(tmp_path):
    assert _orphan_alive_after_parent_killed(tmp_path, "off")
