"""The robustness results page, written from the sweep's CSV
(``docs/topics/robustness-results.md``).

``wheelgym robustness --page PAGE`` (:func:`write_page`) turns the rows of
:mod:`wheelgym.agents.robustness` into Markdown: a summary of the combined level at which each
policy falls (success under 90% on goal, the RMS tracking error over twice the policy's own
nominal RMS on track), the robust agents (``configs/*-robust.yml``, trained under the ``medium``
level) against the agents trained on the nominal robot, what each component of ``medium`` costs
(axis ``medium_without``), and per agent the combined levels, ``medium`` without each
component, the first failing level of every axis and its figures. Nothing on the page is typed
by hand, so it is never staler than the CSV.
"""

from __future__ import annotations

import math
import os
from collections.abc import Sequence
from pathlib import Path

from wheelgym.agents.robustness import (
    MEDIUM_COMPONENTS,
    POLICIES,
    RMS_FACTOR,
    SUCCESS_MIN,
    csv_number,
    fails,
    read_rows,
    summary_table,
)
from wheelgym.registration import ENV_CLASSES

__all__ = ["COMBINED", "falls_at", "render_page", "wilson_interval", "write_page"]

#: The combined levels, the nominal first (``wheelgym.envs.perturbation.LEVELS``).
COMBINED = ("none", "easy", "medium", "hard")
_SHOWN = ("agent", "baseline-nom", "baseline-true")


def _combined(rows: Sequence[dict[str, str]]) -> dict[tuple[str, str], dict[str, str]]:
    return {(r["policy"], r["level"]): r for r in rows if r["axis"] == "combined"}


def _value(r: dict[str, str], track: bool) -> str:
    return f"{1000 * csv_number(r['rms']):.0f} mm" if track else f"{csv_number(r['success']):.0f}%"


def falls_at(rows: Sequence[dict[str, str]], policy: str, track: bool) -> str:
    """The first combined level at which ``policy`` falls, with its value there
    (``"medium (78%)"``), ``"beyond hard"`` when it holds them all, ``"n/a"`` when unswept."""
    comb = _combined(rows)
    if (policy, "none") not in comb:
        return "n/a"
    ref = csv_number(comb[(policy, "none")]["rms"])
    for level in COMBINED:
        r = comb.get((policy, level))
        if r is None:
            continue
        if fails(r, ref, track):
            return f"{'nominal' if level == 'none' else level} ({_value(r, track)})"
    return "beyond hard"


def _is_track(rows: Sequence[dict[str, str]]) -> bool:
    return any(r["rms"] for r in rows)


def _summary(by_target: dict[str, list[dict[str, str]]]) -> list[str]:
    lines = ["## Summary: the combined level at which each policy falls", "",
             f"Success under {SUCCESS_MIN:.0f}% (goal) or the RMS tracking error over "
             f"{RMS_FACTOR:g}x the policy's own nominal RMS (track), with the value there; "
             "\"beyond hard\": still within at `hard`.", "",
             "| agent | criterion | " + " | ".join(_SHOWN) + " |", "|---|---|" + "---|" * 3]
    for name, rows in by_target.items():
        track = _is_track(rows)
        crit = f"RMS > {RMS_FACTOR:g}x own nominal" if track else f"success < {SUCCESS_MIN:.0f}%"
        lines.append(f"| {name} | {crit} | "
                     + " | ".join(falls_at(rows, p, track) for p in _SHOWN) + " |")
    return lines + [""]


def _robust(by_target: dict[str, list[dict[str, str]]]) -> list[str]:
    """Each ``<config>-robust`` agent against ``<config>`` at the ``medium`` level."""
    pairs = [(n, n[: -len("-robust")]) for n in by_target if n.endswith("-robust")]
    if not pairs:
        return []
    lines = ["## Robust agents at `medium`", "",
             "Agents trained under the `medium` level (`configs/*-robust.yml`) against the agents "
             "of the same config trained on the nominal robot, on the same episodes. Goal: "
             f"success at `medium` (target >= {SUCCESS_MIN:.0f}%) with its 95% Wilson interval "
             "over the episodes (at 50 episodes one episode is 2 points); track: the RMS error at "
             "`medium` over the agent's own RMS without perturbation (target <= "
             f"{RMS_FACTOR:g}x), with the RMS at `medium`. The robust agent on the nominal "
             "robot (level `none`): its success, and on track its RMS error; an agent under "
             f"{SUCCESS_MIN:.0f}% there is marked in the last column, whatever its criterion "
             "(a track agent's ratio is then small because its nominal error is large).", "",
             "| robust agent | criterion | robust agent | robust agent, nominal robot | "
             "nominal-trained agent | baseline-nom | baseline-true | target |",
             "|---|---|---|---|---|---|---|---|"]
    for robust, nominal in pairs:
        comb = _combined(by_target[robust])
        track = _is_track(by_target[robust])
        cells = [_at_medium(comb, "agent", track), _on_nominal(comb, track)]
        cells.append(_at_medium(_combined(by_target.get(nominal, [])), "agent", track))
        cells += [_at_medium(comb, p, track) for p in ("baseline-nom", "baseline-true")]
        met = _robust_met(comb, track)
        crit = "RMS medium / none" if track else "success at medium"
        lines.append(f"| {robust} | {crit} | " + " | ".join(cells) + f" | {met} |")
    return lines + [""]


