"""Shipped trained agents: ``agents/pretrained/<CONFIG_NAME>/`` in the repository, shipped in the
wheel as ``wheelgym/pretrained/<CONFIG_NAME>/`` (:func:`wheelgym.resources.pretrained_dir`).

One folder per config (named like its file in ``configs/``, without ``.yml``), exported from
the benchmark's results CSV by :func:`export_best` (``wheelgym pretrained export``):

==================== ==========================================================================
file                 content
==================== ==========================================================================
model.zip            the best seed's final model (Stable-Baselines3 ``<Algo>.load``), its
                     weights as trained; the optimizer's moment estimates are left out
                     (:func:`slim_model`: two thirds of an Adam-trained file, needed only to
                     train on)
vecnormalize.pkl     its ``VecNormalize`` statistics (configs with ``normalize`` only)
config.yml           the run's config as used (``load_run_config``): env id, env kwargs, algorithm
card.json            config name, algorithm, env id and kwargs, seed, training steps, the
                     benchmark row's scores (agent, baseline and random success, RMS error,
                     return, energy, internal force, saturation; train time), the CSV it came
                     from and the dates
==================== ==========================================================================

The best seed of a config: highest ``agent_success``, then lowest ``agent_rms`` (where the
task reports one), then highest ``agent_return``, then the lowest seed; only the rows with the
config's largest training budget in the CSV compete (``--quick`` or ``--budget`` rows do not).
A config trained under a ``perturbation`` (``configs/*-robust.yml``, scored at that level) breaks
a tie on success and RMS by the success on the nominal robot before the return
(:func:`wheelgym.agents.evaluate.nominal_success`, 50 episodes): a robust agent should also
drive the robot it was not trained on. The tied seeds are scored in the order of the return,
stopping at the first with 100%, so their run folders must be on the machine; the card records
what was scored (``nominal_success``).
Which configs to export (those that met their targets) is the caller's choice. The whole folder
is kept under :data:`SIZE_LIMIT_MB`; an export that would pass it is refused before anything is
written.

:func:`load_pretrained` returns the same :class:`~wheelgym.agents.policies.AgentPolicy` as
:func:`~wheelgym.agents.policies.load_agent` (observation statistics applied) with its
:class:`~wheelgym.agents.config.TrainConfig`. The folder is found through
:mod:`wheelgym.resources` (inside the installed package, or the checkout's
``agents/pretrained``); :data:`ROOT_ENV` overrides it, and every function takes a ``root``.
"""

from __future__ import annotations

import io
import json
import math
import os
import shutil
import zipfile
from collections.abc import Callable, Sequence
from datetime import datetime, timezone
from pathlib import Path
from typing import Any

from wheelgym import resources
from wheelgym.agents.config import TrainConfig, load_run_config
from wheelgym.agents.policies import AgentPolicy, load_agent
from wheelgym.agents.store import parse_number, read_rows

__all__ = [
    "ROOT_ENV",
    "SIZE_LIMIT_MB",
    "pretrained_root",
    "available",
    "load_pretrained",
    "read_card",
    "export_best",
    "best_row",
    "perturbed",
    "NOMINAL_EPISODES",
    "slim_model",
]

#: Environment variable naming another folder of pretrained agents (tests, private agents).
ROOT_ENV = resources.PRETRAINED_ENV

#: Size limit of the whole shipped folder, in MB (10**6 bytes): room for the 56 agents (15 MB)
#: and a few more of the clone recipes' 256x256 networks (0.6 MB each); the folder ships in
#: the wheel.
SIZE_LIMIT_MB = 20.0

CARD = "card.json"
MODEL = "model.zip"
STATS = "vecnormalize.pkl"
CONFIG = "config.yml"

#: Episodes of the nominal-robot score that ranks tied seeds of a perturbed config
#: (:func:`best_row`; the robustness sweep's combined level ``none``, seeds 100000-100049).
NOMINAL_EPISODES = 50

#: Benchmark CSV columns copied into card.json as numbers (empty cells: ``null``).
CARD_SCORES: tuple[str, ...] = (
    "agent_success", "baseline_success", "random_success",
    "agent_rms", "baseline_rms",
    "agent_return", "baseline_return", "random_return",
    "agent_energy", "baseline_energy",
    "agent_internal_force", "baseline_internal_force",
    "agent_saturation", "baseline_saturation",
    "train_s", "steps_to_baseline",
)

