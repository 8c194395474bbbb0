"""Hyperparameter search with Optuna: ``wheelgym tune CONFIG``.

Each trial trains the config with hyperparameters drawn by Optuna's TPE sampler (seeded: the
sampler by ``seed``, the trial's training by ``seed + trial number``) for ``timesteps`` steps,
evaluates it ``n_evals`` times along the way (the run's periodic evaluation, eval.csv) and
reports each evaluation to Optuna's pruner, which stops unpromising trials early (median rule
after 5 trials from a third of the budget on, or successive halving; never at the final
evaluation). The trial's value is its last evaluation's ``metric``: mean return (default,
maximised), success rate (maximised) or RMS tracking error (``track``; minimised).

The study lives in an Optuna storage: by default a SQLite file ``<runs_root>/<study>/study.db``;
``storage`` takes any SQLAlchemy URL (``sqlite:///path.db``,
``postgresql+psycopg://user:pass@host/db``, ``mysql+pymysql://...``), a journal file
(``journal:///abs/path.log``, or a path ending in ``.log``: Optuna's ``JournalStorage`` with its
file backend, for a shared file system where no database server runs) or a plain file path
(SQLite). Many processes, on one machine or many against one database server, work on one
study: Optuna coordinates them through the storage. On a database, a heartbeat (every
:data:`HEARTBEAT_S` seconds, or ``heartbeat``) lets the next worker mark the trial of a killed
worker failed once it has been silent for :data:`GRACE_S` seconds (4x ``heartbeat``); a journal
file has no heartbeat (such a trial stays RUNNING, not counted). A study is resumed by name
(another call adds its trials); a call whose config, budget or metric differ from the study's
is refused. Each trial's run folder lies under ``<runs_root>/<study>/``, and with a ``storage``
given (a study that workers share) under ``<runs_root>/<study>/<host>-<pid>/``: one folder per
worker. A new study's first trial is the config's own hyperparameters (those inside the search
space), so the search starts from the config as written; with a ``storage`` given the sampler
is seeded with the worker too, so that workers started together draw different trials.

At the end the best trial's hyperparameters are written as a config in the RL Zoo layout
(``<runs_root>/<study>/best.yml`` or ``out``): the config with the tuned keys, its own
``n_timesteps``, seed and evaluation settings, and a comment at the top naming the study, its
trials and the date. :func:`export_best` writes it for an existing study at any time. Trials
train without the pipeline's ``imitate`` stages of teacher ``self_without_internal_force`` (a
refit after the last step, which none of the evaluations a trial reports sees); the written
config keeps them.

Search spaces (:data:`SEARCH_SPACES`; ``log``: log-uniform, ``float``: uniform, ``cat``: one of):

=== ===========================================================================================
PPO learning_rate log [1e-5, 3e-3]; n_steps {64 .. 1024}; batch_size {64 .. 1024} (at most
    n_steps x n_envs); n_epochs {3, 5, 10, 20}; gamma {0.95 .. 0.999}; gae_lambda {0.9 .. 0.99};
    clip_range {0.1, 0.2, 0.3}; ent_coef {0, 1e-4, 1e-3, 1e-2}; net_arch {32x32 .. 256x256};
    activation_fn {tanh, relu}; log_std_init {-2, -1, 0} (the initial exploration noise, a
    cause of bang-bang, saturated policies)
SAC learning_rate log [1e-5, 3e-3]; batch_size {64 .. 512}; buffer_size {1e5, 3e5, 1e6};
    learning_starts {0, 1000, 10000}; train_freq {1, 4, 8, 16} (gradient_steps the same); tau
    {0.005 .. 0.05}; gamma {0.95 .. 0.999}; net_arch {64x64, 256x256, 400x300}
TD3 as SAC, plus Gaussian action noise std float [0.05, 0.5]
=== ===========================================================================================

With ``max_saturation`` (``--max-saturation F``) a trial that completes is also evaluated
deterministically on the trial's evaluation episodes, and its share of saturated steps (an
action at its bound or a controller torque clipped, as in the benchmark's
``agent_saturation``) becomes an Optuna constraint ``saturation - F <= 0``: the TPE sampler
learns where the feasible region is, and the best trial (and so the written config) is the best
feasible one.

On tiny budgets PPO's ``n_steps`` is halved until a rollout fits the budget and off-policy
``learning_starts`` is capped at a tenth of it; a trial records the values it used.
"""

