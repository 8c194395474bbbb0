"""Robustness sweep: a trained agent against the analytic baseline when the robot is not the model.

``wheelgym robustness TARGET`` (:func:`sweep`): TARGET is a shipped agent's name
(``agents/pretrained/``) or a run folder. For each axis of :data:`AXES` that the robot has, alone
over its levels, for the combined levels ``easy``, ``medium``, ``hard``
(``wheelgym.envs.perturbation.LEVELS``), and for ``medium`` with one of its components removed
at a time (axis ``medium_without``: what each component costs), four policies are scored on the
same seeds:

============== =============================================================================
policy         what it is
============== =============================================================================
agent          the trained agent (its config's env, ``perturbation`` added)
baseline-nom   the analytic baseline believing the nominal model (``model="nominal"``; the
               velocity mode's twist controller ``controller_model="nominal"``)
baseline-true  the baseline with each episode's true plant parameters (``model="true"``,
               ``controller_model="true"``): privileged, an upper reference
random         uniform random actions
============== =============================================================================

Each (level, policy) runs all its episodes as one batch of the native vector env (one
``predict`` per step, :func:`wheelgym.agents.evaluate.run_episodes_vector`) and appends one row
to the CSV (:data:`COLUMNS`): the metrics of :mod:`wheelgym.agents.evaluate` as mean and
standard deviation over episodes. A row already in the CSV (same target, axis, level, policy,
episodes and seed) is not run again, so an interrupted sweep resumes. The agent's rows record
a digest of its ``model.zip`` (``agent_sha``), and every row a digest of the env the policies
are scored on (``env_sha``: the config's env id and ``env_kwargs``). After the agent is
retrained or re-exported its old rows are stale, and after its config's env changed (a reward
weight, a history) all the target's rows are: the sweep refuses to mix them with new ones until
``drop_stale`` removes them (rows from before a column, with it empty, are kept).
:func:`plot` draws success, RMS tracking error (``track``) and energy (robots with motors)
against each axis from the CSV, the policies as lines (``docs/topics/robustness.md``).
"""

from __future__ import annotations

import csv
import dataclasses
import hashlib
import json
import math
import time
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from wheelgym import resources
from wheelgym.agents.config import TrainConfig, load_config
from wheelgym.agents.evaluate import (
    applicable_metrics,
    check_episodes,
    make_eval_venv,
    run_episodes_vector,
    summarize,
)
from wheelgym.agents.policies import RandomPolicy, load_agent
from wheelgym.agents.store import json_digest
from wheelgym.envs.baseline import baseline
from wheelgym.envs.perturbation import FAULT_FIELDS, LEVELS, Perturbation

__all__ = ["AXES", "POLICIES", "COLUMNS", "Axis", "load_target", "agent_digest", "env_digest",
           "MEDIUM_COMPONENTS", "VANISHING", "medium_without",
           "applicable_axes", "sweep",
           "plot", "read_rows", "summary_table", "timing_note", "DEFAULT_OUT", "fails",
           "SUCCESS_MIN", "RMS_FACTOR", "csv_number"]

#: Where ``wheelgym robustness`` writes by default (CSV and figures).
DEFAULT_OUT = resources.results_dir("robustness")

POLICIES = ("agent", "baseline-nom", "baseline-true", "random")


@dataclass(frozen=True)
class Axis:
    """One perturbation axis: its levels (in ``unit``) and the perturbation of a level."""

    name: str
    levels: tuple[Any, ...]
    unit: str
    make: Callable[[Any], Perturbation]
    group: str | None = None  # the randomisation group it needs (None: every robot)
    #: levels that are not ordered from a nominal one (``medium_without``): no "first level
    #: failing", markers without lines in the figures
    ablation: bool = False


def _scale(group: str) -> Callable[[Any], Perturbation]:
    return lambda f: Perturbation(scales={group: (float(f), float(f))})


def _fault(field: str, steps: int) -> Callable[[Any], Perturbation]:
    return lambda p: Perturbation(**{field: (float(p), steps if p > 0 else 0)})


