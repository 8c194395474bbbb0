"""The results table, generated from the results CSV (:mod:`wheelgym.agents.store`).

One line per (config, algo, steps, episodes) over its seeds: the recipe (the config's pipeline
in short: ``scratch``, ``clone+rl``, ``rl+distill``, ...), the number of seeds ``n``, and for
success (and RMS error on ``track``) the mean, the interquartile mean (:func:`iqm`) with a 95%
bootstrap confidence interval (:func:`bootstrap_ci`, a seeded generator: the same table every
time) and the worst seed. The targets (:func:`load_targets`, the data file
``wheelgym/agents/targets.yml``) are judged on the means (``met`` or the ones missed, in bold)
and on the worst seeds, whose success has targets of its own (``worst_seed_*``): success on
the lowest-success seed, on ``track`` the other targets on the largest-RMS seed.

:func:`format_table` is the full Markdown table, :func:`results_page` the page
``docs/topics/results.md`` around it (with the learning-curve images), :func:`readme_summary`
the short summary that :func:`update_readme` puts between the README's markers
(:data:`README_BEGIN`, :data:`README_END`), :func:`navigate_rows` the navigate configs' seeds
that :func:`update_between` puts between :data:`NAVIGATE_BEGIN` and :data:`NAVIGATE_END`
(``docs/topics/planning.md``).
"""

from __future__ import annotations

import importlib.resources
import math
import zlib
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from wheelgym import safe_yaml
from wheelgym.agents.store import parse_number

__all__ = ["TABLE_HEAD", "README_BEGIN", "README_END", "load_targets", "target_misses", "iqm",
           "bootstrap_ci", "format_table", "results_page", "readme_summary", "update_readme",
           "readme_table", "NAVIGATE_BEGIN", "NAVIGATE_END", "navigate_rows", "update_between",
           "between"]

#: Resamples of the bootstrap, and the seed its generators start from (per cell: this plus a
#: CRC of the config name and column, so that a cell does not depend on the table's order).
BOOTSTRAP_RESAMPLES = 10_000
BOOTSTRAP_SEED = 36
_TARGET_KEYS = ("goal_success", "track_success", "below_baseline", "rms_factor", "rms_floor",
                "internal_force_factor", "energy_factor", "saturation", "train_s",
                "worst_seed_success", "worst_seed_below_baseline")


def load_targets(path: str | Path | None = None) -> dict[str, float]:
    """The targets: ``path`` or the package's ``targets.yml``; ``ValueError`` naming a missing,
    unknown or non-numeric key."""
    if path is None:
        res = importlib.resources.files("wheelgym.agents") / "targets.yml"
        with importlib.resources.as_file(res) as p:
            data = safe_yaml.load(p, "targets")
        where = "wheelgym/agents/targets.yml"
    else:
        data, where = safe_yaml.load(path, "targets"), str(path)
    if not isinstance(data, dict):
        raise ValueError(f"{where}: must be a mapping of {list(_TARGET_KEYS)}")
    bad = sorted(set(data) ^ set(_TARGET_KEYS))
    if bad:
        raise ValueError(f"{where}: keys {bad} missing or unknown; the keys: {list(_TARGET_KEYS)}")
    out = {}
    for k in _TARGET_KEYS:
        v = data[k]
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
            raise ValueError(f"{where}: {k} must be a finite number, got {v!r}")
        out[k] = float(v)
    return out


# --------------------------------------------------------------------------------------------
# statistics over seeds
# --------------------------------------------------------------------------------------------


def _mean(values: Sequence[Any]) -> float | None:
    vals = [float(v) for v in values if v is not None]
    return float(np.mean(vals)) if vals else None


def iqm(values: Sequence[float]) -> float:
    """The interquartile mean: the mean of the sorted values whose rank midpoint
    ``(i + 1/2) / n`` lies in ``[1/4, 3/4]`` (the middle half; of 3 values the middle one, of 4
    the middle two, of 5 the middle three; Agarwal et al. 2021). ``ValueError`` when empty."""
    a = np.sort(np.asarray(values, dtype=np.float64))
    n = len(a)
    if n == 0:
        raise ValueError("iqm of no values")
    mid = (np.arange(n) + 0.5) / n
    return float(a[(mid >= 0.25 - 1e-12) & (mid <= 0.75 + 1e-12)].mean())