from __future__ import annotations

import copy
import math
import os
import re
import socket
import time
import warnings
import zlib
from collections.abc import Callable
from dataclasses import dataclass
from datetime import datetime, timezone
from pathlib import Path
from typing import Any

import yaml

from wheelgym.agents.common import make_single_env
from wheelgym.agents.config import (
    ON_POLICY,
    WHEELGYM_BLOCK,
    TrainConfig,
    load_config,
    parse_config,
)
from wheelgym.agents.evaluate import applicable_metrics
from wheelgym.agents.train import train

__all__ = [
    "SEARCH_SPACES",
    "POLICY_KEYS",
    "METRICS",
    "PRUNERS",
    "tune",
    "export_best",
    "sample_params",
    "apply_params",
    "TuneResult",
]

#: Search spaces per algorithm: name -> ("log"|"float", lo, hi) or ("cat", choices).
SEARCH_SPACES: dict[str, dict[str, tuple]] = {
    "ppo": {
        "learning_rate": ("log", 1e-5, 3e-3),
        "n_steps": ("cat", (64, 128, 256, 512, 1024)),
        "batch_size": ("cat", (64, 128, 256, 512, 1024)),
        "n_epochs": ("cat", (3, 5, 10, 20)),
        "gamma": ("cat", (0.95, 0.98, 0.99, 0.995, 0.999)),
        "gae_lambda": ("cat", (0.9, 0.95, 0.98, 0.99)),
        "clip_range": ("cat", (0.1, 0.2, 0.3)),
        "ent_coef": ("cat", (0.0, 1e-4, 1e-3, 1e-2)),
        "net_arch": ("cat", ("32x32", "64x64", "128x128", "256x256")),
        "activation_fn": ("cat", ("tanh", "relu")),
        "log_std_init": ("cat", (-2.0, -1.0, 0.0)),
    },
    "sac": {
        "learning_rate": ("log", 1e-5, 3e-3),
        "batch_size": ("cat", (64, 128, 256, 512)),
        "buffer_size": ("cat", (100_000, 300_000, 1_000_000)),
        "learning_starts": ("cat", (0, 1000, 10_000)),
        "train_freq": ("cat", (1, 4, 8, 16)),
        "tau": ("cat", (0.005, 0.01, 0.02, 0.05)),
        "gamma": ("cat", (0.95, 0.98, 0.99, 0.995, 0.999)),
        "net_arch": ("cat", ("64x64", "256x256", "400x300")),
    },
}
SEARCH_SPACES["td3"] = {**SEARCH_SPACES["sac"], "noise_std": ("float", 0.05, 0.5)}

#: Objective metrics: name -> (eval.csv column, direction).
METRICS: dict[str, tuple[str, str]] = {
    "return": ("mean_return", "maximize"),
    "success": ("success_rate", "maximize"),
    "rms": ("rms_tracking_error", "minimize"),
}

PRUNERS: tuple[str, ...] = ("median", "halving", "none")

#: Seconds between a running trial's heartbeats, and without one before it counts as failed.
HEARTBEAT_S = 30
GRACE_S = 120

#: The searched keys that live in ``policy_kwargs`` (the others are algorithm arguments).
POLICY_KEYS = ("net_arch", "activation_fn", "log_std_init")


def _check_choice(name: str, value: Any, choices) -> None:
    if value not in choices:
        raise ValueError(f"{name} must be one of {list(choices)}, got {value!r}")


def _space(algo: str) -> dict[str, tuple]:
    _check_choice("algo", algo, SEARCH_SPACES)
    return SEARCH_SPACES[algo]


def sample_params(trial: Any, algo: str) -> dict[str, Any]:
    """Draw one point of ``algo``'s search space with an Optuna trial (``suggest_*``)."""
    out: dict[str, Any] = {}
    for name, spec in _space(algo).items():
        if spec[0] == "cat":
            out[name] = trial.suggest_categorical(name, list(spec[1]))
        else:
            out[name] = trial.suggest_float(name, spec[1], spec[2], log=spec[0] == "log")
    return out


def _arch(text: str) -> list[int]:
    return [int(n) for n in text.split("x")]