def pretrained_root(root: str | Path | None = None) -> Path:
    """The folder of pretrained agents: ``root``, ``$WHEELGYM_PRETRAINED`` or the shipped
    agents (:func:`wheelgym.resources.pretrained_dir`). ``ValueError`` if it is not a folder."""
    path = resources.pretrained_dir(root)
    if not path.is_dir():
        raise ValueError(f"pretrained agents folder {str(path)!r} does not exist")
    return path


def available(root: str | Path | None = None) -> list[str]:
    """Sorted names of the agents in the folder (sub-folders holding model.zip and config.yml)."""
    base = pretrained_root(root)
    return sorted(p.name for p in base.iterdir()
                  if p.is_dir() and (p / MODEL).is_file() and (p / CONFIG).is_file())


def _name(name: str) -> str:
    """A config name; a config path (``configs/X.yml``) stands for its stem."""
    text = str(name)
    return Path(text).stem if text.endswith((".yml", ".yaml")) else text


def _folder(name: str, root: str | Path | None) -> Path:
    names = available(root)
    key = _name(name)
    if key not in names:
        raise ValueError(f"no pretrained agent {name!r}; available: "
                         f"{names or '(none shipped yet)'} in {pretrained_root(root)}")
    return pretrained_root(root) / key


def read_card(name: str, root: str | Path | None = None) -> dict[str, Any]:
    """The agent's card.json (``{}`` when it has none)."""
    path = _folder(name, root) / CARD
    if not path.is_file():
        return {}
    try:
        return json.loads(path.read_text())
    except (OSError, json.JSONDecodeError) as e:
        raise ValueError(f"{path}: unreadable card: {e}") from None


def load_pretrained(name: str, root: str | Path | None = None,
                    device: str = "cpu") -> tuple[AgentPolicy, TrainConfig]:
    """The shipped agent ``name`` (a config name) with its statistics, and its config.

    ``ValueError`` listing the available names when there is no such agent.
    """
    folder = _folder(name, root)
    config = load_run_config(folder / CONFIG)
    if config.normalize is not None and not (folder / STATS).is_file():
        raise ValueError(f"{folder}: the config normalises observations but {STATS} is missing")
    agent = load_agent(folder / MODEL, config.algo, folder / STATS, device=device)
    return agent, config


# --------------------------------------------------------------------------------------------
# export
# --------------------------------------------------------------------------------------------


def _rank(row: dict[str, str]) -> tuple[float, float, float, float]:
    """Larger is better: success, then lower RMS, then return, then the lower seed."""
    succ, rms, ret = (parse_number(row.get(c))
                      for c in ("agent_success", "agent_rms", "agent_return"))
    return (-math.inf if succ is None else succ,
            -math.inf if rms is None else -rms,
            -math.inf if ret is None else ret,
            -float(row["seed"]))


def best_row(rows: Sequence[dict[str, str]], config: str,
             nominal_success: Callable[[dict[str, str]], float] | None = None,
             scored: dict[str, float] | None = None) -> dict[str, str]:
    """The best seed's row of ``config`` among its rows with the largest ``n_timesteps``.

    ``nominal_success`` (a row -> its agent's success on the nominal robot, 0-1): rows tied
    with the best on success and RMS are ranked by it before the return (module docstring);
    they are scored in the order of the return, stopping at the first with 1.0 (none after it
    can rank higher). ``scored``: filled with seed -> the value of each row scored.
    """
    mine = [r for r in rows if r["config"] == config]
    if not mine:
        raise ValueError(f"no rows of config {config!r}")
    budget = max(float(r["n_timesteps"]) for r in mine)
    ranked = sorted((r for r in mine if float(r["n_timesteps"]) == budget), key=_rank,
                    reverse=True)
    tied = [r for r in ranked if _rank(r)[:2] == _rank(ranked[0])[:2]]
    if nominal_success is None or len(tied) == 1:
        return ranked[0]
    best, best_value = tied[0], -math.inf
    for r in tied:
        value = float(nominal_success(r))
        if scored is not None:
            scored[r["seed"]] = value
        if value > best_value:
            best, best_value = r, value
        if value >= 1.0:
            break
    return best


def perturbed(config: TrainConfig) -> bool:
    """Whether ``config`` trains (and the benchmark scores it) under a ``perturbation``."""
    return config.env_kwargs.get("perturbation") is not None


