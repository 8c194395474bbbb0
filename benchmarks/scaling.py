"""Speed-up of ``wheelgym benchmark``: one small grid on the local pool with 1 and 2 workers and
on a local Ray instance with 2 CPUs, wall-clock each (the commands as a user types them, so
process start, Ray start and baseline scoring are included).

Usage: ``python benchmarks/scaling.py [--budget 10000] [--seeds 2] [--episodes 5] [CONFIGS]``
(default configs: ThreeWheel-goal-velocity and SkidSteer-goal-velocity). Each mode writes a
fresh CSV in a temporary folder; the rows of the three modes are checked to agree (all columns
but the timing ones), then a Markdown table is printed. Needs the ``cluster`` extra for Ray.
"""

from __future__ import annotations

import argparse
import os
import platform
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from wheelgym.agents.benchmark import read_rows
from wheelgym.agents.config import configs_dir

TIMING = ("train_s", "cpu_s", "finished_utc", "run_dir")
MODES: tuple[tuple[str, list[str]], ...] = (
    ("local, 1 worker", ["--workers", "1"]),
    ("local, 2 workers", ["--workers", "2"]),
    ("Ray (local, 2 CPUs)", ["--ray", "local", "--workers", "2"]),
)


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("configs", nargs="*", type=Path)
    p.add_argument("--budget", type=int, default=10_000)
    p.add_argument("--seeds", type=int, default=2)
    p.add_argument("--episodes", type=int, default=5)
    a = p.parse_args()
    configs = a.configs or [configs_dir() / "ThreeWheel-goal-velocity.yml",
                            configs_dir() / "SkidSteer-goal-velocity.yml"]
    grid = [*map(str, configs), "--seeds", str(a.seeds), "--budget", str(a.budget),
            "--episodes", str(a.episodes)]
    results: list[tuple[str, str, float]] = []
    reference: list[dict] | None = None
    load0 = os.getloadavg()[0]
    env = {**os.environ, "RAY_ENABLE_WINDOWS_OR_OSX_CLUSTER": "0"}  # Ray on 127.0.0.1 only
    with tempfile.TemporaryDirectory(prefix="wheelgym-scaling-") as tmp:
        for i, (label, extra) in enumerate(MODES):
            csv_path = Path(tmp) / f"mode{i}.csv"
            argv = ["benchmark", *grid, "--csv", str(csv_path), "--runs-root",
                    str(Path(tmp) / f"runs{i}"), *extra]
            t0 = time.perf_counter()
            done = subprocess.run([sys.executable, "-m", "wheelgym.cli", *argv], env=env,
                                  capture_output=True, text=True)
            wall = time.perf_counter() - t0
            if done.returncode != 0:
                print(f"{label}: failed (rc {done.returncode}): {done.stderr[-600:]}",
                      file=sys.stderr)
                return 1
            rows = sorted(({k: v for k, v in r.items() if k not in TIMING}
                           for r in read_rows(csv_path)), key=lambda r: (r["config"], r["seed"]))
            if len(rows) != len(configs) * a.seeds:
                print(f"{label}: {len(rows)} rows", file=sys.stderr)
                return 1
            same = "reference" if reference is None else ("yes" if rows == reference else "NO")
            reference = reference or rows
            shown = ["wheelgym", *argv[:1], "...", *extra]
            results.append((label, " ".join(shown), wall))
            print(f"{label}: {wall:.1f} s (rows equal to 1 worker's: {same})", flush=True)
    base = results[0][2]
    print(f"\n{len(configs)} configs x {a.seeds} seeds x {a.budget} steps, {a.episodes} "
          f"evaluation episodes; {os.cpu_count()} CPUs, {platform.processor() or 'cpu'}, "
          f"load average at the start {load0:.1f}\n")
    print("| mode | command | wall [s] | speed-up |")
    print("|---|---|---|---|")
    for label, cmd, wall in results:
        print(f"| {label} | `{cmd}` | {wall:.1f} | {base / wall:.2f}x |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
