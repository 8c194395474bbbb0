"""Train a Stable-Baselines3 agent on a wheelgym environment from a YAML config.

A run folder (``runs/<Robot>-<task>-<mode>-<algo>-s<seed>-<UTC time>``, never reused: a clash
gets a ``-2``, ``-3`` suffix) holds:

====================== ======================================================================
file                   content
====================== ======================================================================
config.yml             the config as used (overrides applied), loadable by ``load_config``
model.zip              the final (or interrupted, or failed) model
vecnormalize.pkl       ``VecNormalize`` statistics (when ``normalize`` is on)
eval.csv               evaluation history: steps, wall time (continued across resumes),
                       mean/std return, success rate, mean length, RMS tracking error
                       (``track`` only; empty otherwise)
best_model.zip         the model of the best evaluation (and ``best_vecnormalize.pkl``)
checkpoints/           ``ckpt_<steps>_steps.zip`` and ``ckpt_vecnormalize_<steps>_steps.pkl``
tb/                    TensorBoard logs
run.json               ``status``, steps, wall time, versions, ``stages``; ``error`` when failed
reward_weights.csv     with the rl stage's ``reward_schedule``: each change of the reward weights
                       (step, term, the weight the training envs then hold)
run.lock               present while a process trains in the folder (holds its pid)
====================== ======================================================================

The run trains the config's pipeline (:mod:`wheelgym.agents.pipeline`; without one, a single
``rl`` stage) in order on one model. run.json's ``stages`` records each stage: its kind (and
teacher), ``status`` (``pending``, ``running``, ``finished``, ``interrupted``, ``stopped``,
``failed``), the steps the model had after it, its wall time and, for an ``imitate`` stage, the
fit's figures; ``stage`` is the index of the last stage started and ``recipe`` the recipe's
short name (:attr:`wheelgym.agents.config.TrainConfig.recipe`).

``status`` in run.json: ``cloning`` while an ``imitate`` stage with the baseline as teacher
runs, ``distilling`` while one with the policy itself as teacher runs, ``running`` during the
``rl`` stage; ``finished`` when every stage has run to its end; ``interrupted`` after Ctrl-C
(SIGINT); ``stopped`` when the caller's ``on_eval`` hook ended training early (a pruned tuning
trial); ``failed`` when training raised (``error`` holds the exception's type and message; the
exception propagates). A process that died without a word (SIGKILL, power loss) leaves
``running`` (or ``cloning``, ``distilling``).

Ctrl-C (SIGINT) at any stage stops it at the next environment step (or fit batch) and saves the
model and statistics as they are (a second Ctrl-C stops at once, still saving). ``subproc``
vector-env workers ignore SIGINT (they share the terminal's process group), so the main process
stops them cleanly. ``resume`` continues a run in its own folder from its last saved model or
checkpoint, at the first stage not finished (an interrupted ``imitate`` stage runs again from
the saved model; the ``rl`` stage continues to ``n_timesteps``), and runs every stage after it.

Only one process at a time trains in a run folder: ``train`` and ``resume`` take ``run.lock``
(created exclusively) and remove it on exit; a second process is refused with ``ValueError``. A
lock whose process no longer exists (a killed run) is stale and taken over.
"""

from __future__ import annotations

import json
import os
import platform
import re
import signal
import time
from collections.abc import Callable
from dataclasses import dataclass
from datetime import datetime, timezone
from pathlib import Path
from typing import Any

import gymnasium as gym

from wheelgym import resources
from wheelgym.agents.common import (
    algo_class,
    build_model,
    make_train_env,
    wrap_normalize,
)
from wheelgym.agents.config import TrainConfig, load_config, load_run_config
from wheelgym.agents.pipeline import BASELINE_TEACHERS, RL, Imitate

__all__ = [
    "train",
    "resume",
    "new_run_dir",
    "RunLock",
    "TrainResult",
    "EVAL_COLUMNS",
    "EVAL_HISTORY_SEED",
]

RUNS_DIR = resources.RUNS

#: First episode seed of the periodic evaluations (eval.csv): episodes use seeds
#: ``EVAL_HISTORY_SEED + i`` for ``i < eval_episodes``.
EVAL_HISTORY_SEED = 10_000