def _run_config(row: dict[str, str]) -> TrainConfig:
    run = Path(row.get("run_dir") or "")
    if not row.get("run_dir") or not (run / CONFIG).is_file():
        raise ValueError(f"{row['config']} seed {row['seed']} (run folder {str(run)!r}): no "
                         f"{CONFIG}; is the run folder on this machine?")
    return load_run_config(run / CONFIG)


def _run_nominal_success(row: dict[str, str]) -> float:
    from wheelgym.agents.evaluate import nominal_success

    run = Path(row.get("run_dir") or "")
    if not (run / CONFIG).is_file() or not (run / MODEL).is_file():
        raise ValueError(
            f"{row['config']} seed {row['seed']}: seeds tied at the best success are ranked by "
            f"their success on the nominal robot, which needs their run folders; "
            f"{str(run)!r} has no {CONFIG} or {MODEL} (retrain the seeds into a CSV of their "
            f"own, wheelgym benchmark {row['config']} --seeds N --csv NEW.csv, and export from "
            f"it: on another CPU a seed can give another model)")
    config = load_run_config(run / CONFIG)
    agent = load_agent(run / MODEL, config.algo, run / STATS, device=config.device)
    return nominal_success(agent, config, episodes=NOMINAL_EPISODES)


def _size(path: Path) -> int:
    if path.is_file():
        return path.stat().st_size
    return sum(p.stat().st_size for p in path.rglob("*") if p.is_file())


def _shown(path: Path) -> str:
    """``path`` relative to the repository when inside it (cards stay machine-independent)."""
    repo = resources.repository_root()
    if repo is not None:
        try:
            return str(path.resolve().relative_to(repo.resolve()))
        except ValueError:
            pass
    return str(path)


#: How the entries of an SB3 model file holding an optimizer's state dict end (PPO's
#: ``policy.optimizer.pth``; SAC's ``actor.optimizer.pth``, ``critic.optimizer.pth`` and
#: ``ent_coef_optimizer.pth``).
OPTIMIZER_SUFFIX = "optimizer.pth"


def slim_model(src: str | Path) -> bytes:
    """``src`` (an SB3 ``model.zip``) without the optimizers' per-parameter state.

    Each optimizer's state dict keeps its parameter groups (learning rate, betas) and loses its
    ``state`` (Adam's two moment estimates per weight: twice the weights' size), so
    ``<Algo>.load`` still reads the file; a run trained on from it starts the moments afresh.
    Every other entry, the weights included, is copied byte for byte.
    """
    import torch

    out = io.BytesIO()
    with zipfile.ZipFile(src) as zin, zipfile.ZipFile(out, "w", zipfile.ZIP_DEFLATED) as zout:
        for info in zin.infolist():
            data = zin.read(info)
            if info.filename.endswith(OPTIMIZER_SUFFIX):
                state = torch.load(io.BytesIO(data), map_location="cpu", weights_only=True)
                state["state"] = {}
                buf = io.BytesIO()
                torch.save(state, buf)
                data = buf.getvalue()
            zout.writestr(info, data)
    return out.getvalue()