#: The components of ``medium`` that the axis ``medium_without`` removes, one a level
#: (``"nothing"``: ``medium`` itself).
MEDIUM_COMPONENTS = ("nothing", "parameters", "action_delay", "actuator_lag", "obs_noise",
                     "action_noise", "signal_faults")


#: The magnitude that stands for a removed random component in :func:`medium_without`: its
#: draws stay, its effect is below float32's resolution and the state's round-off.
VANISHING = 1e-300


def medium_without(component: str) -> Perturbation:
    """The ``medium`` level with one component removed: ``"parameters"`` (every scale at 1x,
    ``x_icr`` at +0), ``"signal_faults"`` (dropped and stuck actions and observations), or the
    field of that name (``action_delay``, ``actuator_lag``, ``obs_noise``, ``action_noise``);
    ``"nothing"``: ``medium``.

    Paired with ``medium``: a removed component keeps its random draws, so each episode draws
    its goal, parameters and faults as at ``medium``. The scales become 1x (a draw from
    ``[1, 1]``); the noises and the faults' probabilities become :data:`VANISHING` (a fault
    starts only on a uniform draw of exactly 0, once in about 2^53 draws; a noise adds about
    1e-300, which a float32 observation cannot hold and which is far below the state's
    round-off). The delay and the lag draw nothing. So a policy that reads the state (the
    baselines) scores exactly as at ``medium`` without an observation component.
    """
    med = LEVELS["medium"]
    if component not in MEDIUM_COMPONENTS:
        raise ValueError(f"unknown component {component!r}; valid components: "
                         f"{list(MEDIUM_COMPONENTS)}")
    if component == "nothing":
        return med
    if component == "parameters":
        return med.replace(scales={g: (0.0, 0.0) if g == "x_icr" else (1.0, 1.0)
                                   for g in med.scales})
    if component == "signal_faults":
        return med.replace(**{f: (VANISHING, getattr(med, f)[1]) for f in FAULT_FIELDS})
    if component in ("obs_noise", "action_noise"):
        return med.replace(**{component: VANISHING})
    return med.replace(**{component: 0})


#: The single axes, each over five levels including the nominal one (1x, or 0).
AXES: dict[str, Axis] = {a.name: a for a in (
    Axis("mass", (0.5, 0.75, 1.0, 1.5, 2.0), "x", _scale("mass"), "mass"),
    Axis("inertia", (0.5, 0.75, 1.0, 1.5, 2.0), "x", _scale("inertia"), "inertia"),
    Axis("friction", (0.3, 0.6, 1.0, 1.25, 1.5), "x", _scale("friction"), "friction"),
    Axis("wheel_radius", (0.9, 0.95, 1.0, 1.05, 1.1), "x", _scale("wheel_radius"),
         "wheel_radius"),
    Axis("torque_limit", (0.4, 0.55, 0.7, 0.85, 1.0), "x", _scale("torque_limit"),
         "torque_limit"),
    Axis("motor", (0.8, 0.9, 1.0, 1.1, 1.2), "x", _scale("motor"), "motor"),
    Axis("x_icr", (-0.06, -0.03, 0.0, 0.03, 0.06), "m", _scale("x_icr"), "x_icr"),
    Axis("caster_trail", (0.6, 0.8, 1.0, 1.2, 1.4), "x", _scale("caster_trail"),
         "caster_trail"),
    Axis("action_delay", (0, 1, 2, 3, 5), "steps", lambda k: Perturbation(action_delay=int(k))),
    Axis("actuator_lag", (0.0, 0.025, 0.05, 0.1, 0.2), "s",
         lambda t: Perturbation(actuator_lag=float(t))),
    Axis("obs_noise", (0.0, 0.025, 0.05, 0.075, 0.1), "rel. std",
         lambda s: Perturbation(obs_noise=float(s))),
    Axis("action_noise", (0.0, 0.05, 0.1, 0.2, 0.3), "std",
         lambda s: Perturbation(action_noise=float(s))),
    Axis("action_dropped", (0.0, 0.01, 0.02, 0.05, 0.1), "prob (3 steps)",
         _fault("action_dropped", 3)),
    Axis("action_stuck", (0.0, 0.01, 0.02, 0.05, 0.1), "prob (3 steps)",
         _fault("action_stuck", 3)),
    Axis("obs_dropped", (0.0, 0.01, 0.02, 0.05, 0.1), "prob (3 steps)",
         _fault("obs_dropped", 3)),
    Axis("obs_stuck", (0.0, 0.01, 0.02, 0.05, 0.1), "prob (3 steps)",
         _fault("obs_stuck", 3)),
    Axis("combined", ("none", "easy", "medium", "hard"), "level",
         lambda n: Perturbation() if n == "none" else LEVELS[n]),
    Axis("medium_without", MEDIUM_COMPONENTS, "component removed", medium_without,
         ablation=True),
)}