def _without(rows: Sequence[dict[str, str]], policy: str) -> dict[str, dict[str, str]]:
    """``policy``'s rows of the axis ``medium_without`` by component."""
    return {r["level"]: r for r in rows
            if r["axis"] == "medium_without" and r["policy"] == policy}


def _without_cells(pts: dict[str, dict[str, str]], track: bool) -> list[str]:
    """``medium`` and ``medium`` without each component (``-``: not swept); the component
    whose removal gains the most in bold, where one gains anything."""
    vals = {c: csv_number(pts[c]["rms" if track else "success"]) for c in MEDIUM_COMPONENTS
            if c in pts}
    gain = {c: (vals["nothing"] - v if track else v - vals["nothing"])
            for c, v in vals.items() if c != "nothing" and "nothing" in vals}
    best = max(gain, key=gain.get) if gain and max(gain.values()) > 0 else None
    cells = []
    for c in MEDIUM_COMPONENTS:
        if c not in pts:
            cells.append("-")
            continue
        v = _value(pts[c], track)
        cells.append(f"**{v}**" if c == best else v)
    return cells


def _without_header(first: str) -> list[str]:
    """The header of a ``medium_without`` table whose first column is ``first``."""
    comps = MEDIUM_COMPONENTS[1:]
    return [f"| {first} | medium | " + " | ".join(f"without {c}" for c in comps) + " |",
            "|---|" + "---|" * (len(comps) + 1)]


def _without_table(rows: Sequence[dict[str, str]], track: bool) -> list[str]:
    """One agent's section: every policy at ``medium`` without each component."""
    if not any(_without(rows, p) for p in POLICIES):
        return []
    what = "RMS tracking error" if track else "success"
    lines = ["", f"`medium` without one component, {what} (in bold the removal that gains "
             "the most):", "", *_without_header("policy")]
    for pol in POLICIES:
        pts = _without(rows, pol)
        if pts:
            lines.append(f"| {pol} | " + " | ".join(_without_cells(pts, track)) + " |")
    return lines


def _component_costs(by_target: dict[str, list[dict[str, str]]]) -> list[str]:
    """Each agent at ``medium`` and at ``medium`` without one component at a time."""
    have = [n for n, rows in by_target.items() if _without(rows, "agent")]
    if not have:
        return []
    lines = ["## What `medium` costs, component by component", "",
             "Each agent at `medium` and at `medium` with one of its components removed (axis "
             "`medium_without`, [Robustness](robustness.md)): success (goal) or RMS tracking "
             "error (track); in bold the removal that gains the most. The episodes are paired: "
             "a removed component keeps its random draws, so each episode starts and is "
             "perturbed as at `medium` but for that component. Once a policy's path differs it "
             "meets the other components' faults at other moments, so at 50 episodes (one "
             "episode is 2 points) a few points either way are noise. The baselines' numbers "
             "are in each agent's section below.", "", *_without_header("agent")]
    for name in have:
        rows = by_target[name]
        lines.append(f"| {name} | "
                     + " | ".join(_without_cells(_without(rows, "agent"), _is_track(rows)))
                     + " |")
    return lines + [""]


def wilson_interval(successes: float, n: int, z: float = 1.959963984540054
                    ) -> tuple[float, float]:
    """The Wilson score interval of a success rate (``z``: the normal 97.5% quantile, a 95%
    interval): the rates ``p`` with
    ``(successes / n - p)^2 <= z^2 p (1 - p) / n``. Returns ``(low, high)`` as fractions."""
    if n < 1:
        raise ValueError(f"n must be >= 1, got {n!r}")
    p, z2 = successes / n, z * z
    centre = (p + z2 / (2 * n)) / (1 + z2 / n)
    half = z * math.sqrt(p * (1 - p) / n + z2 / (4 * n * n)) / (1 + z2 / n)
    # (0 and 1 exactly at the ends, where centre -/+ half leaves a round-off)
    return (0.0 if p <= 0 else centre - half), (1.0 if p >= 1 else centre + half)


def _success_with_interval(r: dict[str, str]) -> str:
    """``"86% [74, 93]"``: the success rate and its 95% Wilson interval over the episodes."""
    s, n = csv_number(r["success"]), int(csv_number(r["episodes"]))
    lo, hi = wilson_interval(round(s * n / 100), n)
    return f"{s:.0f}% [{100 * lo:.0f}, {100 * hi:.0f}]"


def _at_medium(comb: dict[tuple[str, str], dict[str, str]], policy: str, track: bool) -> str:
    med, none = comb.get((policy, "medium")), comb.get((policy, "none"))
    if med is None or none is None:
        return "n/a"
    if not track:
        return _success_with_interval(med)
    rms, nominal = csv_number(med["rms"]), csv_number(none["rms"])
    ratio = rms / nominal if nominal > 0 else math.inf
    return f"{ratio:.1f}x ({1000 * rms:.0f} mm)"