#: Columns of eval.csv, in order.
EVAL_COLUMNS: tuple[str, ...] = ("timesteps", "wall_s", "mean_return", "std_return",
                                 "success_rate", "mean_length", "rms_tracking_error")

#: ``on_eval(row) -> bool``: called after each periodic evaluation with eval.csv's row as numbers
#: (``success_rate`` and ``rms_tracking_error`` ``None`` when not reported); ``False`` stops
#: training (status ``stopped``).
EvalHook = Callable[[dict], bool]


# --------------------------------------------------------------------------------------------
# run folders
# --------------------------------------------------------------------------------------------


def _check_root(root: Path) -> None:
    if root.exists() and not root.is_dir():
        raise ValueError(f"runs root {str(root)!r} exists and is not a folder")


def new_run_dir(config: TrainConfig, root: str | Path | None = None) -> Path:
    """Create a fresh run folder; never returns an existing one."""
    root = Path(RUNS_DIR if root is None else root)
    _check_root(root)
    try:
        root.mkdir(parents=True, exist_ok=True)
    except OSError as e:
        raise ValueError(f"cannot create runs root {str(root)!r}: {e.strerror or e}") from None
    stamp = datetime.now(timezone.utc).strftime("%Y%m%d-%H%M%S")
    base = f"{config.name}-s{config.seed}-{stamp}"
    for i in range(1, 1000):
        path = root / (base if i == 1 else f"{base}-{i}")
        try:
            path.mkdir()
        except FileExistsError:
            continue
        return path
    raise RuntimeError(f"could not create a new run folder under {root}")


LOCK_NAME = "run.lock"


def _pid_alive(pid: int) -> bool:
    if pid <= 0:
        return False
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:  # exists, owned by someone else
        return True
    except OSError:
        return False
    return True


def _read_lock_pid(path: Path) -> int | None:
    try:
        return int(path.read_text().split()[0])
    except (OSError, ValueError, IndexError):
        return None


class RunLock:
    """Exclusive ownership of a run folder: ``run.lock`` created with ``O_EXCL``, holding the pid.

    A lock whose pid is no longer a live process is stale and is taken over. Released (the file
    removed) by :meth:`release`, or on leaving the ``with`` block.
    """

    def __init__(self, run_dir: str | Path) -> None:
        self.path = Path(run_dir) / LOCK_NAME
        self.held = False

    def acquire(self) -> RunLock:
        for _ in range(3):
            try:
                fd = os.open(self.path, os.O_CREAT | os.O_EXCL | os.O_WRONLY, 0o644)
            except FileExistsError:
                pid = _read_lock_pid(self.path)
                if pid is None:  # being written right now, or garbage: look again
                    time.sleep(0.05)
                    pid = _read_lock_pid(self.path)
                if pid is not None and _pid_alive(pid):
                    raise ValueError(
                        f"run dir {str(self.path.parent)!r} is in use by another wheelgym "
                        f"process (pid {pid}); wait for it or choose another folder"
                    ) from None
                self._remove_stale(pid)
                continue
            except OSError as e:
                raise ValueError(
                    f"cannot lock run dir {str(self.path.parent)!r}: {e.strerror or e}"
                ) from None
            with os.fdopen(fd, "w") as f:
                f.write(f"{os.getpid()}\n")
            self.held = True
            return self
        raise ValueError(f"could not lock run dir {str(self.path.parent)!r} (contended)")

    def _remove_stale(self, pid: int | None) -> None:
        """Move a stale lock aside; put it back if it turned out to be a fresh one."""
        aside = self.path.with_name(f"{LOCK_NAME}.stale-{os.getpid()}")
        try:
            os.replace(self.path, aside)
        except FileNotFoundError:
            return  # someone else removed it
        if _read_lock_pid(aside) != pid and _read_lock_pid(aside) is not None:
            try:  # a live process re-created it meanwhile: give it back
                os.link(aside, self.path)
            except OSError:
                pass
        try:
            aside.unlink()
        except OSError:
            pass

    def release(self) -> None:
        if self.held:
            self.held = False
            if _read_lock_pid(self.path) == os.getpid():
                try:
                    self.path.unlink()
                except OSError:
                    pass

    def __enter__(self) -> RunLock:
        return self.acquire() if not self.held else self

    def __exit__(self, *exc) -> None:
        self.release()