def bootstrap_ci(values: Sequence[float], key: str, level: float = 0.95,
                 resamples: int = BOOTSTRAP_RESAMPLES) -> tuple[float, float]:
    """The percentile bootstrap confidence interval of :func:`iqm` over ``values`` (seeds
    resampled with replacement), from a generator seeded with :data:`BOOTSTRAP_SEED` and a
    CRC-32 of ``key``: the same interval every time for the same values and key."""
    a = np.asarray(values, dtype=np.float64)
    rng = np.random.default_rng([BOOTSTRAP_SEED, zlib.crc32(key.encode())])
    idx = rng.integers(0, len(a), size=(resamples, len(a)))
    stats = np.sort(a[idx], axis=1)
    n = len(a)
    mid = (np.arange(n) + 0.5) / n
    keep = (mid >= 0.25 - 1e-12) & (mid <= 0.75 + 1e-12)
    boot = stats[:, keep].mean(axis=1)
    lo, hi = np.quantile(boot, [(1 - level) / 2, (1 + level) / 2])
    return float(lo), float(hi)


# --------------------------------------------------------------------------------------------
# targets
# --------------------------------------------------------------------------------------------


def target_misses(config: str, col: Callable[[str], list[float | None]],
                  targets: dict[str, float] | None = None, worst_seed: bool = False) -> list[str]:
    """The targets (:func:`load_targets`) that the means over seeds of a config's rows miss.

    ``config`` is a config name ``Robot-task-mode[-...]`` (the task is its second field);
    ``col(name)`` gives the CSV column ``name`` of the config's rows as numbers.
    ``worst_seed``: the rows are the worst seed's alone, whose success is judged on the
    ``worst_seed_*`` targets (goal and track ``>= worst_seed_success``, goal and navigate
    ``>= baseline - worst_seed_below_baseline``); the other targets are the same."""
    t = load_targets() if targets is None else targets
    parts = config.split("-")
    task = parts[1] if len(parts) > 1 else ""
    m = {c: _mean(col(c)) for c in (
        "agent_success", "baseline_success", "agent_rms", "baseline_rms", "agent_energy",
        "baseline_energy", "agent_internal_force", "baseline_internal_force",
        "agent_saturation", "train_s")}
    miss = []
    succ, base = m["agent_success"], m["baseline_success"]
    if succ is not None:
        if worst_seed:
            floor = t["worst_seed_success"] if task in ("goal", "track") else 0.0
            below = t["worst_seed_below_baseline"]
        else:
            floor = {"goal": t["goal_success"], "track": t["track_success"]}.get(task, 0.0)
            below = t["below_baseline"]
        if base is not None:
            floor = max(floor, base - below) if task != "track" else floor
        if succ < floor - 1e-9:
            miss.append("success")
    if task == "track" and m["agent_rms"] is not None and m["baseline_rms"] is not None:
        if m["agent_rms"] > max(t["rms_factor"] * m["baseline_rms"], t["rms_floor"]):
            miss.append("RMS")
    if config.endswith("-torque") or "-torque-" in config:
        xf, bxf = m["agent_internal_force"], m["baseline_internal_force"]
        if xf is not None and bxf is not None and xf > t["internal_force_factor"] * bxf:
            miss.append("internal force")
        e, be = m["agent_energy"], m["baseline_energy"]
        if (xf is not None and e is not None and be is not None
                and e > t["energy_factor"] * be):
            miss.append("energy")
    if m["agent_saturation"] is not None and m["agent_saturation"] > t["saturation"]:
        miss.append("saturation")
    if m["train_s"] is not None and m["train_s"] > t["train_s"]:
        miss.append("time")
    return miss


# --------------------------------------------------------------------------------------------
# cells
# --------------------------------------------------------------------------------------------