def _base_for_algo(config: TrainConfig, algo: str) -> dict:
    """The config's file form for ``algo``: switching algorithms keeps only the shared keys."""
    data = config.to_dict()
    if algo == config.algo:
        return data
    block = data[config.env_id]
    keep = {"policy", "n_envs", "n_timesteps", "normalize", "gamma", "learning_rate"}
    new = {k: v for k, v in block.items() if k in keep}
    pk = {k: v for k, v in block.get("policy_kwargs", {}).items() if k in POLICY_KEYS}
    if pk:
        new["policy_kwargs"] = pk
    data[config.env_id] = new
    data[WHEELGYM_BLOCK]["algo"] = algo
    if algo not in ON_POLICY:  # the fitted Gaussian mean: on-policy policies' only
        _drop_imitate(data, ("baseline", "self_without_internal_force"))
    parse_config(data, source=config.source)  # a clear message if the switch is invalid
    return data


def _drop_imitate(data: dict, teachers: tuple[str, ...]) -> None:
    """Remove the ``imitate`` stages of ``teachers`` from the file form ``data`` (in place; a
    pipeline left with only its ``rl`` stage of no keys goes)."""
    wg = data[WHEELGYM_BLOCK]
    stages = [s for s in wg.get("pipeline") or []
              if not (s.get("stage") == "imitate" and s.get("teacher") in teachers)]
    if stages == [{"stage": "rl"}] or not stages:
        wg.pop("pipeline", None)
    else:
        wg["pipeline"] = stages