def _use_given_dir(path: Path) -> tuple[Path, RunLock]:
    """A user-chosen ``--run-dir``, created and locked; never one that holds files."""
    if path.exists() and not path.is_dir():
        raise ValueError(f"run dir {str(path)!r} exists and is not a folder")
    try:
        path.mkdir(parents=True, exist_ok=True)
    except OSError as e:
        raise ValueError(f"cannot create run dir {str(path)!r}: {e.strerror or e}") from None
    lock = RunLock(path).acquire()
    if any(p.name != LOCK_NAME for p in path.iterdir()):
        lock.release()
        raise ValueError(f"run dir {str(path)!r} exists and is not empty; runs never overwrite")
    return path, lock


def _short(text: str, limit: int = 400) -> str:
    """One line of at most ``limit`` characters."""
    line = " ".join(text.split())
    return line if len(line) <= limit else line[: limit - 3] + "..."


def _write_json(path: Path, data: dict) -> None:
    tmp = path.with_suffix(".tmp")
    tmp.write_text(json.dumps(data, indent=2))
    os.replace(tmp, path)


def _versions() -> dict[str, str]:
    import stable_baselines3 as sb3
    import torch

    import wheelgym

    return {
        "wheelgym": wheelgym.__version__,
        "stable_baselines3": sb3.__version__,
        "torch": torch.__version__,
        "gymnasium": gym.__version__,
        "python": platform.python_version(),
    }


# --------------------------------------------------------------------------------------------
# callbacks
# --------------------------------------------------------------------------------------------


class _StopOnSignal:
    """SIGINT handler: first Ctrl-C asks training to stop at the next step, the second raises."""

    def __init__(self) -> None:
        self.requested = False
        self._previous: Any = None

    def __enter__(self) -> _StopOnSignal:
        try:
            self._previous = signal.signal(signal.SIGINT, self._handle)
        except ValueError:  # not the main thread: leave signals alone
            self._previous = None
        return self

    def _handle(self, signum, frame) -> None:
        if self.requested:
            raise KeyboardInterrupt
        self.requested = True

    def __exit__(self, *exc) -> None:
        if self._previous is not None:
            signal.signal(signal.SIGINT, self._previous)


# --------------------------------------------------------------------------------------------
# train / resume
# --------------------------------------------------------------------------------------------


@dataclass
class TrainResult:
    """What a training call leaves: its folder, status, steps and wall time."""

    run_dir: Path
    status: str
    timesteps: int
    wall_s: float


def _save(model, run_dir: Path) -> None:
    model.save(run_dir / "model.zip")
    norm = model.get_vec_normalize_env()
    if norm is not None:
        norm.save(str(run_dir / "vecnormalize.pkl"))


def _finish(model, run_dir: Path, info: dict, status: str, wall_s: float,
            error: BaseException | None = None) -> None:
    """Save the model and statistics, close the envs and record ``status`` in run.json; a
    failure to save or close becomes a note there (never masking the run's own ``error``)."""
    notes = []
    try:
        _save(model, run_dir)
    except Exception as e:
        notes.append(f"saving the model failed: {type(e).__name__}: {e}")
    try:
        model.get_env().close()
    except Exception as e:
        notes.append(f"closing the environments failed: {type(e).__name__}: {e}")
    info.update(
        status=status,
        timesteps=int(model.num_timesteps),
        wall_s=wall_s,
        finished_utc=datetime.now(timezone.utc).isoformat(timespec="seconds"),
    )
    if error is not None:
        info["error"] = _short(f"{type(error).__name__}: {error}")
    if notes:
        info["notes"] = notes
    _write_json(run_dir / "run.json", info)




# --------------------------------------------------------------------------------------------
# the pipeline's stages
# --------------------------------------------------------------------------------------------


def _record(stage: Any) -> dict[str, Any]:
    """A stage's entry in run.json's ``stages`` before it runs."""
    rec: dict[str, Any] = {"stage": stage.kind}
    if isinstance(stage, Imitate):
        rec["teacher"] = stage.teacher
    rec["status"] = "pending"
    return rec