def _cell(values: Sequence[float | None], scale: float, digits: int, spread: bool = True) -> str:
    vals = [v for v in values if v is not None]
    if not vals:
        return "-"
    a = np.asarray(vals, dtype=np.float64) * scale
    if len(a) == 1 or not spread:
        return f"{a.mean():.{digits}f}"
    return f"{a.mean():.{digits}f} ± {a.std():.{digits}f}"


def _reach_cell(values: Sequence[float | None]) -> str:
    hit = [v for v in values if v is not None]
    if not hit:
        return "never"
    mean = float(np.mean(hit))
    text = f"{mean / 1000:.0f}k" if mean >= 10_000 else f"{mean:.0f}"
    return text if len(hit) == len(values) else f"{text} ({len(hit)}/{len(values)})"


def _duration(seconds: float) -> str:
    if seconds < 120:
        return f"{seconds:.0f} s"
    if seconds < 7200:
        return f"{seconds / 60:.1f} min"
    return f"{seconds / 3600:.1f} h"


def _ratio_cell(col: Callable[[str], list[float | None]], agent: str, base: str) -> str:
    a, b = _mean(col(agent)), _mean(col(base))
    if a is None or b is None or b <= 0.0:
        return "-"
    return f"{a / b:.2f}x" if a / b < 100 else f"{a / b:.0f}x"


def _iqm_cell(values: Sequence[float | None], scale: float, digits: int, key: str) -> str:
    """``IQM [lo, hi]`` (95% bootstrap CI) of the values given, scaled; ``-`` when none."""
    vals = [float(v) * scale for v in values if v is not None]
    if not vals:
        return "-"
    lo, hi = bootstrap_ci(vals, key)
    return f"{iqm(vals):.{digits}f} [{lo:.{digits}f}, {hi:.{digits}f}]"


def _worst(rs: list[dict[str, str]], rms: bool) -> dict[str, str]:
    """The worst seed's row: the lowest success, or with ``rms`` the largest RMS error (ties: the
    lowest seed)."""
    def badness(r: dict[str, str]) -> tuple:
        if rms:
            v = parse_number(r.get("agent_rms"))
            return (-(v if v is not None else math.inf), int(float(r["seed"])))
        v = parse_number(r.get("agent_success"))
        return ((v if v is not None else -math.inf), int(float(r["seed"])))

    return min(rs, key=badness)


def _targets_cell(name: str, rs: list[dict[str, str]], targets: dict[str, float]) -> str:
    """The targets the means over ``rs`` miss, in bold, or ``met``."""
    def col(c: str, rs: list[dict[str, str]] = rs) -> list[float | None]:
        return [parse_number(r.get(c)) for r in rs]

    return ", ".join(f"**{m}**" for m in target_misses(name, col, targets)) or "met"


def _worst_seed_cell(name: str, rs: list[dict[str, str]], targets: dict[str, float]) -> str:
    """The worst-seed targets missed, in bold, or ``met``: success judged on the lowest-success
    seed, and on track the other targets on the largest-RMS seed (goal and navigate: the
    lowest-success seed for all), so that neither worst seed hides behind the other."""
    def misses(r: dict[str, str]) -> list[str]:
        return target_misses(name, lambda c: [parse_number(r.get(c))], targets, worst_seed=True)

    by_success = misses(_worst(rs, rms=False))
    rms = any(parse_number(r.get("agent_rms")) is not None for r in rs)
    rest = [m for m in misses(_worst(rs, rms)) if m != "success"]
    got = (["success"] if "success" in by_success else []) + rest
    return ", ".join(f"**{m}**" for m in got) or "met"


TABLE_HEAD: tuple[str, ...] = (
    "config", "recipe", "algo", "steps", "n", "episodes",
    "success mean [%]", "success IQM [95% CI] [%]", "worst seed success [%]",
    "baseline success [%]", "random success [%]",
    "RMS mean [m]", "RMS IQM [95% CI] [m]", "worst seed RMS [m]", "baseline RMS [m]",
    "agent return", "baseline return", "random return",
    "energy / baseline", "internal force / baseline", "agent saturation [%]",
    "steps to baseline", "train [s/seed]", "targets (mean)", "targets (worst seed)",
)