def _on_nominal(comb: dict[tuple[str, str], dict[str, str]], track: bool) -> str:
    none = comb.get(("agent", "none"))
    if none is None:
        return "n/a"
    succ = f"{csv_number(none['success']):.0f}%"
    return f"{succ} ({1000 * csv_number(none['rms']):.0f} mm)" if track else succ


def _robust_met(comb: dict[tuple[str, str], dict[str, str]], track: bool) -> str:
    med, none = comb.get(("agent", "medium")), comb.get(("agent", "none"))
    if med is None or none is None:
        return "n/a"
    if fails(med, csv_number(none["rms"]), track):
        return "**missed**"
    nominal = csv_number(none["success"])
    if nominal < SUCCESS_MIN:  # met at `medium`, lost on the robot without perturbation
        return f"met; **fails the nominal robot** ({nominal:.0f}%)"
    return "met"


def _per_agent(name: str, rows: list[dict[str, str]], csv_path: Path, fig_rel: str) -> list[str]:
    track = _is_track(rows)
    comb = _combined(rows)
    what = "success [%] / RMS tracking error [mm]" if track else "success [%]"
    lines = [f"### {name}", "", f"Combined levels, {what}:", "",
             "| policy | " + " | ".join(COMBINED) + " |", "|---|" + "---|" * len(COMBINED)]
    for pol in POLICIES:
        cells = []
        for level in COMBINED:
            r = comb.get((pol, level))
            if r is None:
                cells.append("-")
            elif track:
                cells.append(f"{csv_number(r['success']):.0f} / {1000 * csv_number(r['rms']):.1f}")
            else:
                cells.append(f"{csv_number(r['success']):.0f}")
        if any(c != "-" for c in cells):
            lines.append(f"| {pol} | " + " | ".join(cells) + " |")
    lines += _without_table(rows, track)
    crit = (f"RMS > {RMS_FACTOR:g}x the policy's nominal RMS" if track
            else f"success < {SUCCESS_MIN:.0f}%")
    table = summary_table(csv_path, [name]).splitlines()[2:]  # without its bold title line
    lines += ["", f"First level failing ({crit}; `-`: none within the levels, `nominal`: fails "
              "without perturbation):", "", *[t for t in table if t], ""]
    figs = [c for c in ("success", "rms", "energy")
            if (csv_path.parent / f"{name}-{c}.png").is_file()]
    lines += [" ".join(f"![{name} {c}]({fig_rel}/{name}-{c}.png)" for c in figs), ""]
    return lines


def _order(name: str) -> tuple:
    """Robots in the table's order, then task, then the rest of the name."""
    robots = list(ENV_CLASSES)
    robot, _, rest = name.partition("-")
    task = rest.split("-", 1)[0]
    tasks = ("goal", "track", "navigate")
    return (robots.index(robot) if robot in robots else len(robots),
            tasks.index(task) if task in tasks else len(tasks), rest)


def render_page(csv_path: str | Path, page: str | Path) -> str:
    """The page's Markdown from ``csv_path``; figure links relative to ``page``'s folder."""
    csv_path = Path(csv_path)
    rows = [r for r in read_rows(csv_path) if r.get("status") == "ok"]
    by_target: dict[str, list[dict[str, str]]] = {}
    for r in sorted(rows, key=lambda r: _order(r["target"])):
        by_target.setdefault(r["target"], []).append(r)
    fig_rel = Path(os.path.relpath(csv_path.parent.resolve(), Path(page).parent.resolve()))
    n_eps = sorted({r["episodes"] for r in rows})
    lines = ["# Robustness results", "",
             "Written by `python -m wheelgym.cli robustness --page "
             "docs/topics/robustness-results.md` from "
             f"`{_shown_path(csv_path, Path(page))}` ({len(rows)} rows, {len(by_target)} agents, "
             f"{'/'.join(n_eps)} episodes per level and policy); what the axes, levels and "
             "policies are: [Robustness](robustness.md).", "",
             *_summary(by_target), *_robust(by_target), *_component_costs(by_target),
             "## Per agent", ""]
    for name, mine in by_target.items():
        lines += _per_agent(name, mine, csv_path, fig_rel.as_posix())
    return "\n".join(lines).rstrip() + "\n"


def _shown_path(path: Path, page: Path) -> str:
    """``path`` from the folder the page and the CSV share (a checkout's root)."""
    a, b = path.resolve(), page.resolve()
    try:
        return Path(os.path.relpath(a, os.path.commonpath([a, b]))).as_posix()
    except ValueError:  # another drive
        return a.as_posix()


def write_page(csv_path: str | Path, page: str | Path) -> Path:
    """Write :func:`render_page` to ``page``; its path."""
    page = Path(page)
    page.write_text(render_page(csv_path, page))
    return page