def export_best(
    csv_path: str | Path,
    configs: Sequence[str | Path] | None = None,
    out_root: str | Path | None = None,
    size_limit_mb: float = SIZE_LIMIT_MB,
    log: Callable[[str], None] | None = None,
) -> list[Path]:
    """Copy the best seed's run of each config of the results CSV into ``out_root``.

    ``configs``: names or config paths (their stems) to export (default: every config in the
    CSV). ``out_root``: default ``$WHEELGYM_PRETRAINED`` or, in a source checkout, the
    repository's ``agents/pretrained`` (created; an installed package is not written to).
    Per config: the run's final ``model.zip`` (through :func:`slim_model`),
    ``vecnormalize.pkl`` (when the config normalises), ``config.yml``, and a ``card.json``
    from the CSV row; an existing folder of that name is replaced, others are kept. Refuses
    (``ValueError``, nothing written) when a run folder lacks a file or the folder's total
    (kept agents plus the new ones) would exceed ``size_limit_mb`` MB. Returns the folders.
    A perturbed config's seeds tied at the best success are scored on the nominal robot first
    (:func:`best_row`; a few seconds each), ``log`` told before each.
    """
    csv_path = Path(csv_path)
    rows = read_rows(csv_path)
    known = sorted({r["config"] for r in rows})
    names = [_name(str(c)) for c in configs] if configs else known
    bad = [n for n in names if n not in known]
    if bad:
        raise ValueError(f"configs {bad} have no rows in {csv_path}; configs there: {known}")
    names = list(dict.fromkeys(names))
    root = resources.pretrained_dir(out_root, for_writing=True)
    if root.exists() and not root.is_dir():
        raise ValueError(f"pretrained root {str(root)!r} exists and is not a folder")

    plans: list[tuple[str, dict[str, str], TrainConfig, dict[str, Path]]] = []
    nominal: dict[str, dict[str, float]] = {}
    for name in names:
        row = best_row(rows, name)
        config = _run_config(row)
        if perturbed(config):
            nominal[name] = {}

            def score(r: dict[str, str], name: str = name) -> float:
                if log is not None:
                    log(f"{name}: seed {r['seed']} on the nominal robot ({NOMINAL_EPISODES} "
                        f"episodes; seeds tied at the best success are ranked by it)")
                return _run_nominal_success(r)

            chosen = best_row(rows, name, score, nominal[name])
            if chosen is not row:
                row, config = chosen, _run_config(chosen)
        run = Path(row["run_dir"])
        where = f"{name} seed {row['seed']} (run folder {str(run)!r})"
        files = {MODEL: run / MODEL, CONFIG: run / CONFIG}
        if config.normalize is not None:
            files[STATS] = run / STATS
        missing = [f for f, p in files.items() if not p.is_file()]
        if missing:
            raise ValueError(f"{where}: missing {missing}")
        plans.append((name, row, config, files))
    models = {name: slim_model(files[MODEL]) for name, _, _, files in plans}

    new_bytes = sum(len(models[name]) if f == MODEL else _size(p)
                    for name, _, _, files in plans for f, p in files.items())
    kept = ([p for p in root.iterdir() if p.name not in names and not p.name.startswith(".")]
            if root.is_dir() else [])
    total = new_bytes + sum(_size(p) for p in kept) + 4096 * len(plans)  # cards
    limit = size_limit_mb * 1e6
    if total > limit:
        raise ValueError(f"exporting {names} would make {root} {total / 1e6:.2f} MB, over the "
                         f"{size_limit_mb:g} MB limit; export fewer configs")

    root.mkdir(parents=True, exist_ok=True)
    now = datetime.now(timezone.utc).isoformat(timespec="seconds")
    out: list[Path] = []
    for name, row, config, files in plans:
        out.append(_write_agent(root, name, row, config, files, models[name], csv_path, now,
                                nominal.get(name)))
    return out


def _write_agent(root: Path, name: str, row: dict[str, str], config: TrainConfig,
                 files: dict[str, Path], model: bytes, csv_path: Path, now: str,
                 nominal: dict[str, float] | None = None) -> Path:
    """One agent's folder under ``root``, written aside and moved into place (an existing
    one replaced); its ``config.yml`` in the current spelling."""
    tmp = root / f".{name}.tmp-{os.getpid()}"
    if tmp.exists():
        shutil.rmtree(tmp)
    tmp.mkdir()
    try:
        for fname, src in files.items():
            if fname == MODEL:
                (tmp / fname).write_bytes(model)
            elif fname == CONFIG:
                config.dump(tmp / fname)
            else:
                shutil.copyfile(src, tmp / fname)
        card: dict[str, Any] = {
            "config": name,
            "algo": config.algo,
            "env_id": config.env_id,
            "env_kwargs": config.env_kwargs,
            "normalize": config.normalize is not None,
            "seed": int(float(row["seed"])),
            "n_timesteps": int(float(row["n_timesteps"])),
            "episodes": int(float(row.get("episodes") or 0)),
            "scores": {c: parse_number(row.get(c)) for c in CARD_SCORES},
            "csv": _shown(csv_path),
            "run_dir": row.get("run_dir", ""),
            "finished_utc": row.get("finished_utc", ""),
            "exported_utc": now,
            "files": {f: (tmp / f).stat().st_size for f in files},
        }
        if nominal:  # the tie-break of a perturbed config: seed -> success on the nominal robot
            card["nominal_success"] = {"episodes": NOMINAL_EPISODES, "by_seed": nominal}
        (tmp / CARD).write_text(json.dumps(card, indent=2) + "\n")
        dest = root / name
        if dest.exists():
            old = root / f".{name}.old-{os.getpid()}"
            os.replace(dest, old)
            os.replace(tmp, dest)
            shutil.rmtree(old, ignore_errors=True)
        else:
            os.replace(tmp, dest)
    finally:
        if tmp.exists():
            shutil.rmtree(tmp, ignore_errors=True)
    return dest