def _recipe(rs: list[dict[str, str]], recipes: dict[str, str] | None) -> str:
    """The rows' ``recipe`` column, else the config file's (``recipes``), else ``?``."""
    got = sorted({r.get("recipe") or "" for r in rs} - {""})
    if got:
        return ", ".join(got)
    return (recipes or {}).get(rs[0]["config"], "?")


def _line(key: tuple[str, str, int, int], rs: list[dict[str, str]],
          targets: dict[str, float], recipes: dict[str, str] | None) -> str:
    name, algo, steps, eps = key

    def col(c: str, rs: list[dict[str, str]] = rs) -> list[float | None]:
        return [parse_number(r.get(c)) for r in rs]

    rms = any(v is not None for v in col("agent_rms"))
    low = _worst(rs, rms=False)  # the lowest success
    far = _worst(rs, rms=True)  # the largest RMS error (track)
    return "| " + " | ".join([
        name, _recipe(rs, recipes), algo.upper(), str(steps), str(len(rs)), str(eps),
        _cell(col("agent_success"), 100, 0, False),
        _iqm_cell(col("agent_success"), 100, 0, f"{name}/success"),
        _cell([parse_number(low.get("agent_success"))], 100, 0, False) + f" (s{low['seed']})",
        _cell(col("baseline_success"), 100, 0, False), _cell(col("random_success"), 100, 0, False),
        _cell(col("agent_rms"), 1, 3, False), _iqm_cell(col("agent_rms"), 1, 3, f"{name}/rms"),
        _cell([parse_number(far.get("agent_rms"))], 1, 3, False) + (
            f" (s{far['seed']})" if rms else ""),
        _cell(col("baseline_rms"), 1, 3, False),
        _cell(col("agent_return"), 1, 1), _cell(col("baseline_return"), 1, 1, False),
        _cell(col("random_return"), 1, 1, False),
        _ratio_cell(col, "agent_energy", "baseline_energy"),
        _ratio_cell(col, "agent_internal_force", "baseline_internal_force"),
        _cell(col("agent_saturation"), 100, 0), _reach_cell(col("steps_to_baseline")),
        _cell(col("train_s"), 1, 0, False), _targets_cell(name, rs, targets),
        _worst_seed_cell(name, rs, targets),
    ]) + " |"


TABLE_NOTE = (
    "n: seeds (rows). Success and RMS: each seed's mean over the evaluation episodes, then over "
    "the seeds the mean, the interquartile mean (the mean of the middle half of the sorted "
    "values: of 3 seeds the middle one, of 5 the middle three) with its 95% percentile "
    "bootstrap confidence interval (seeds resampled, {resamples} resamples, seeded generator), "
    "and the worst seed (lowest success; RMS: largest error) with its number; with n = 3 "
    "the interval spans at most the seeds' range. Baseline and random: mean over the same "
    "episodes. Agent return and saturation: mean ± std over seeds. Steps to baseline: first "
    "periodic evaluation within 5 points of the baseline's success (track: within 2x its RMS "
    "error), mean over the seeds that reached it. Energy and internal force: the agent's mean "
    "over the baseline's. Targets (wheelgym/agents/targets.yml), judged on the means and "
    "stated for the worst seeds alone (success on the lowest-success seed; on track the other "
    "targets on the largest-RMS seed): `met`, or the ones missed in bold (success: goal "
    ">= {goal:.0f}% and >= baseline - {below:.0f} points, navigate >= baseline - {below:.0f}, "
    "track >= {track:.0f}%; the worst seed: goal and track >= {wgoal:.0f}%, goal and navigate "
    ">= baseline - {wbelow:.0f}; RMS <= max({rf:g}x baseline, {floor:g} m); torque mode internal "
    "force <= {xf:g}x and energy <= {ef:g}x the baseline's where internal force is defined; "
    "saturation <= {sat:.0f}%; time <= {ts:.0f} s/seed). Recipe: the config's pipeline "
    "(scratch: RL only; clone: imitating the analytic baseline; clone-true: imitating it with "
    "the true, perturbed parameters; plan-clone: imitating the "
    "planning baseline; distill: the policy refitted without its internal force)."
)