def _records_of(info: dict, config: TrainConfig, run_dir: Path) -> list[dict[str, Any]]:
    """run.json's stage records; for a run written before the pipeline (``clone`` and
    ``distill`` entries instead) made from those."""
    if "stages" in info:
        recs = info["stages"]
        kinds = [(r.get("stage"), r.get("teacher")) for r in recs]
        want = [(r["stage"], r.get("teacher")) for r in map(_record, config.stages)]
        if kinds != want:
            raise ValueError(f"{run_dir}: run.json's stages {kinds} are not the config's "
                             f"pipeline {want}")
        return recs
    recs = [_record(s) for s in config.stages]
    for rec, stage in zip(recs, config.stages, strict=True):
        if isinstance(stage, Imitate):
            old = info.pop("clone" if stage.teacher == "baseline" else "distill", None)
            if old is not None:
                rec.update(old, status="interrupted" if old.get("interrupted") else "finished")
    return recs


def _first_pending(config: TrainConfig, model, records: list[dict[str, Any]]) -> int:
    """The index of the first stage not finished (``rl``: fewer steps than ``n_timesteps``);
    every stage from it on runs (again)."""
    for i, (stage, rec) in enumerate(zip(config.stages, records, strict=True)):
        if isinstance(stage, RL):
            if model.num_timesteps < config.n_timesteps:
                return i
        elif rec.get("status") != "finished":
            return i
    return len(records)


def _imitate(config: TrainConfig, stage: Imitate, model, stop: _StopOnSignal) -> dict:
    """Run an ``imitate`` stage; its figures (``interrupted`` when a Ctrl-C ended it)."""
    from wheelgym.agents.clone import clone_baseline, distill_internal_force

    opts = stage.resolved()
    try:
        if stage.teacher in BASELINE_TEACHERS:
            return clone_baseline(model, stage.steps, seed=config.seed,
                                  stop=lambda: stop.requested, rounds=opts["rounds"],
                                  epochs=opts["epochs"], internal_force=opts["internal_force"],
                                  lr=opts["lr"], teacher_kwargs=stage.teacher_kwargs,
                                  **BASELINE_TEACHERS[stage.teacher])
        return distill_internal_force(model, stage.steps, rounds=opts["rounds"],
                                      weight=opts["internal_force"], epochs=opts["epochs"],
                                      seed=config.seed, lr=opts["lr"],
                                      stop=lambda: stop.requested)
    except KeyboardInterrupt:  # a second Ctrl-C: stop at once (the caller saves)
        return {"interrupted": True}


def _rl(config: TrainConfig, model, run_dir: Path, stop: _StopOnSignal, progress: bool,
        wall: Callable[[], float], on_eval: EvalHook | None, reset: bool) -> str:
    """Run the ``rl`` stage up to ``n_timesteps``; its status."""
    from wheelgym.agents.callbacks import make_callbacks

    total = config.n_timesteps
    remaining = max(total - model.num_timesteps, 0)
    callbacks = make_callbacks(config, run_dir, model, lambda: stop.requested, progress, wall,
                               on_eval, EVAL_COLUMNS, EVAL_HISTORY_SEED)
    if remaining > 0:
        model.learn(total_timesteps=remaining, callback=callbacks, reset_num_timesteps=reset,
                    tb_log_name="tb")
    if model.num_timesteps >= total:
        return "finished"
    return ("interrupted" if stop.requested else
            "stopped" if on_eval is not None else "finished")


def _run_stage(config: TrainConfig, i: int, model, run_dir: Path, info: dict,
               stop: _StopOnSignal, progress: bool, wall: Callable[[], float],
               on_eval: EvalHook | None, reset: bool) -> str:
    """Run stage ``i``, recording it in run.json (``stages[i]``); its status."""
    stage = config.stages[i]
    rec = _record(stage)
    rec["status"] = "running"
    info["stages"][i] = rec
    info.update(status=stage.status, stage=i)
    _write_json(run_dir / "run.json", info)
    t0 = time.perf_counter()
    if isinstance(stage, RL):
        status = _rl(config, model, run_dir, stop, progress, wall, on_eval, reset)
    else:
        fit = _imitate(config, stage, model, stop)
        rec.update(fit)
        status = "interrupted" if fit.get("interrupted") else "finished"
    rec.update(status=status, timesteps=int(model.num_timesteps),
               wall_s=round(time.perf_counter() - t0, 2))
    return status