#: The CSV's columns, in order (metrics: mean and sd over the level's episodes).
COLUMNS = ("target", "config", "axis", "level", "unit", "policy", "episodes", "seed",
           "success", "success_sd", "rms", "rms_sd", "energy", "energy_sd", "return",
           "return_sd", "peak_torque", "saturation", "length", "numerical_failures", "wall_s",
           "status", "agent_sha", "env_sha")

_METRIC_COLS = {"success": "success", "rms_tracking_error": "rms", "energy": "energy",
                "ret": "return"}


def load_target(target: str | Path) -> tuple[str, Any, TrainConfig]:
    """``(name, agent, config)`` of a shipped agent's name or a run folder (its final model)."""
    path = Path(target)
    if (path / "config.yml").is_file():
        config = load_config(path / "config.yml")
        if not (path / "model.zip").is_file():
            raise ValueError(f"{path}: no model.zip")
        agent = load_agent(path / "model.zip", config.algo, path / "vecnormalize.pkl",
                           device=config.device)
        run = path / "run.json"  # the config file it was trained from (the CSV's config column)
        source = json.loads(run.read_text()).get("config_source") if run.is_file() else None
        return path.name, agent, dataclasses.replace(config, source=source or config.source)
    from wheelgym.agents.pretrained import load_pretrained

    agent, config = load_pretrained(str(target))
    name = Path(config.source).parent.name
    return name, agent, dataclasses.replace(config, source=f"{name}.yml")


def agent_digest(target: str | Path) -> str:
    """The first 12 hex digits of the SHA-256 of the target's ``model.zip`` (a run folder's, or
    the shipped agent's): the ``agent_sha`` of its rows."""
    path = Path(target)
    if (path / "config.yml").is_file():
        model = path / "model.zip"
    else:
        from wheelgym.agents.pretrained import MODEL, _folder

        model = _folder(str(target), None) / MODEL
    return hashlib.sha256(model.read_bytes()).hexdigest()[:12]


def env_digest(config: TrainConfig) -> str:
    """The first 12 hex digits of the SHA-256 of the config's env id and ``env_kwargs``: the
    ``env_sha`` of its target's rows (every policy is scored on that env)."""
    return json_digest({"env_id": config.env_id, "env_kwargs": config.env_kwargs})


