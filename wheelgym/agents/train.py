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
run.json               ``status``, steps, wall time, versions; ``error`` when failed
reward_weights.csv     with a ``reward_schedule``: each change of the reward weights (step,
                       term, the weight the training envs then hold)
run.lock               present while a process trains in the folder (holds its pid)
====================== ======================================================================

``status`` in run.json: ``cloning`` while ``clone_baseline`` demonstrates and fits;
``running`` while training; ``distilling`` while ``distill_internal_force`` refits the trained
policy (after the last step; its figures go to run.json's ``distill``); ``finished`` when the
target number of steps was reached (and any distillation done); ``interrupted`` after Ctrl-C
(SIGINT); ``stopped`` when the caller's ``on_eval`` hook ended training early (a pruned tuning
trial); ``failed`` when training raised (``error`` holds the exception's type and message; the
exception propagates). A process that died without a word (SIGKILL, power loss) leaves
``running`` (or ``cloning``, ``distilling``).

Ctrl-C (SIGINT) stops at the next environment step and saves the model and statistics (a second
Ctrl-C stops at once, still saving); during ``clone_baseline`` it ends the demonstration or fit
at the next step or batch and saves the partly fitted model (``resume`` clones again); so during
``distill_internal_force`` (``resume`` distils again). ``subproc``
vector-env workers ignore SIGINT (they share the terminal's process group), so the main process
stops them cleanly. ``resume`` continues a run in
its own folder from its last saved model or checkpoint.

Only one process at a time trains in a run folder: ``train`` and ``resume`` take ``run.lock``
(created exclusively) and remove it on exit; a second process is refused with ``ValueError``. A
lock whose process no longer exists (a killed run) is stale and taken over.
"""

from __future__ import annotations

import csv
import json
import math
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
import numpy as np

from wheelgym import resources
from wheelgym.agents.common import (
    algo_class,
    build_model,
    make_single_env,
    make_train_env,
    wrap_normalize,
)
from wheelgym.agents.config import TrainConfig, load_config, weights_at
from wheelgym.agents.evaluate import applicable_metrics, evaluate_policy_episodes
from wheelgym.agents.policies import AgentPolicy

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


def _make_callbacks(config: TrainConfig, run_dir: Path, model, stop: _StopOnSignal,
                    progress: bool, wall: Callable[[], float], on_eval: EvalHook | None = None):
    """SB3 callbacks: stop on SIGINT, progress bar, checkpoints, evaluation history.

    ``wall()`` is the run's training wall time so far (s), continued across resumes; it is the
    ``wall_s`` column of eval.csv. ``on_eval`` sees each evaluation; ``False`` stops training.
    """
    from stable_baselines3.common.callbacks import (
        BaseCallback,
        CallbackList,
        CheckpointCallback,
        ProgressBarCallback,
    )

    n_envs = model.get_env().num_envs

    class StopCallback(BaseCallback):
        def _on_step(self) -> bool:
            return not stop.requested

    class EvalHistory(BaseCallback):
        """Every ``eval_freq`` steps: deterministic episodes on fixed seeds -> eval.csv."""

        def __init__(self) -> None:
            super().__init__()
            self.every = max(config.eval_freq // n_envs, 1)
            self.path = run_dir / "eval.csv"
            self.best = -math.inf
            self.env: gym.Env | None = None
            self.columns: list[str] = list(EVAL_COLUMNS)

        def _on_training_start(self) -> None:
            if not self.path.exists():
                with self.path.open("w", newline="") as f:
                    csv.writer(f).writerow(self.columns)
            else:  # resumed: keep the best so far, and the file's own columns (older runs)
                with self.path.open() as f:
                    reader = csv.DictReader(f)
                    rows = list(reader)
                    self.columns = list(reader.fieldnames or self.columns)
                if rows:
                    self.best = max(float(r["mean_return"]) for r in rows)

        def _on_step(self) -> bool:
            if self.n_calls % self.every:
                return True
            if self.env is None:
                self.env = make_single_env(config)
                self.with_rms = "rms_tracking_error" in applicable_metrics(self.env)
            if config.reward_schedule:  # returns scored with the weights training has now
                self.env.unwrapped.set_reward_weights(
                    weights_at(config.reward_schedule, self.num_timesteps))
            norm = self.model.get_vec_normalize_env()
            policy = AgentPolicy(self.model, norm)
            seeds = [EVAL_HISTORY_SEED + i for i in range(config.eval_episodes)]
            episodes = evaluate_policy_episodes(self.env, policy, seeds, record=False)
            rets = np.array([e.ret for e in episodes])
            succ = [e.success for e in episodes if e.success is not None]
            rate = float(np.mean(succ)) if succ else None
            errs = [e.rms_tracking_error for e in episodes if e.rms_tracking_error is not None]
            rms = float(np.mean(errs)) if errs and self.with_rms else None
            mean_len = float(np.mean([e.length for e in episodes]))
            wall_s = wall()
            cells = {
                "timesteps": self.num_timesteps, "wall_s": f"{wall_s:.2f}",
                "mean_return": f"{rets.mean():.6g}", "std_return": f"{rets.std():.6g}",
                "success_rate": "" if rate is None else f"{rate:.4f}",
                "mean_length": f"{mean_len:.1f}",
                "rms_tracking_error": "" if rms is None else f"{rms:.6g}",
            }
            with self.path.open("a", newline="") as f:
                csv.writer(f).writerow([cells.get(c, "") for c in self.columns])
            self.logger.record("eval/mean_reward", float(rets.mean()))
            if succ:
                self.logger.record("eval/success_rate", rate)
            if rets.mean() > self.best:
                self.best = float(rets.mean())
                self.model.save(run_dir / "best_model.zip")
                if norm is not None:
                    norm.save(str(run_dir / "best_vecnormalize.pkl"))
            if on_eval is not None:
                row = {"timesteps": int(self.num_timesteps), "wall_s": wall_s,
                       "mean_return": float(rets.mean()), "std_return": float(rets.std()),
                       "success_rate": rate, "mean_length": mean_len,
                       "rms_tracking_error": rms}
                if not on_eval(row):
                    return False
            return True

        def _on_training_end(self) -> None:
            if self.env is not None:
                self.env.close()

    class RewardSchedule(BaseCallback):
        """Sets ``config.reward_schedule``'s weights on the training envs as steps pass its
        points (also at the start, so a resumed run continues with its weights)."""

        def __init__(self) -> None:
            super().__init__()
            self.now: dict[str, float] | None = None

        def _apply(self) -> None:
            w = weights_at(config.reward_schedule, self.num_timesteps)
            if w != self.now:
                self.training_env.env_method("set_reward_weights", w)
                set_now = self.training_env.get_attr("reward_weights")[0]
                path = run_dir / "reward_weights.csv"  # the record of each change
                new = not path.exists()
                with path.open("a", newline="") as f:
                    out = csv.writer(f)
                    if new:
                        out.writerow(["timesteps", "term", "weight"])
                    for k in sorted(w):
                        out.writerow([self.num_timesteps, k, repr(set_now[k])])
                self.now = w
                for k, v in w.items():
                    self.logger.record(f"reward_weights/{k}", v)

        def _on_training_start(self) -> None:
            self._apply()

        def _on_step(self) -> bool:
            self._apply()
            return True

    callbacks: list = [StopCallback()]
    if config.reward_schedule:
        callbacks.append(RewardSchedule())
    if progress:
        callbacks.append(ProgressBarCallback())
    if config.checkpoint_freq > 0:
        callbacks.append(
            CheckpointCallback(
                save_freq=max(config.checkpoint_freq // n_envs, 1),
                save_path=str(run_dir / "checkpoints"),
                name_prefix="ckpt",
                save_vecnormalize=True,
            )
        )
    if config.eval_freq > 0:
        callbacks.append(EvalHistory())
    return CallbackList(callbacks)


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


def _learn(config: TrainConfig, model, run_dir: Path, total: int, progress: bool,
           info: dict, reset_num_timesteps: bool,
           on_eval: EvalHook | None = None) -> TrainResult:
    """Train to ``total`` steps; save and record the status in run.json whatever happens."""
    t0 = time.perf_counter()
    wall_before = float(info.get("wall_s", 0.0))
    remaining = max(total - model.num_timesteps, 0)
    status = "failed"
    error: BaseException | None = None
    with _StopOnSignal() as stop:
        try:
            info.update(status="running", target_timesteps=total)
            info.pop("error", None)
            info.pop("notes", None)
            _write_json(run_dir / "run.json", info)
            callbacks = _make_callbacks(config, run_dir, model, stop, progress,
                                        lambda: wall_before + time.perf_counter() - t0,
                                        on_eval)
            if remaining > 0:
                model.learn(
                    total_timesteps=remaining,
                    callback=callbacks,
                    reset_num_timesteps=reset_num_timesteps,
                    tb_log_name="tb",
                )
            done = model.num_timesteps >= total
            pending = done and _needs_distill(config, model, info)
            if pending and not stop.requested:
                _distill(config, model, run_dir, info, stop)
                pending = bool(info["distill"].get("interrupted"))
            status = ("interrupted" if pending else "finished" if done else
                      "interrupted" if stop.requested else
                      "stopped" if on_eval is not None else "finished")
        except KeyboardInterrupt:
            status = "interrupted"
        except BaseException as e:
            error = e
            raise
        finally:
            _finish(model, run_dir, info, status,
                    round(wall_before + time.perf_counter() - t0, 2), error)
    return TrainResult(run_dir, status, int(model.num_timesteps), info["wall_s"])


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
    """Train from a config (or its path) into a new run folder.

    ``seed`` and ``total_timesteps`` override the config (the saved ``config.yml`` holds the
    values used). ``run_dir`` names the folder (it must not exist or be empty); otherwise one is
    made under ``runs_root`` (default ``runs/``). ``on_eval`` (see :data:`EvalHook`) sees each
    periodic evaluation and may stop training (status ``stopped``).
    """
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

    if run_dir is not None:
        out, lock = _use_given_dir(Path(run_dir))
    else:
        out = new_run_dir(config, runs_root)
        lock = RunLock(out).acquire()
    try:
        try:
            venv = wrap_normalize(make_train_env(config), config)
            try:
                check_reward_schedule(config, venv)
                check_distill(config, venv)
                model = build_model(config, venv, tensorboard_log=str(out / "tb"),
                                    verbose=verbose)
            except BaseException:
                venv.close()
                raise
        except BaseException:
            lock.release()
            if not any(out.iterdir()):  # nothing written: leave no empty folder behind
                out.rmdir()
            raise
        config.dump(out / "config.yml")
        info = {
            "config_source": config.source,
            "env_id": config.env_id,
            "env_kwargs": config.env_kwargs,
            "algo": config.algo,
            "seed": config.seed,
            "started_utc": datetime.now(timezone.utc).isoformat(timespec="seconds"),
            "versions": _versions(),
            "wall_s": 0.0,
        }
        if config.clone_baseline is not None:  # the policy starts as the baseline's clone
            interrupted = _clone(config, model, out, info)
            if interrupted is not None:
                return interrupted
        return _learn(config, model, out, config.n_timesteps, progress, info, True, on_eval)
    finally:
        lock.release()


def _clone(config: TrainConfig, model, run_dir: Path, info: dict) -> TrainResult | None:
    """``clone_baseline`` before training: the fit's figures go to ``info["clone"]``.

    A first Ctrl-C ends the demonstration or the fit early; the partly fitted model and its
    statistics are then saved, run.json says ``interrupted`` (0 steps) and the result is
    returned; :func:`resume` clones again before it trains. ``None`` when the clone finished.
    """
    from wheelgym.agents.clone import clone_baseline

    t0 = time.perf_counter()
    wall_before = float(info.get("wall_s", 0.0))
    with _StopOnSignal() as stop:
        try:
            info.update(status="cloning")
            _write_json(run_dir / "run.json", info)
            fit = clone_baseline(model, config.clone_baseline, seed=config.seed,
                                 stop=lambda: stop.requested,
                                 rounds=config.clone_rounds or 1,
                                 epochs=config.clone_epochs,
                                 internal_force=config.clone_internal_force)
        except KeyboardInterrupt:  # a second Ctrl-C: stop at once, still saving
            fit = {"interrupted": True}
        except BaseException as e:  # (the caller releases the lock)
            model.get_env().close()
            info.update(status="failed", error=_short(f"{type(e).__name__}: {e}"))
            _write_json(run_dir / "run.json", info)
            raise
    wall = round(wall_before + time.perf_counter() - t0, 2)
    info["clone"] = {**fit, "wall_s": round(time.perf_counter() - t0, 2)}
    info["wall_s"] = wall
    if not fit.get("interrupted"):
        return None
    info["target_timesteps"] = config.n_timesteps
    _finish(model, run_dir, info, "interrupted", wall)
    return TrainResult(run_dir, "interrupted", int(model.num_timesteps), wall)


def _needs_distill(config: TrainConfig, model, info: dict) -> bool:
    """``distill_internal_force`` is set and has not run to its end at these steps."""
    if config.distill_internal_force is None:
        return False
    last = info.get("distill")
    return (last is None or bool(last.get("interrupted"))
            or last.get("timesteps") != int(model.num_timesteps))


def _distill(config: TrainConfig, model, run_dir: Path, info: dict, stop) -> None:
    """``distill_internal_force`` after training: the figures go to ``info["distill"]``
    (``interrupted`` when a Ctrl-C ended it early; :func:`resume` distils again)."""
    from wheelgym.agents.clone import DISTILL_ROUNDS, DISTILL_WEIGHT, distill_internal_force

    t0 = time.perf_counter()
    info.update(status="distilling")
    _write_json(run_dir / "run.json", info)
    weight = DISTILL_WEIGHT if config.distill_weight is None else config.distill_weight
    try:
        fit = distill_internal_force(model, config.distill_internal_force,
                                     rounds=config.distill_rounds or DISTILL_ROUNDS,
                                     weight=weight, seed=config.seed,
                                     stop=lambda: stop.requested)
    except KeyboardInterrupt:  # a second Ctrl-C: stop at once (the caller saves)
        fit = {"interrupted": True}
    info["distill"] = {**fit, "timesteps": int(model.num_timesteps),
                       "wall_s": round(time.perf_counter() - t0, 2)}


def check_distill(config: TrainConfig, venv) -> None:
    """``ValueError`` before training when ``distill_internal_force`` could not run after it."""
    if config.distill_internal_force is not None:
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
    """Continue a run in its own folder up to ``total_timesteps`` (default: the config's).

    Loads the newest of ``model.zip`` and the checkpoints, with its ``VecNormalize`` statistics;
    evaluation history and TensorBoard logs continue.
    """
    import torch
    from stable_baselines3.common.vec_env import VecNormalize

    run_dir = Path(run)
    if not (run_dir / "config.yml").is_file():
        raise ValueError(f"{run_dir}: not a run folder (no config.yml)")
    with RunLock(run_dir):
        config = load_config(run_dir / "config.yml")
        if total_timesteps is not None:
            config = config.replace(n_timesteps=total_timesteps)
        torch.set_num_threads(config.torch_threads)
        model_path, stats_path = latest_model(run_dir)
        # Fresh env seeds for the continuation: the same seeds would replay the first episodes.
        venv = make_train_env(config, seed=config.seed + 7919)
        try:
            check_reward_schedule(config, venv)
            check_distill(config, venv)
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
        if total_timesteps is not None:
            config.dump(run_dir / "config.yml")
        info_path = run_dir / "run.json"
        info = json.loads(info_path.read_text()) if info_path.is_file() else {}
        info.setdefault("resumed_from", []).append(str(model_path.name))
        if config.clone_baseline is not None and info.get("clone", {}).get("interrupted"):
            # Ctrl-C came during the clone: fit again (from the partial fit) before training
            interrupted = _clone(config, model, run_dir, info)
            if interrupted is not None:
                return interrupted
        return _learn(config, model, run_dir, config.n_timesteps, progress, info, False)