def _groups(rows: Sequence[dict[str, str]]) -> dict[tuple[str, str, int, int], list]:
    groups: dict[tuple[str, str, int, int], list[dict[str, str]]] = {}
    for r in rows:
        key = (r["config"], r.get("algo", ""), int(float(r["n_timesteps"])),
               int(float(r.get("episodes") or 0)))
        groups.setdefault(key, []).append(r)
    return groups


def format_table(rows: Sequence[dict[str, str]], recipes: dict[str, str] | None = None,
                 targets: dict[str, float] | None = None) -> str:
    """The Markdown results table of CSV rows: one line per (config, algo, steps, episodes),
    then the note on its columns and the total CPU time of the rows (``cpu_s``, else
    ``train_s``). ``recipes``: config name -> recipe for rows without a ``recipe`` column."""
    t = load_targets() if targets is None else targets
    lines = ["| " + " | ".join(TABLE_HEAD) + " |", "|" + "---|" * len(TABLE_HEAD)]
    cpu = sum(parse_number(r.get("cpu_s")) or parse_number(r.get("train_s")) or 0.0
              for r in rows)
    for key, rs in sorted(_groups(rows).items()):
        lines.append(_line(key, rs, t, recipes))
    lines.append("")
    lines.append(TABLE_NOTE.format(
        resamples=BOOTSTRAP_RESAMPLES, goal=100 * t["goal_success"],
        below=100 * t["below_baseline"], track=100 * t["track_success"], rf=t["rms_factor"],
        floor=t["rms_floor"], xf=t["internal_force_factor"], ef=t["energy_factor"],
        sat=100 * t["saturation"], ts=t["train_s"], wgoal=100 * t["worst_seed_success"],
        wbelow=100 * t["worst_seed_below_baseline"])
        + f" Total CPU time {_duration(cpu)} ({len(rows)} runs).")
    return "\n".join(lines)


# --------------------------------------------------------------------------------------------
# the results page and the README summary
# --------------------------------------------------------------------------------------------

#: The learning-curve images the results page shows (``wheelgym benchmark --curves``).
CURVES: tuple[tuple[str, str], ...] = (
    ("curves.png", "Learning curves"),
    ("curves-navigate.png", "Learning curves of the navigate configs"),
    ("curves-dagger.png", "Learning curves of the configs that start from a clone"),
)


def results_page(rows: Sequence[dict[str, str]], recipes: dict[str, str] | None = None,
                 images: str = "../../benchmarks/results",
                 configs: Sequence[str] = ()) -> str:
    """``docs/topics/results.md``: the full table, the ``configs`` (names) that have no rows
    yet, and the curves (``images``: their folder relative to the page)."""
    text = [
        "# Results", "",
        "Every config of `configs/` trained on seeds 0, 1, ... and scored against the analytic "
        "baseline and a random policy on the same evaluation episodes. Generated by "
        "`python -m wheelgym.cli benchmark --table --page docs/topics/results.md` from "
        "`benchmarks/results/training.csv`; do not edit by hand.", "",
        format_table(rows, recipes), "",
    ]
    missing = sorted(set(configs) - {r["config"] for r in rows})
    if missing:
        text += ["Configs without rows yet: " + ", ".join(f"`{n}`" for n in missing) + ".", ""]
    for name, title in CURVES:
        text += [f"![{title}]({images}/{name})", ""]
    return "\n".join(text)


def readme_summary(rows: Sequence[dict[str, str]], recipes: dict[str, str] | None = None,
                   targets: dict[str, float] | None = None) -> str:
    """The README's short summary: per task the configs, how many meet their targets on the
    mean and on the worst seed, and the seeds per config; a link to the full table."""
    t = load_targets() if targets is None else targets
    per: dict[str, list[tuple[bool, bool, int]]] = {}
    for (name, _algo, _steps, _eps), rs in sorted(_groups(rows).items()):
        task = name.split("-")[1] if "-" in name else "?"
        if name.endswith("-robust"):  # trained and scored under the medium perturbation level
            task += ", robust (at medium)"
        per.setdefault(task, []).append((_targets_cell(name, rs, t) == "met",
                                         _worst_seed_cell(name, rs, t) == "met", len(rs)))
    lines = ["| task | table lines | targets met (mean) | targets met (worst seed) | seeds |",
             "|---|---|---|---|---|"]
    for task, v in sorted(per.items()):
        seeds = sorted({n for _, _, n in v})
        lines.append(f"| {task} | {len(v)} | {sum(a for a, _, _ in v)} | "
                     f"{sum(b for _, b, _ in v)} | {', '.join(map(str, seeds))} |")
    lines += ["", "The full table, with the interquartile means, 95% bootstrap intervals, worst "
              "seeds and recipes: docs/topics/results.md."]
    return "\n".join(lines)