def _resume(csv_path: Path, name: str, sha: str, drop_stale: bool,
            env_sha: str = "") -> set[tuple]:
    """The keys of the rows done, after adding the digest columns to a CSV from before them
    and dropping (``drop_stale``) the target's stale rows, or refusing them: agent rows of
    another model (``agent_sha`` other than ``sha``) and rows of another env (``env_sha``
    other than ``env_sha``). An empty digest, in the CSV or given, judges nothing."""
    if not csv_path.is_file():
        return set()
    with csv_path.open(newline="") as f:
        reader = csv.DictReader(f)
        header, rows = tuple(reader.fieldnames or ()), list(reader)
    if header not in (COLUMNS, COLUMNS[:-1], COLUMNS[:-2]):
        raise ValueError(f"{csv_path}: not a robustness CSV (its columns are not {list(COLUMNS)})")
    mine = [r for r in rows if r["target"] == name]
    stale_agent = [r for r in mine if r["policy"] == "agent" and r.get("agent_sha")
                   and r["agent_sha"] != sha] if sha else []
    stale_env = [r for r in mine if r.get("env_sha") and r["env_sha"] != env_sha
                 ] if env_sha else []
    if (stale_agent or stale_env) and not drop_stale:
        what = []
        if stale_agent:
            what.append(f"{len(stale_agent)} agent row(s) of {name!r} from another model.zip "
                        f"than its {sha} (column agent_sha)")
        if stale_env:
            what.append(f"{len(stale_env)} row(s) of {name!r} scored on another env than its "
                        f"config's {env_sha} (column env_sha: env id and env_kwargs)")
        raise ValueError(f"{csv_path} holds {' and '.join(what)}; give --drop-stale to remove "
                         f"them and sweep again, or another --csv")
    gone = {id(r) for r in stale_agent + stale_env}
    if gone or header != COLUMNS:
        keep = [r for r in rows if id(r) not in gone]
        with csv_path.open("w", newline="") as f:
            w = csv.DictWriter(f, fieldnames=COLUMNS, lineterminator="\n")
            w.writeheader()
            w.writerows({c: r.get(c) or "" for c in COLUMNS} for r in keep)
        rows = keep
    return {_key(r["target"], r["axis"], r["level"], r["policy"], r["episodes"], r["seed"])
            for r in rows}


def _robot_of(config: TrainConfig) -> Any:
    from wheelgym.envs.robots import get_spec

    env_id = config.env_id.split("/")[-1]
    return get_spec(env_id.rsplit("-v", 1)[0])


def applicable_axes(config: TrainConfig, names: Iterable[str] | None = None) -> list[Axis]:
    """The axes of :data:`AXES` (or ``names``, in that order) that the config's robot has: the
    parameter axes need its randomisation group (``motor``: DC motors too)."""
    spec = _robot_of(config)
    dc = config.env_kwargs.get("motor") == "dc" or config.env_kwargs.get(
        "action_mode") == "voltage"
    chosen = list(AXES) if names is None else list(names)
    bad = [n for n in chosen if n not in AXES]
    if bad:
        raise ValueError(f"unknown axis {bad[0]!r}; valid axes: {list(AXES)}")
    out = []
    for n in chosen:
        ax = AXES[n]
        if ax.group is not None and (ax.group not in spec.randomize
                                     or (ax.group == "motor" and not dc)):
            continue
        out.append(ax)
    return out


def read_rows(path: str | Path) -> list[dict[str, str]]:
    """The CSV's rows (``[]`` when it does not exist)."""
    path = Path(path)
    if not path.is_file():
        return []
    with path.open(newline="") as f:
        return list(csv.DictReader(f))


def _key(target: str, axis: str, level: Any, policy: str, episodes: int, seed: int) -> tuple:
    return (target, axis, str(level), policy, str(episodes), str(seed))


def _row(target: str, config: TrainConfig, axis: Axis, level: Any, policy: str,
         episodes: int, seed: int, eps: list | None, wall: float, status: str,
         metrics: Sequence[str] = ()) -> dict[str, Any]:
    row: dict[str, Any] = {c: "" for c in COLUMNS}
    row.update(target=target, config=Path(config.source).stem, axis=axis.name, level=level,
               unit=axis.unit, policy=policy, episodes=episodes, seed=seed,
               wall_s=f"{wall:.2f}", status=status)
    if eps:
        s = summarize(eps)
        for attr, col in _METRIC_COLS.items():
            v = s.get(attr)
            if v is not None and attr in metrics:  # (evaluate.applicable_metrics)
                row[col] = f"{v[0]:.6g}"
                row[f"{col}_sd"] = f"{v[1]:.6g}"
        for attr, col in (("peak_torque", "peak_torque"), ("saturation", "saturation"),
                          ("length", "length")):
            v = s.get(attr)
            if v is not None and (attr in metrics or attr == "length"):
                row[col] = f"{v[0]:.6g}"
        row["numerical_failures"] = sum(bool(e.numerical_failure) for e in eps)
    return row