def _run_pipeline(config: TrainConfig, model, run_dir: Path, info: dict, progress: bool,
                  on_eval: EvalHook | None, reset: bool) -> TrainResult:
    """Run the stages from the first unfinished one; save and record the status in run.json
    whatever happens (Ctrl-C at any stage saves the model as it is)."""
    t0 = time.perf_counter()
    wall_before = float(info.get("wall_s", 0.0))

    def wall() -> float:
        return wall_before + time.perf_counter() - t0

    status = "failed"
    error: BaseException | None = None
    info["target_timesteps"] = config.n_timesteps
    info.pop("error", None)
    info.pop("notes", None)
    with _StopOnSignal() as stop:
        try:
            status = "finished"
            for i in range(_first_pending(config, model, info["stages"]), len(config.stages)):
                if stop.requested:
                    status = "interrupted"
                    break
                status = _run_stage(config, i, model, run_dir, info, stop, progress, wall,
                                    on_eval, reset)
                if status != "finished":
                    break
        except KeyboardInterrupt:
            status = "interrupted"
        except BaseException as e:
            status = "failed"
            error = e
            raise
        finally:
            if status == "failed" or status == "interrupted":
                for rec in info["stages"]:
                    if rec.get("status") == "running":
                        rec["status"] = status
            _finish(model, run_dir, info, status, round(wall(), 2), error)
    return TrainResult(run_dir, status, int(model.num_timesteps), info["wall_s"])


def check_stages(config: TrainConfig, venv) -> None:
    """``ValueError`` before training when a stage could not run on ``venv``: a reward
    schedule's term the env lacks, or a distillation on envs without an internal force."""
    check_reward_schedule(config, venv)
    if any(isinstance(s, Imitate) and s.teacher == "self_without_internal_force"
           for s in config.stages):
        from wheelgym.agents.clone import check_distill_envs

        check_distill_envs(venv)


def check_reward_schedule(config: TrainConfig, venv) -> None:
    """``ValueError`` naming the schedule's terms that the env does not have, and its terms."""
    if not config.reward_schedule:
        return
    names = list(venv.get_attr("reward_weights")[0])
    bad = [k for k in config.reward_schedule if k not in names]
    if bad:
        raise ValueError(f"{config.source}: reward_schedule terms {bad} unknown for "
                         f"{config.env_id} {config.env_kwargs}; valid terms: {names}")


# --------------------------------------------------------------------------------------------
# train / resume
# --------------------------------------------------------------------------------------------


def _prepare(config: TrainConfig, seed: int | None,
             total_timesteps: int | None) -> TrainConfig:
    """The config with the call's overrides, torch's threads set."""
    import torch

    if not isinstance(config, TrainConfig):
        config = load_config(config)
    changes: dict[str, Any] = {}
    if seed is not None:
        changes["seed"] = seed
    if total_timesteps is not None:
        changes["n_timesteps"] = total_timesteps
    if changes:
        config = config.replace(**changes)
    torch.set_num_threads(config.torch_threads)
    return config


def _open_run(config: TrainConfig, run_dir: str | Path | None, runs_root: str | Path | None,
              verbose: int) -> tuple[Path, RunLock, Any]:
    """The locked run folder and the model on its training envs (no folder left behind when
    building fails)."""
    if run_dir is not None:
        out, lock = _use_given_dir(Path(run_dir))
    else:
        out = new_run_dir(config, runs_root)
        lock = RunLock(out).acquire()
    try:
        venv = wrap_normalize(make_train_env(config), config)
        try:
            check_stages(config, venv)
            model = build_model(config, venv, tensorboard_log=str(out / "tb"), verbose=verbose)
        except BaseException:
            venv.close()
            raise
    except BaseException:
        lock.release()
        if not any(out.iterdir()):  # nothing written: leave no empty folder behind
            out.rmdir()
        raise
    return out, lock, model


