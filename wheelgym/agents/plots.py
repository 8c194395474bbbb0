"""Learning curves of the benchmark's runs, from their run folders' eval.csv
(``wheelgym benchmark --curves OUT.png``)."""

from __future__ import annotations

import csv
from collections.abc import Callable, Sequence
from pathlib import Path

import numpy as np

from wheelgym.agents.evaluate import _figure
from wheelgym.agents.store import parse_number

__all__ = ["plot_curves"]


def _mean(values: Sequence) -> float | None:
    vals = [float(v) for v in values if v is not None]
    return float(np.mean(vals)) if vals else None


def _eval_history(run_dir: Path) -> list[dict[str, float | None]]:
    path = run_dir / "eval.csv"
    if not path.is_file():
        return []
    with path.open(newline="") as f:
        return [{k: parse_number(v) for k, v in r.items() if k is not None}
                for r in csv.DictReader(f)]


def _draw(ax_s, ax_t, per_step: dict, n_runs: int, rs: list[dict[str, str]], rms: bool,
          scale: float, label: str, title: str) -> None:
    """One config's curves against steps (``ax_s``) and wall time (``ax_t``)."""
    xs = sorted(per_step)
    ys = [np.array([y for _, y in per_step[x]]) for x in xs]
    ws = [float(np.mean([w for w, _ in per_step[x]])) for x in xs]
    level = _mean([parse_number(r.get("baseline_eval_rms" if rms else "baseline_eval_success"))
                   for r in rs])
    for ax, x, xlabel in ((ax_s, xs, "environment steps"), (ax_t, ws, "wall time [s]")):
        if xs:
            ax.plot(x, [y.mean() for y in ys], color="C0", lw=1.5,
                    label=f"agent (mean of {n_runs})")
            ax.fill_between(x, [y.min() for y in ys], [y.max() for y in ys], color="C0",
                            alpha=0.25, lw=0, label="min-max over seeds")
        else:
            ax.text(0.5, 0.5, "no evaluation history", ha="center", va="center",
                    transform=ax.transAxes)
        if level is not None:
            ax.axhline(level * scale, color="C1", ls="--", lw=1.2, label="baseline")
        if rms and xs and min(float(y.min()) for y in ys) > 0:
            ax.set_yscale("log")  # agent and baseline errors differ by orders of magnitude
        ax.set_xlabel(xlabel)
        ax.set_ylabel(label)
        ax.set_title(title, fontsize=9)
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7, loc="best")


def plot_curves(rows: Sequence[dict[str, str]], configs: Sequence[str], out: str | Path,
                log: Callable[[str], None] | None = None) -> Path:
    """Learning curves of ``configs`` (names or config paths: their stems) from the rows' run
    folders: success rate (track: RMS error) against steps and against wall seconds, mean over
    seeds with the min-max spread, and the baseline's level on the same evaluation seeds."""
    names = [Path(c).stem for c in configs] if configs else sorted({r["config"] for r in rows})
    known = sorted({r["config"] for r in rows})
    bad = [n for n in names if n not in known]
    if bad:
        raise ValueError(f"configs {bad} have no rows in the CSV; configs there: {known}")
    groups: dict[tuple[str, int], list[dict[str, str]]] = {}
    for r in rows:
        if r["config"] in names:
            groups.setdefault((r["config"], int(float(r["n_timesteps"]))), []).append(r)
    keys = sorted(groups, key=lambda k: (names.index(k[0]), k[1]))
    fig = _figure(11.0, 3.2 * len(keys))
    axes = fig.subplots(len(keys), 2, squeeze=False)
    for (name, steps), (ax_s, ax_t) in zip(keys, axes, strict=True):
        rs = groups[(name, steps)]
        rms = any(parse_number(r.get("agent_rms")) is not None for r in rs)
        column = "rms_tracking_error" if rms else "success_rate"
        scale, label = (1.0, "RMS tracking error [m]") if rms else (100.0, "success [%]")
        per_step: dict[float, list[tuple[float, float]]] = {}
        n_runs = 0
        for r in rs:
            hist = [h for h in _eval_history(Path(r.get("run_dir", "")))
                    if h.get(column) is not None and h.get("timesteps") is not None]
            if not hist:
                if log is not None:
                    log(f"{name} seed {r['seed']}: no evaluation history in {r.get('run_dir')}")
                continue
            n_runs += 1
            for h in hist:
                per_step.setdefault(h["timesteps"], []).append(
                    (h.get("wall_s") or 0.0, h[column] * scale))
        _draw(ax_s, ax_t, per_step, n_runs, rs, rms, scale, label, f"{name} ({steps} steps)")
    fig.tight_layout()
    out = Path(out)
    out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out)
    return out