def _check_sweep_args(episodes: Any, policies: Sequence[str]) -> None:
    check_episodes(episodes)
    bad = [p for p in policies if p not in POLICIES]
    if bad:
        raise ValueError(f"unknown policy {bad[0]!r}; valid policies: {list(POLICIES)}")


def _score(config: TrainConfig, agent: Any, pol: str, pert: Perturbation,
           envs: dict[str, Any], seeds: list[int]) -> tuple[list | None, str, tuple[str, ...]]:
    """``(episodes, status, metrics)`` of policy ``pol`` on ``config``'s env under ``pert``,
    one batch of ``len(seeds)`` episodes; ``envs`` caches the level's vector envs by the
    controller's model. A level the model cannot be built or integrated at: ``(None,
    "invalid: ...", ())``."""
    cm = "true" if pol == "baseline-true" else "nominal"
    try:
        if cm not in envs:
            envs[cm] = make_eval_venv(config, len(seeds), pert, cm)
        venv = envs[cm]
        policy = (agent if pol == "agent" else RandomPolicy(venv.action_space)
                  if pol == "random" else baseline(venv, model=cm))
        eps = run_episodes_vector(venv, policy, seeds)
        return eps, "ok", ("ret", *applicable_metrics(venv))
    except ValueError as e:  # e.g. a level the integrator cannot step
        return None, "invalid: " + " ".join(str(e).split())[:200], ()


def sweep(target: str | Path, *, out: str | Path = DEFAULT_OUT, csv_path: str | Path | None = None,
          episodes: int = 50, seed: int = 100_000, axes: Sequence[str] | None = None,
          policies: Sequence[str] = POLICIES, log: Callable[[str], None] | None = None,
          loaded: tuple[str, Any, TrainConfig] | None = None,
          drop_stale: bool = False) -> dict[str, Any]:
    """Run (or resume) the sweep of ``target``; returns ``{"csv", "rows", "ran", "skipped",
    "wall_s", "figures"}``. ``loaded``: the ``(name, agent, config)`` of :func:`load_target`
    when already loaded. Episodes of a level: seeds ``seed .. seed + episodes - 1``.
    ``drop_stale``: remove the target's agent rows of another ``model.zip`` first (else they
    raise ``ValueError``)."""
    _check_sweep_args(episodes, policies)
    name, agent, config = loaded if loaded is not None else load_target(target)
    import torch

    torch.set_num_threads(int(getattr(config, "torch_threads", 0) or 1))  # (batch predicts)
    if config.env_kwargs.get("goal_conditioned"):
        raise ValueError(f"{name}: goal-conditioned agents (Dict observations) are not swept")
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    csv_path = out / "robustness.csv" if csv_path is None else Path(csv_path)
    sha = agent_digest(target)
    env_sha = env_digest(config)
    # ("": a sweep without the agent neither judges nor drops its rows)
    done = _resume(csv_path, name, sha if "agent" in policies else "", drop_stale, env_sha)
    new_file = not csv_path.is_file()
    seeds = [seed + i for i in range(episodes)]
    cache: dict[tuple[str, str], dict[str, Any]] = {}  # (policy, perturbation) -> row
    ran = skipped = 0
    t_all = time.perf_counter()
    with csv_path.open("a", newline="") as f:
        # "\n" ends, as the committed sweep CSV (csv's default is "\r\n")
        w = csv.DictWriter(f, fieldnames=COLUMNS, lineterminator="\n")
        if new_file:
            w.writeheader()
            f.flush()
        for axis in applicable_axes(config, axes):
            for level in axis.levels:
                pert = axis.make(level)
                todo = [p for p in policies
                        if _key(name, axis.name, level, p, episodes, seed) not in done]
                skipped += len(policies) - len(todo)
                envs: dict[str, Any] = {}
                for pol in todo:
                    ck = (pol, repr(pert))
                    if ck in cache:  # the same perturbation on another axis (the nominal)
                        row = dict(cache[ck], axis=axis.name, level=level, unit=axis.unit)
                        w.writerow(row)
                        f.flush()
                        ran += 1
                        continue
                    t0 = time.perf_counter()
                    eps, status, metrics = _score(config, agent, pol, pert, envs, seeds)
                    row = _row(name, config, axis, level, pol, episodes, seed, eps,
                               time.perf_counter() - t0, status, metrics)
                    row["agent_sha"] = sha if pol == "agent" else ""
                    row["env_sha"] = env_sha
                    cache[ck] = row
                    w.writerow(row)
                    f.flush()
                    ran += 1
                    if log is not None:
                        log(f"{name} {axis.name}={level} {pol}: success {row['success'] or '-'}"
                            f" rms {row['rms'] or '-'} energy {row['energy'] or '-'} "
                            f"({row['wall_s']} s{'' if status == 'ok' else ', ' + status})")
                for e in envs.values():
                    e.close()
    rows = [r for r in read_rows(csv_path) if r["target"] == name]
    return {"csv": csv_path, "rows": rows, "ran": ran, "skipped": skipped,
            "wall_s": time.perf_counter() - t_all, "target": name}