def train(
    config: TrainConfig | str | Path,
    *,
    seed: int | None = None,
    total_timesteps: int | None = None,
    run_dir: str | Path | None = None,
    runs_root: str | Path | None = None,
    progress: bool = True,
    verbose: int = 0,
    on_eval: EvalHook | None = None,
) -> TrainResult:
    """Train from a config (or its path) into a new run folder: its pipeline's stages in order.

    ``seed`` and ``total_timesteps`` override the config (the saved ``config.yml`` holds the
    values used). ``run_dir`` names the folder (it must not exist or be empty); otherwise one is
    made under ``runs_root`` (default ``runs/``). ``on_eval`` (see :data:`EvalHook`) sees each
    periodic evaluation and may stop training (status ``stopped``).
    """
    config = _prepare(config, seed, total_timesteps)
    out, lock, model = _open_run(config, run_dir, runs_root, verbose)
    try:
        config.dump(out / "config.yml")
        info = {
            "config_source": config.source,
            "env_id": config.env_id,
            "env_kwargs": config.env_kwargs,
            "algo": config.algo,
            "seed": config.seed,
            "recipe": config.recipe,
            "started_utc": datetime.now(timezone.utc).isoformat(timespec="seconds"),
            "versions": _versions(),
            "wall_s": 0.0,
            "stages": [_record(s) for s in config.stages],
        }
        return _run_pipeline(config, model, out, info, progress, on_eval, True)
    finally:
        lock.release()


_CKPT = re.compile(r"ckpt_(\d+)_steps\.zip$")


def latest_model(run_dir: Path) -> tuple[Path, Path | None]:
    """The newest saved model of a run (``model.zip`` or the latest checkpoint) and its stats."""
    candidates: list[tuple[float, Path, Path | None]] = []
    final = run_dir / "model.zip"
    if final.is_file():
        candidates.append((final.stat().st_mtime, final, run_dir / "vecnormalize.pkl"))
    ckpt_dir = run_dir / "checkpoints"
    if ckpt_dir.is_dir():
        for p in ckpt_dir.iterdir():
            m = _CKPT.search(p.name)
            if m:
                stats = ckpt_dir / f"ckpt_vecnormalize_{m.group(1)}_steps.pkl"
                candidates.append((p.stat().st_mtime, p, stats))
    if not candidates:
        raise ValueError(f"{run_dir}: no model.zip or checkpoint to resume from")
    _, model, stats = max(candidates, key=lambda c: c[0])
    return model, (stats if stats is not None and stats.is_file() else None)


def resume(
    run: str | Path,
    *,
    total_timesteps: int | None = None,
    progress: bool = True,
    verbose: int = 0,
) -> TrainResult:
    """Continue a run in its own folder: from its first unfinished stage (an interrupted
    ``imitate`` stage again from the model as saved; ``rl`` up to ``total_timesteps``, default
    the config's, and every stage after it again).

    Loads the newest of ``model.zip`` and the checkpoints, with its ``VecNormalize`` statistics;
    evaluation history and TensorBoard logs continue. A run folder written before the pipeline
    is read in the new spelling (:func:`wheelgym.agents.config.load_run_config`).
    """
    import torch

    run_dir = Path(run)
    if not (run_dir / "config.yml").is_file():
        raise ValueError(f"{run_dir}: not a run folder (no config.yml)")
    with RunLock(run_dir):
        config = load_run_config(run_dir / "config.yml")
        if total_timesteps is not None:
            config = config.replace(n_timesteps=total_timesteps)
        torch.set_num_threads(config.torch_threads)
        model_path, model = _load_for_resume(config, run_dir, verbose)
        config.dump(run_dir / "config.yml")  # the new spelling, and any new total
        info_path = run_dir / "run.json"
        info = json.loads(info_path.read_text()) if info_path.is_file() else {}
        info["stages"] = _records_of(info, config, run_dir)
        info.setdefault("resumed_from", []).append(str(model_path.name))
        return _run_pipeline(config, model, run_dir, info, progress, None, False)


def _load_for_resume(config: TrainConfig, run_dir: Path, verbose: int) -> tuple[Path, Any]:
    """The newest saved model of the run on fresh training envs, with its statistics."""
    from stable_baselines3.common.vec_env import VecNormalize

    model_path, stats_path = latest_model(run_dir)
    # Fresh env seeds for the continuation: the same seeds would replay the first episodes.
    venv = make_train_env(config, seed=config.seed + 7919)
    try:
        check_stages(config, venv)
        if config.normalize is not None:
            if stats_path is None:
                raise ValueError(
                    f"{run_dir}: normalize is on but no VecNormalize statistics found")
            venv = VecNormalize.load(str(stats_path), venv)
            venv.training = True
        model = algo_class(config.algo).load(
            str(model_path), env=venv, device=config.device,
            tensorboard_log=str(run_dir / "tb"), verbose=verbose,
        )
    except BaseException:
        venv.close()
        raise
    return model_path, model