def apply_params(base: dict, algo: str, params: dict[str, Any], timesteps: int) -> dict:
    """The file form ``base`` with ``params`` (a point of the search space) set, fitted to a
    trial of ``timesteps`` steps (see the module docstring); ``base`` is not changed."""
    data = copy.deepcopy(base)
    env_id = next(k for k in data if k != WHEELGYM_BLOCK)
    block = data[env_id]
    n_envs = int(block.get("n_envs", 1))
    pk = dict(block.get("policy_kwargs", {}))
    for name, value in params.items():
        if name == "net_arch":
            pk["net_arch"] = _arch(value)
        elif name in ("activation_fn", "log_std_init"):
            pk[name] = value
        elif name == "noise_std":
            block["noise_type"], block["noise_std"] = "normal", float(value)
        elif name == "train_freq":
            block["train_freq"] = block["gradient_steps"] = int(value)
        else:
            block[name] = value
    if pk:
        block["policy_kwargs"] = pk
    if algo in ON_POLICY and "n_steps" in block:
        while block["n_steps"] * n_envs > timesteps and block["n_steps"] > 16:
            block["n_steps"] //= 2
        if "batch_size" in block:
            block["batch_size"] = min(block["batch_size"], block["n_steps"] * n_envs)
    if "learning_starts" in block:
        block["learning_starts"] = min(block["learning_starts"], timesteps // 10)
    return data


def _config_params(base: dict, algo: str) -> dict[str, Any]:
    """The base config's own values that lie inside the search space (the first trial)."""
    env_id = next(k for k in base if k != WHEELGYM_BLOCK)
    block = base[env_id]
    values = dict(block)
    pk = block.get("policy_kwargs", {})
    if isinstance(pk.get("net_arch"), list):
        values["net_arch"] = "x".join(str(n) for n in pk["net_arch"])
    # SB3's defaults where the config names none: Tanh for PPO's MlpPolicy, ReLU off-policy
    values["activation_fn"] = pk.get("activation_fn", "tanh" if algo == "ppo" else "relu")
    if algo == "ppo":  # SB3's PPO policy starts at log std 0 unless the config says otherwise
        values["log_std_init"] = float(pk.get("log_std_init", 0.0))
    if "noise_std" in block:
        values["noise_std"] = block["noise_std"]
    out = {}
    for name, spec in _space(algo).items():
        v = values.get(name)
        if v is None or isinstance(v, (bool, str)) and spec[0] != "cat":
            continue
        if spec[0] == "cat":
            if v in spec[1]:
                out[name] = v
        elif isinstance(v, (int, float)) and spec[1] <= v <= spec[2]:
            out[name] = float(v)
    return out


# --------------------------------------------------------------------------------------------
# storage
# --------------------------------------------------------------------------------------------


def _slug(name: str) -> str:
    return re.sub(r"[^A-Za-z0-9._-]+", "_", name).strip("._") or "study"


#: File name endings read as a journal file (not SQLite) when given as a plain path.
JOURNAL_SUFFIXES = (".log", ".journal")


def _storage_url(storage: str | Path) -> str:
    text = str(storage)
    if "://" in text:
        return text
    path = Path(text).expanduser().resolve()
    return f"journal://{path}" if path.suffix in JOURNAL_SUFFIXES else f"sqlite:///{path}"


def _journal_file(url: str) -> Path | None:
    if not url.startswith("journal://"):
        return None
    rest = url[len("journal://"):]
    if not rest.startswith("/"):
        raise ValueError(f"--storage {url!r}: a journal URL is journal:///ABSOLUTE/PATH.log")
    return Path(rest)


def make_storage(storage: str | Path, heartbeat: int | None = None):
    """An Optuna storage for a URL or a file path: ``RDBStorage`` with a heartbeat (every
    ``heartbeat`` seconds, grace 4x; default :data:`HEARTBEAT_S` and :data:`GRACE_S`), or a
    ``JournalStorage`` on a file for ``journal:///path`` and ``*.log`` paths."""
    import optuna

    url = _storage_url(storage)
    journal = _journal_file(url)
    if journal is not None:
        if not journal.parent.is_dir():
            raise ValueError(f"--storage {url!r}: folder {str(journal.parent)!r} does not exist")
        from optuna.storages.journal import JournalFileBackend

        return optuna.storages.JournalStorage(JournalFileBackend(str(journal)))
    kwargs: dict[str, Any] = {}
    if url.startswith("sqlite"):
        kwargs["engine_kwargs"] = {"connect_args": {"timeout": 60}}  # waits, not "locked"
    beat, grace = (HEARTBEAT_S, GRACE_S) if heartbeat is None else (heartbeat, 4 * heartbeat)
    try:
        from wheelgym.agents.cluster import rdb_storage  # schema made once by racing workers

        with warnings.catch_warnings():
            warnings.simplefilter("ignore", optuna.exceptions.ExperimentalWarning)
            return rdb_storage(url, heartbeat_interval=beat, grace_period=grace, **kwargs)
    except Exception as e:  # SQLAlchemy's URL, driver and connection errors
        raise ValueError(f"--storage {text_of(url)!r}: {type(e).__name__}: "
                         f"{' '.join(str(e).split())[:300]}") from None


def text_of(url: str) -> str:
    """A storage URL without its password (for messages)."""
    return re.sub(r"(://[^:/@]+):[^@]*@", r"\1:***@", url)


def _sqlite_file(url: str) -> Path | None:
    return Path(url[len("sqlite:///"):]) if url.startswith("sqlite:///") else None


def _load_study(name: str, storage: str | Path):
    import optuna

    url = _storage_url(storage)
    path = _sqlite_file(url) or _journal_file(url)
    if path is not None and not path.is_file():
        raise ValueError(f"no study storage at {str(path)!r} (give --storage)")
    store = make_storage(url)
    try:
        return optuna.load_study(study_name=name, storage=store)
    except KeyError:
        names = sorted(s.study_name for s in optuna.get_all_study_summaries(store))
        raise ValueError(f"no study {name!r} in {text_of(url)}; studies there: {names}") from None


# --------------------------------------------------------------------------------------------
# export
# --------------------------------------------------------------------------------------------


def _counts(study) -> dict[str, int]:
    from optuna.trial import TrialState

    states = [t.state for t in study.get_trials(deepcopy=False)]
    return {
        "all": len(states),
        "complete": states.count(TrialState.COMPLETE),
        "pruned": states.count(TrialState.PRUNED),
        "failed": states.count(TrialState.FAIL),
    }


def _best_config_text(study) -> str:
    counts = _counts(study)
    if counts["complete"] == 0:
        raise ValueError(f"study {study.study_name!r} has no complete trial yet "
                         f"({counts['all']} trials: {counts['pruned']} pruned, "
                         f"{counts['failed']} failed)")
    attrs = study.user_attrs
    if "base_config" not in attrs:
        raise ValueError(f"study {study.study_name!r} was not made by wheelgym tune")
    best = study.best_trial
    base = attrs["base_config"]
    data = copy.deepcopy(best.user_attrs["config"])
    env_id = next(k for k in data if k != WHEELGYM_BLOCK)
    base_env = next(k for k in base if k != WHEELGYM_BLOCK)
    data[env_id]["n_timesteps"] = base[base_env]["n_timesteps"]
    for key in ("seed", "eval_freq", "eval_episodes", "checkpoint_freq", "pipeline"):
        if key in base[WHEELGYM_BLOCK]:  # the pipeline with the stages trials leave out
            data[WHEELGYM_BLOCK][key] = base[WHEELGYM_BLOCK][key]
    config = parse_config(data, source=f"study {study.study_name}")
    metric = attrs.get("metric", "return")
    stamp = datetime.now(timezone.utc).strftime("%Y-%m-%d %H:%M UTC")
    header = (
        f"# Tuned by `wheelgym tune`: study {study.study_name!r}, best of {counts['complete']} "
        f"complete trials ({counts['all']} in all: {counts['pruned']} pruned, "
        f"{counts['failed']} failed)\n"
        f"# trial {best.number}: {metric} {best.value:.6g} after {attrs.get('timesteps')} steps "
        f"per trial (sampler seed {attrs.get('seed')}); base config {attrs.get('source')}\n"
        f"# written {stamp}; n_timesteps, seed and evaluation settings are the base config's\n"
    )
    if attrs.get("max_saturation") is not None:
        header += (f"# constraint: saturation <= {100 * attrs['max_saturation']:.0f}% of the steps "
                   f"(trial {best.number}: {100 * best.user_attrs.get('saturation', 0.0):.0f}%)\n")
    return header + yaml.safe_dump(config.to_dict(), sort_keys=False)


def _write_atomic(path: Path, text: str) -> Path:
    if path.is_dir():
        raise ValueError(f"--out {str(path)!r} is a folder; give a file name")
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    tmp.write_text(text)
    os.replace(tmp, path)
    return path


def export_best(study_name: str, storage: str | Path | None = None, out: str | Path | None = None,
                runs_root: str | Path = "runs/tune") -> Path:
    """Write the best config of an existing study (default storage: the study's SQLite file
    under ``runs_root``; default ``out``: ``<runs_root>/<study>/best.yml``)."""
    study_dir = Path(runs_root) / _slug(study_name)
    storage = study_dir / "study.db" if storage is None else storage
    study = _load_study(study_name, storage)
    path = Path(out) if out is not None else study_dir / "best.yml"
    return _write_atomic(path, _best_config_text(study))


# --------------------------------------------------------------------------------------------
# tune
# --------------------------------------------------------------------------------------------


@dataclass
class TuneResult:
    """What a tuning call leaves: the study, its counts, the best value and the written config."""

    study_name: str
    storage: str
    trials_run: int
    counts: dict[str, int]
    best_value: float | None
    best_trial: int | None
    best_config: Path | None
    wall_s: float


def _has_best(study) -> bool:
    """Whether the study has a best trial (complete, and feasible under its constraints)."""
    try:
        return study.best_trial is not None
    except ValueError:
        return False


def final_saturation(run_dir: str | Path, config: TrainConfig, episodes: int,
                     seed: int = 100_000) -> float:
    """Share of steps with an action at its bound or a controller torque clipped, mean over
    ``episodes`` deterministic episodes (seeds ``seed ..``) of the run's final model (the
    benchmark's ``agent_saturation``); 0 where the env reports no saturation."""
    from wheelgym.agents.evaluate import evaluate_policy_episodes
    from wheelgym.agents.policies import load_agent

    run_dir = Path(run_dir)  # no vecnormalize.pkl (normalize off): load_agent takes None
    agent = load_agent(run_dir / "model.zip", config.algo, run_dir / "vecnormalize.pkl",
                       device=config.device)
    env = make_single_env(config)
    try:
        eps = evaluate_policy_episodes(env, agent, range(seed, seed + episodes), record=False)
    finally:
        env.close()
    sats = [e.saturation for e in eps if e.saturation is not None]
    return float(sum(sats) / len(sats)) if sats else 0.0


def _make_pruner(name: str, timesteps: int):
    """Median rule (after 5 trials, from a third of the budget on) or successive halving."""
    import optuna

    _check_choice("pruner", name, PRUNERS)
    if name == "median":
        return optuna.pruners.MedianPruner(n_startup_trials=5, n_warmup_steps=timesteps // 3)
    if name == "halving":
        return optuna.pruners.SuccessiveHalvingPruner()
    return optuna.pruners.NopPruner()


def _check_tune_args(algo: str, metric: str, pruner: str, ints: dict[str, Any],
                     timeout: float | None, max_saturation: float | None) -> None:
    """``ValueError`` naming the first bad argument of :func:`tune` and its valid values."""
    _check_choice("algo", algo, SEARCH_SPACES)
    _check_choice("metric", metric, METRICS)
    _check_choice("pruner", pruner, PRUNERS)
    for name, value in ints.items():
        if value is not None and (not isinstance(value, int) or value < 1):
            raise ValueError(f"{name} must be an integer >= 1, got {value!r}")
    if timeout is not None and not (timeout > 0 and math.isfinite(timeout)):
        raise ValueError(f"timeout must be a positive number of seconds, got {timeout!r}")
    if max_saturation is not None and (isinstance(max_saturation, bool)
                                       or not isinstance(max_saturation, (int, float))
                                       or not 0.0 <= max_saturation <= 1.0):
        raise ValueError(f"max_saturation must be a share in [0, 1], got {max_saturation!r}")


def _check_metric_env(config: TrainConfig, metric: str) -> None:
    """A bad env id or env_kwargs fails here, not in every trial; ``rms`` needs ``track``."""
    env = make_single_env(config)
    try:
        if metric == "rms":
            if "rms_tracking_error" not in applicable_metrics(env):
                raise ValueError(f"metric 'rms' needs the track task; {config.source} has "
                                 f"task {config.task!r} (use 'return' or 'success')")
    finally:
        env.close()


@dataclass
class _Study:
    """An open study and where this worker's trials go."""

    study: Any
    url: str
    n_before: int
    worker: str
    trials_dir: Path
    study_dir: Path


def _open_study(name: str, root: Path, storage: str | Path | None, heartbeat: int | None,
                seed: int, direction: str, pruner: str, steps: int) -> _Study:
    """Create or load the study (a new one's sampler seeded with ``seed``, a shared one's also
    with the worker)."""
    import optuna

    study_dir = root / _slug(name)
    if storage is None:
        study_dir.mkdir(parents=True, exist_ok=True)
    url = _storage_url(study_dir / "study.db" if storage is None else storage)
    store = make_storage(url, heartbeat=heartbeat)
    study_dir.mkdir(parents=True, exist_ok=True)
    try:
        n_before = len(optuna.load_study(study_name=name, storage=store).trials)
    except KeyError:
        n_before = 0
    worker = _slug(f"{socket.gethostname()}-{os.getpid()}")
    sampler_seed = seed + n_before
    trials_dir = study_dir
    if storage is not None:  # a shared study: this worker's folder, its own draws
        trials_dir = study_dir / worker
        sampler_seed = (sampler_seed + zlib.crc32(worker.encode())) % 2**32
    sampler = optuna.samplers.TPESampler(seed=sampler_seed)  # reads the trials' constraints
    optuna.logging.set_verbosity(optuna.logging.WARNING)
    study = optuna.create_study(storage=store, study_name=name, direction=direction,
                                sampler=sampler, pruner=_make_pruner(pruner, steps),
                                load_if_exists=True)
    return _Study(study, url, n_before, worker, trials_dir, study_dir)


def _check_identity(st: _Study, name: str, identity: dict[str, Any], extra: dict[str, Any],
                    direction: str, metric: str) -> None:
    """Record a new study's settings; refuse a call whose settings differ from the study's."""
    study = st.study
    if "base_config" not in study.user_attrs:  # a new study: base_config is written last, so
        # a worker that sees it sees the others (workers started together all write them)
        for k, v in {**identity, **extra}.items():
            if k != "base_config":
                study.set_user_attr(k, v)
        study.set_user_attr("base_config", identity["base_config"])
    attrs = study.user_attrs
    diff = sorted(k for k, v in identity.items() if attrs.get(k) != v)
    if diff:
        raise ValueError(
            f"study {name!r} in {text_of(st.url)} was made with other {', '.join(diff)} "
            f"(timesteps {attrs.get('timesteps')}, metric {attrs.get('metric')!r}, "
            f"max_saturation {attrs.get('max_saturation')}, base "
            f"{attrs.get('source')}); give another --study-name or the same settings")
    if direction != study.direction.name.lower():
        raise ValueError(f"study {name!r} is to {study.direction.name.lower()}, metric {metric!r} "
                         f"to {direction}")


@dataclass
class _Trials:
    """What each trial of a :func:`tune` call shares."""

    config: TrainConfig
    base: dict
    algo: str
    steps: int
    seed: int
    episodes: int
    eval_freq: int
    metric: str
    column: str
    max_saturation: float | None
    st: _Study


def _trial_config(t: _Trials, trial: Any) -> TrainConfig:
    """The trial's config: the base with the trial's draw, its seed and evaluation settings."""
    params = sample_params(trial, t.algo)
    data = apply_params(t.base, t.algo, params, t.steps)
    # the distillation runs after training, unseen by the evaluations the trial reports
    _drop_imitate(data, ("self_without_internal_force",))
    env_id = next(k for k in data if k != WHEELGYM_BLOCK)
    data[env_id]["n_timesteps"] = t.steps
    data[WHEELGYM_BLOCK].update(seed=t.seed + trial.number, eval_freq=t.eval_freq,
                                eval_episodes=t.episodes, checkpoint_freq=0)
    trial.set_user_attr("config", data)
    trial.set_user_attr("seed", t.seed + trial.number)
    trial.set_user_attr("worker", t.st.worker)
    return parse_config(data, source=f"{t.config.source} (trial {trial.number})")


def _objective(t: _Trials) -> Callable[[Any], float]:
    """Optuna's objective: train the trial's config, report its evaluations to the pruner."""
    import optuna

    def objective(trial: optuna.Trial) -> float:
        cfg = _trial_config(t, trial)
        values: list[float] = []
        pruned = False

        def on_eval(row: dict) -> bool:
            nonlocal pruned
            value = row[t.column]
            if value is None:
                raise ValueError(f"the evaluation reports no {t.column} (metric {t.metric!r})")
            values.append(float(value))
            trial.report(float(value), int(row["timesteps"]))
            if row["timesteps"] < t.steps and trial.should_prune():  # never the final one
                pruned = True
                return False
            return True

        try:
            result = train(cfg, runs_root=t.st.trials_dir, progress=False, on_eval=on_eval)
        except Exception as e:
            trial.set_user_attr("error", f"{type(e).__name__}: {' '.join(str(e).split())[:300]}")
            raise
        trial.set_user_attr("run_dir", str(result.run_dir))
        trial.set_user_attr("wall_s", result.wall_s)
        if result.status == "interrupted":
            raise KeyboardInterrupt
        if pruned:
            raise optuna.TrialPruned()
        if not values:
            raise ValueError("no evaluation happened (timesteps too small?)")
        if t.max_saturation is not None:
            sat = final_saturation(result.run_dir, cfg, t.episodes)
            trial.set_user_attr("saturation", sat)
            trial.set_constraint("saturation", sat - t.max_saturation)  # feasible: <= 0
        return values[-1]

    return objective


def _trial_line(study: Any, t: Any, metric: str) -> str:
    """The log line of a trial that ended."""
    secs = t.user_attrs.get("wall_s")
    took = f" in {secs:.0f} s" if secs is not None else ""
    state = t.state.name.lower()
    if state == "complete":
        what = f"{metric} {t.value:.4g}"
        if "saturation" in t.user_attrs:
            what += f", saturation {100 * t.user_attrs['saturation']:.0f}%"
    elif state == "pruned":
        what = f"pruned at {t.last_step} steps"
    else:
        what = f"failed: {t.user_attrs.get('error', 'see the run folder')}"
    try:
        bt = study.best_trial
        best = f"; best trial {bt.number}: {bt.value:.4g}"
    except ValueError:  # none complete, or none feasible
        best = ""
    return f"trial {t.number} {what}{took}{best} ({t.user_attrs.get('run_dir', '-')})"


def _optimize(st: _Study, t: _Trials, trials: int | None, timeout: float | None,
              log: Callable[[str], None] | None) -> tuple[int, bool]:
    """Run the trials; how many ran, and whether a Ctrl-C ended them."""
    ran = 0

    def report(study: Any, trial: Any) -> None:
        nonlocal ran
        ran += 1
        if log is not None:
            log(_trial_line(study, trial, t.metric))

    try:
        st.study.optimize(_objective(t), n_trials=trials, timeout=timeout, callbacks=[report],
                          catch=(ValueError, RuntimeError, FloatingPointError))
    except KeyboardInterrupt:
        return ran, True
    return ran, False


def tune(
    config: TrainConfig | str | Path,
    *,
    trials: int | None = None,
    timesteps: int | None = None,
    timeout: float | None = None,
    storage: str | Path | None = None,
    study_name: str | None = None,
    runs_root: str | Path = "runs/tune",
    seed: int = 0,
    algo: str | None = None,
    metric: str = "return",
    pruner: str = "median",
    n_evals: int = 5,
    eval_episodes: int | None = None,
    out: str | Path | None = None,
    enqueue_config: bool = True,
    heartbeat: int | None = None,
    max_saturation: float | None = None,
    log: Callable[[str], None] | None = None,
) -> TuneResult:
    """Run (or continue) an Optuna study on ``config``; write the best config at the end.

    ``trials``: trials this call runs (default 20, or unlimited with ``timeout``); ``timesteps``:
    steps per trial (default the config's ``n_timesteps``); ``timeout``: seconds after which no
    new trial starts; ``algo``: tune another algorithm than the config's (``ppo``, ``sac``,
    ``td3``); ``metric``: one of :data:`METRICS`; ``pruner``: one of :data:`PRUNERS`;
    ``n_evals``: evaluations per trial (pruning points); ``heartbeat``: seconds between a
    running trial's heartbeats on a database storage; ``max_saturation``: the largest share of
    saturated steps (0..1) of a feasible trial (an Optuna constraint). Ctrl-C stops the
    running trial (marked failed), still writes the best config so far and re-raises
    ``KeyboardInterrupt``.
    """
    if not isinstance(config, TrainConfig):
        config = load_config(config)
    algo = config.algo if algo is None else algo
    _check_tune_args(algo, metric, pruner, {"trials": trials, "timesteps": timesteps,
                                            "n_evals": n_evals, "eval_episodes": eval_episodes,
                                            "heartbeat": heartbeat}, timeout, max_saturation)
    if trials is None and timeout is None:
        trials = 20
    steps = config.n_timesteps if timesteps is None else timesteps
    episodes = config.eval_episodes if eval_episodes is None else eval_episodes
    column, direction = METRICS[metric]
    base = _base_for_algo(config, algo)
    name = study_name or f"{config.name.rsplit('-', 1)[0]}-{algo}"
    root = Path(runs_root)
    if root.exists() and not root.is_dir():
        raise ValueError(f"runs root {str(root)!r} exists and is not a folder")
    _check_metric_env(config, metric)
    st = _open_study(name, root, storage, heartbeat, seed, direction, pruner, steps)
    identity = {"base_config": base, "timesteps": steps, "metric": metric,
                "eval_episodes": episodes, "n_evals": n_evals, "max_saturation": max_saturation}
    _check_identity(st, name, identity, {"seed": seed, "source": config.source, "algo": algo},
                    direction, metric)
    if enqueue_config and st.n_before == 0:
        params = _config_params(base, algo)
        if params:
            st.study.enqueue_trial(params, skip_if_exists=True)
    t = _Trials(config, base, algo, steps, seed, episodes, max(steps // n_evals, 1), metric,
                column, max_saturation, st)
    if log is not None:
        budget = f"{trials} trial(s)" if trials is not None else "trials"
        limit = f" for up to {timeout:g} s" if timeout is not None else ""
        log(f"study {name!r} ({text_of(st.url)}): {st.n_before} trial(s) so far; running "
            f"{budget} of {steps} steps{limit}, {algo.upper()}, metric {metric}, pruner "
            f"{pruner}; worker {st.worker}, runs in {st.trials_dir}")
    t0 = time.perf_counter()
    ran, interrupted = _optimize(st, t, trials, timeout, log)
    return _conclude(st, name, metric, out, ran, interrupted, time.perf_counter() - t0, log)


def _conclude(st: _Study, name: str, metric: str, out: str | Path | None, ran: int,
              interrupted: bool, wall_s: float, log: Callable[[str], None] | None) -> TuneResult:
    """Write the best config (if any), log the study's counts, re-raise a Ctrl-C."""
    study = st.study
    counts = _counts(study)
    path: Path | None = None
    best_value = best_number = None
    if _has_best(study):
        path = _write_atomic(Path(out) if out is not None else st.study_dir / "best.yml",
                             _best_config_text(study))
        best_value, best_number = float(study.best_value), study.best_trial.number
    if log is not None:
        tail = (f"best trial {best_number}: {metric} {best_value:.4g}; wrote {path}"
                if path is not None else "no complete (feasible) trial, no config written")
        log(f"study {name!r}: {counts['all']} trials ({counts['complete']} complete, "
            f"{counts['pruned']} pruned, {counts['failed']} failed); {tail}")
    if interrupted:
        raise KeyboardInterrupt
    return TuneResult(name, text_of(st.url), ran, counts, best_value, best_number, path, wall_s)