def csv_number(v: str) -> float:
    """A CSV cell as a float (NaN when empty or not a number)."""
    try:
        return float(v)
    except (TypeError, ValueError):
        return math.nan


_STYLE = {"agent": ("C0", "o"), "baseline-nom": ("C1", "s"), "baseline-true": ("C2", "^"),
          "random": ("C7", "x")}


def plot(csv_path: str | Path, out: str | Path | None = None,
         targets: Sequence[str] | None = None) -> list[Path]:
    """Draw, for each target of the CSV (or ``targets``), one PNG per metric (success; RMS
    tracking error where the task reports it; energy where the robot has motors):
    ``<out>/<target>-<metric>.png``, one panel per axis with the policies as lines."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    csv_path = Path(csv_path)
    out = csv_path.parent if out is None else Path(out)
    out.mkdir(parents=True, exist_ok=True)
    rows = [r for r in read_rows(csv_path) if r.get("status") == "ok"]
    names = sorted({r["target"] for r in rows}) if targets is None else list(targets)
    files: list[Path] = []
    for name in names:
        mine = [r for r in rows if r["target"] == name]
        axes = [a for a in AXES if any(r["axis"] == a for r in mine)]
        for col, label in (("success", "success [%]"), ("rms", "RMS tracking error [m]"),
                           ("energy", "energy [J]")):
            if not any(r[col] for r in mine):
                continue
            k = len(axes)
            ncol = min(4, k)
            nrow = math.ceil(k / ncol)
            fig, grid = plt.subplots(nrow, ncol, figsize=(2.6 * ncol, 2.0 * nrow), dpi=70,
                                     squeeze=False)
            for j, ax_name in enumerate(axes):
                ax = grid[j // ncol][j % ncol]
                axis = AXES[ax_name]
                lv = [str(x) for x in axis.levels]
                for pol in POLICIES:
                    pts = {r["level"]: csv_number(r[col]) for r in mine
                           if r["axis"] == ax_name and r["policy"] == pol}
                    if not pts:
                        continue
                    xs = [i for i, v in enumerate(lv) if v in pts]
                    ys = [pts[lv[i]] for i in xs]
                    c, m = _STYLE[pol]
                    ax.plot(xs, ys, color=c, marker=m, ms=3, lw=1, label=pol,
                            ls="none" if axis.ablation else "-")
                slant = {"rotation": 40, "ha": "right"} if axis.ablation else {}
                ax.set_xticks(range(len(lv)), lv, fontsize=6, **slant)
                ax.tick_params(labelsize=6)
                ax.set_title(f"{ax_name} [{axis.unit}]", fontsize=7)
                if col == "rms":
                    ax.set_yscale("log")
            for j in range(k, nrow * ncol):
                grid[j // ncol][j % ncol].axis("off")
            grid[0][0].legend(fontsize=5)
            fig.suptitle(f"{name}: {label}", fontsize=8)
            fig.tight_layout()
            path = out / f"{name}-{col}.png"
            _save_small(fig, path)
            plt.close(fig)
            files.append(path)
    return files


def _save_small(fig: Any, path: Path) -> None:
    """The figure as a PNG of a 64-colour palette (a third of the RGBA file's size)."""
    import io

    from PIL import Image

    buf = io.BytesIO()
    fig.savefig(buf, format="png")
    buf.seek(0)
    with Image.open(buf) as im:
        im.convert("RGB").quantize(colors=64).save(path, optimize=True)


def summary_table(csv_path: str | Path, targets: Sequence[str] | None = None) -> str:
    """Markdown: per target and policy, the first level of each axis (from the nominal
    outwards) at which success falls under 90% (goal) or the RMS exceeds twice the policy's
    nominal RMS (track); ``-`` where it never does within the levels swept. (Not of the
    ablation axes, whose levels have no order.)"""
    rows = [r for r in read_rows(csv_path) if r.get("status") == "ok"]
    names = sorted({r["target"] for r in rows}) if targets is None else list(targets)
    lines = []
    for name in names:
        mine = [r for r in rows if r["target"] == name]
        track = any(r["rms"] for r in mine)
        axes = [a for a in AXES if not AXES[a].ablation and any(r["axis"] == a for r in mine)]
        lines += [f"**{name}** ({'RMS > 2x nominal' if track else 'success < 90%'}):", "",
                  "| policy | " + " | ".join(axes) + " |",
                  "|---|" + "---|" * len(axes)]
        for pol in POLICIES:
            cells = []
            for a in axes:
                pts = {r["level"]: r for r in mine if r["axis"] == a and r["policy"] == pol}
                cells.append(_first_failure(AXES[a], pts, track))
            if any(c != "n/a" for c in cells):
                lines.append(f"| {pol} | " + " | ".join(cells) + " |")
        lines.append("")
    return "\n".join(lines)


#: Goal: a policy holds a level while its success is at least this (%).
SUCCESS_MIN = 90.0
#: Track: a policy holds a level while its RMS error is at most this times its nominal RMS.
RMS_FACTOR = 2.0


def fails(row: dict[str, str], nominal_rms: float, track: bool) -> bool:
    """Whether a policy's CSV ``row`` is past the benchmark's criterion: success under
    :data:`SUCCESS_MIN` (goal), or an RMS error over :data:`RMS_FACTOR` times the policy's
    own ``nominal_rms`` (track)."""
    if track:
        return not csv_number(row["rms"]) <= RMS_FACTOR * nominal_rms
    return not csv_number(row["success"]) >= SUCCESS_MIN


def _first_failure(axis: Axis, pts: dict[str, dict[str, str]], track: bool) -> str:
    lv = [str(x) for x in axis.levels]
    nominal = {"combined": "none"}.get(axis.name)
    if nominal is None:
        nominal = next((v for v in lv if float(v) in (0.0, 1.0)), lv[0])
    if nominal not in pts:
        return "n/a"
    ref = csv_number(pts[nominal]["rms"])

    def bad(r: dict[str, str]) -> bool:
        return fails(r, ref, track)

    if bad(pts[nominal]):
        return "nominal"
    i0 = lv.index(nominal)
    found = []
    for side in (lv[i0 + 1:], lv[:i0][::-1]):
        for v in side:
            if v in pts and bad(pts[v]):
                found.append(v)
                break
    return ", ".join(found) if found else "-"


def timing_note(result: dict[str, Any]) -> str:
    """One line: rows run, rows resumed, wall time."""
    return (f"{result['target']}: {result['ran']} rows run, {result['skipped']} already in "
            f"{result['csv']} ({result['wall_s']:.1f} s)")