README_BEGIN = "<!-- results-summary: begin -->"
README_END = "<!-- results-summary: end -->"


NAVIGATE_BEGIN = "<!-- navigate-rows: begin -->"
NAVIGATE_END = "<!-- navigate-rows: end -->"


def _table_span(text: str, begin: str, end: str) -> tuple[int, int] | None:
    """Where the text between the markers ``begin`` and ``end`` starts and ends in ``text``
    (None: no markers)."""
    i, j = text.find(begin), text.find(end)
    return None if i < 0 or j < i else (i + len(begin), j)


def between(text: str, begin: str, end: str) -> str | None:
    """The text between the markers ``begin`` and ``end`` (None when they are missing)."""
    span = _table_span(text, begin, end)
    return None if span is None else text[span[0]:span[1]].strip("\n")


def update_between(path: str | Path, begin: str, end: str, body: str, what: str = "") -> None:
    """Put ``body`` between the markers ``begin`` and ``end`` of the Markdown file ``path``
    (``ValueError`` naming the file, the ``what`` markers and the markers themselves when they
    are missing)."""
    path = Path(path)
    text = path.read_text()
    span = _table_span(text, begin, end)
    if span is None:
        raise ValueError(f"{path}: no {what + ' ' if what else ''}markers ({begin!r} ... "
                         f"{end!r})")
    path.write_text(text[:span[0]] + "\n" + body + "\n" + text[span[1]:])


def _range(values: Sequence[float], unit: str) -> str:
    return f"{min(values):.0f}-{max(values):.0f}{unit}"


def navigate_rows(rows: Sequence[dict[str, str]]) -> str:
    """The navigate configs' seeds as two tables, the random arenas then the maps: per config
    its recipe, each seed's success (in seed order), the range of the seeds' saturation, the
    reactive baseline's success and the range of the seeds' training time."""
    by: dict[str, list[dict[str, str]]] = {}
    for r in rows:
        if "-navigate-" in r["config"]:
            by.setdefault(r["config"], []).append(r)
    maps = {c for c in by if "-office-" in c or "-warehouse-" in c}
    head = ["| config | recipe | success by seed (0, 1, ...) | saturation | reactive baseline | "
            "time a seed |", "|---|---|---|---|---|---|"]
    out: list[str] = []
    for group in (sorted(set(by) - maps), sorted(maps)):
        if not group:
            continue
        out += ([""] if out else []) + head
        for c in group:
            rs = sorted(by[c], key=lambda r: int(float(r["seed"])))
            success = " / ".join(f"{100 * float(r['agent_success']):.0f}" for r in rs)
            sat = [100 * (parse_number(r["agent_saturation"]) or 0.0) for r in rs]
            base = 100 * float(rs[0]["baseline_success"])
            out.append(f"| {c} | {_recipe(rs, None)} | {success}% | {_range(sat, '%')} | "
                       f"{base:.0f}% | {_range([float(r['train_s']) for r in rs], ' s')} |")
    return "\n".join(out)


def readme_table(text: str) -> str | None:
    """The text between the README markers (:data:`README_BEGIN`, :data:`README_END`), or
    None when the markers are missing."""
    return between(text, README_BEGIN, README_END)


def update_readme(path: str | Path, summary: str) -> None:
    """Put ``summary`` between the results markers of the Markdown file ``path`` (``ValueError``
    naming the file when they are missing)."""
    update_between(path, README_BEGIN, README_END, summary, what="results")
