"""Score a trained agent, the analytic baseline and a random policy with one loop, same seeds.

Every policy drives the same environment through :func:`run_episode`, reset with the same
seeds, so the rows of the table differ only by the policy. Per episode:

========================= ======= =========================================================
metric                    unit    definition
========================= ======= =========================================================
success                   %       ``info["is_success"]`` at the episode's last step
return                    -       sum of rewards
RMS tracking error        m       ``sqrt(mean(e^2))`` of ``info["tracking_error"]`` over steps
                                  (distance to the goal, or to the reference on ``track``)
energy                    J       ``info["energy"]`` (cumulative motor work) at the last step
peak torque               N·m     ``max |info["motor_torque"]|`` over steps and motors
mean internal force       N·m     mean of ``|info["internal_force"]|``: the norm of the torques'
                                  null-space part (ThreeWheel; 0 for the others)
saturation                % time  share of steps with ``info["saturated"]``: an action at (or
                                  beyond) its bound, or a controller torque clipped
========================= ======= =========================================================

The table gives mean ± standard deviation over episodes; a metric that an environment does
not report reads ``n/a``. Columns that mean nothing for the environment are left out of
``results.md``, ``results.csv`` and ``episodes.csv`` (:func:`applicable_metrics`): the RMS
tracking error on ``goal`` and ``navigate`` (a distance to a goal, not a tracking error), energy
and peak torque for the kinematic robots (no motors), and the internal force for robots that
have none (all but ThreeWheel).

Plots: ``trajectories.png`` (x-y paths against goal or reference) and, per policy over its first
recorded episode, ``torques.png`` (the applied motor torques, one line per named motor:
``drive_1`` ... ``steer_3`` on ThreeWheel) for the dynamic robots or ``inputs.png`` (the
commanded inputs in physical units, e.g. ``v`` [m/s] and ``w`` [rad/s]) for the kinematic ones.
"""

from __future__ import annotations

import csv
import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np

from wheelgym.agents.common import ensure_registered, make_single_env
from wheelgym.agents.config import TrainConfig, load_run_config
from wheelgym.agents.policies import RandomPolicy, load_agent, make_baseline

__all__ = [
    "Episode",
    "run_episode",
    "evaluate_policy_episodes",
    "run_episodes_vector",
    "nominal_success",
    "make_eval_venv",
    "check_episodes",
    "summarize",
    "METRICS",
    "format_markdown",
    "write_csv",
    "evaluate_run",
    "evaluate_agent",
    "EvaluationResult",
    "applicable_metrics",
    "input_channels",
    "plot_torques",
    "plot_inputs",
]

#: Per-episode metrics in table order: (attribute, column header, scale for display).
METRICS: tuple[tuple[str, str, float], ...] = (
    ("success", "success [%]", 100.0),
    ("ret", "return", 1.0),
    ("rms_tracking_error", "RMS tracking error [m]", 1.0),
    ("energy", "energy [J]", 1.0),
    ("peak_torque", "peak torque [N·m]", 1.0),
    ("mean_internal_force", "mean internal force [N·m]", 1.0),
    ("saturation", "saturation [% time]", 100.0),
)

#: How many episodes per policy keep full traces for the plots.
TRACE_EPISODES = 4


@dataclass
class Episode:
    """One episode's scores (and, when recorded, its traces)."""

    seed: int
    ret: float = 0.0
    length: int = 0
    success: bool | None = None
    rms_tracking_error: float | None = None
    energy: float | None = None
    peak_torque: float | None = None
    mean_internal_force: float | None = None
    saturation: float | None = None
    numerical_failure: bool = False
    terminated: bool = False  # ended by the task (success, collision, ...), not by the time limit
    dt: float = 1.0
    poses: np.ndarray | None = None  # (T + 1, 3): x, y, yaw
    torques: np.ndarray | None = None  # (T, n_motors); None for robots without motors
    inputs: np.ndarray | None = None  # (T, m) commanded inputs of robots without motors
    goal: np.ndarray | None = None  # goal pose (x, y[, yaw])
    reference: np.ndarray | None = None  # (T, 3) reference poses along the episode (track)
    rewards: np.ndarray | None = None  # (T,) the reward of each step
    frames: list = field(default_factory=list)


def _norm(x: Any) -> float:
    a = np.asarray(x, dtype=np.float64)
    return float(np.sqrt(np.sum(a * a)))


def _pos_error(x: Any) -> float:
    """Tracking error as a distance [m]: a scalar as it is, a vector by its (x, y) part."""
    a = np.asarray(x, dtype=np.float64).ravel()
    return float(abs(a[0])) if a.size == 1 else float(np.hypot(a[0], a[1]))


def _reset_policy(policy: Any, seed: int) -> None:
    reset = getattr(policy, "reset", None)
    if reset is None:
        return
    try:
        reset(seed=seed)
    except TypeError:
        reset()


def _goal_of(info: dict) -> np.ndarray | None:
    """The goal pose of a goal/navigate episode (reset info ``task.goal``), else ``None``."""
    task = info.get("task")
    goal = task.get("goal") if isinstance(task, dict) else info.get("goal")
    return None if goal is None else np.asarray(goal, dtype=np.float64).ravel()


def _target_pose(env: gym.Env) -> np.ndarray | None:
    """The task's current target pose (the moving reference of ``track``), where exposed."""
    task = getattr(getattr(env.unwrapped, "core", None), "task", None)
    fn = getattr(task, "target_pose", None)
    if fn is None:
        return None
    return np.asarray(fn(), dtype=np.float64).reshape(-1, 3)[0]


#: Units of the kinematic models' input names (models.kinematic ``input_modes``).
_INPUT_UNITS = {"v": "m/s", "w": "rad/s", "psi": "rad", "psidot": "rad/s", "phidot": "rad/s",
                "phidot_L": "rad/s", "phidot_R": "rad/s"}


def _core(env: gym.Env) -> Any:
    return getattr(env.unwrapped, "core", None)


def _has_motors(env: gym.Env) -> bool:
    spec = getattr(_core(env), "spec", None)
    return spec is None or getattr(spec, "n_motor", 1) > 0


def input_channels(env: gym.Env) -> tuple[str, tuple[str, ...], tuple[str, ...]]:
    """What the input plot of ``env`` shows: ``(kind, names, units)``.

    ``kind`` is ``"torque"`` (dynamic robots: the motors, named by the robot spec's
    ``motor_names``) or ``"input"`` (kinematic robots: the commanded inputs of the action mode,
    e.g. ``("v", "w")`` in ``("m/s", "rad/s")``).
    """
    core = _core(env)
    spec = getattr(core, "spec", None)
    n_act = int(np.prod(env.action_space.shape or (0,)))
    if _has_motors(env):
        n = getattr(spec, "n_motor", n_act)
        names = tuple(getattr(spec, "motor_names", ()) or ())
        if len(names) != n:
            names = tuple(getattr(getattr(core, "model", None), "input_names", ()) or ())
        if len(names) != n:
            names = tuple(f"motor {j + 1}" for j in range(n))
        return "torque", names, ("N·m",) * n
    names = tuple(getattr(getattr(core, "model", None), "input_names", ()) or ())
    if len(names) != n_act:
        return "input", tuple(f"action {j + 1}" for j in range(n_act)), ("-",) * n_act
    return "input", names, tuple(_INPUT_UNITS.get(n, "-") for n in names)


def applicable_metrics(env: gym.Env) -> tuple[str, ...]:
    """The :data:`METRICS` attributes that mean something for ``env`` (see module docstring)."""
    core = _core(env)
    spec = getattr(core, "spec", None)
    task = getattr(core, "task_name", None)
    skip = set()
    if task in ("goal", "navigate"):
        skip.add("rms_tracking_error")
    if spec is not None:
        if getattr(spec, "n_motor", 1) == 0:
            skip |= {"energy", "peak_torque", "mean_internal_force"}
        if not getattr(spec, "has_internal_force", True):
            skip.add("mean_internal_force")
    return tuple(a for a, _, _ in METRICS if a not in skip)


def _commanded_input(env: gym.Env, action: Any) -> np.ndarray:
    """The input a robot without motors was commanded this step, in physical units.

    The environment scales the clipped action onto the input bounds into its ``U`` buffer; where
    that is not exposed, the clipped action itself (normalised, in [-1, 1]).
    """
    u = getattr(_core(env), "U", None)
    a = np.clip(np.asarray(action, dtype=np.float64).ravel(), -1.0, 1.0)
    if u is not None:
        row = np.asarray(u[0], dtype=np.float64).ravel()
        if row.size == a.size:
            return row.copy()
    return a


class _Tally:
    """The running sums of one episode's step infos (:func:`run_episode`)."""

    def __init__(self, env: gym.Env, ep: Episode, record: bool, info: dict) -> None:
        self.env, self.ep, self.record = env, ep, record
        self.motors = _has_motors(env)
        self.poses: list = []
        self.torques: list = []
        self.inputs: list = []
        self.refs: list = []
        self.rewards: list = []
        self.err2 = 0.0
        self.n_err = 0
        self.peak: float | None = None
        self.f_sum = 0.0
        self.n_force = 0
        self.n_sat = 0
        self.has_sat = False
        if record:
            ep.goal = _goal_of(info)
            if "pose" in info:
                self.poses.append(np.asarray(info["pose"], dtype=np.float64).ravel()[:3])

    def step(self, action: Any, reward: float, info: dict) -> None:
        ep, record = self.ep, self.record
        ep.ret += float(reward)
        ep.length += 1
        if record:
            self.rewards.append(float(reward))
        if "tracking_error" in info:
            e = _pos_error(info["tracking_error"])
            self.err2 += e * e
            self.n_err += 1
        if self.motors and "motor_torque" in info:
            tau = np.asarray(info["motor_torque"], dtype=np.float64).ravel()
            if tau.size:
                m = float(np.max(np.abs(tau)))
                self.peak = m if self.peak is None else max(self.peak, m)
                if record:
                    self.torques.append(tau)
        if record and not self.motors:
            self.inputs.append(_commanded_input(self.env, action))
        if "internal_force" in info and info["internal_force"] is not None:
            self.f_sum += _norm(info["internal_force"])
            self.n_force += 1
        if "saturated" in info:
            self.has_sat = True
            self.n_sat += bool(np.any(info["saturated"]))
        if "energy" in info:
            ep.energy = float(info["energy"])
        if record:
            if "pose" in info:
                self.poses.append(np.asarray(info["pose"], dtype=np.float64).ravel()[:3])
            if ep.goal is None:
                ref = _target_pose(self.env)
                if ref is not None:
                    self.refs.append(ref)
        if info.get("numerical_failure", False):
            ep.numerical_failure = True

    def finish(self, info: dict) -> Episode:
        ep = self.ep
        if "is_success" in info:
            ep.success = bool(info["is_success"])
        ep.rms_tracking_error = math.sqrt(self.err2 / self.n_err) if self.n_err else None
        ep.peak_torque = self.peak
        ep.mean_internal_force = self.f_sum / self.n_force if self.n_force else None
        ep.saturation = self.n_sat / ep.length if self.has_sat and ep.length else None
        if self.record:
            ep.poses = np.array(self.poses) if self.poses else None
            ep.torques = np.array(self.torques) if self.torques else None
            ep.inputs = np.array(self.inputs) if self.inputs else None
            ep.rewards = np.array(self.rewards)
            if self.refs and len({r.size for r in self.refs}) == 1:
                ep.reference = np.array(self.refs)
        return ep


def run_episode(
    env: gym.Env,
    policy: Any,
    seed: int,
    *,
    record: bool = True,
    deterministic: bool = True,
    render: bool = False,
) -> Episode:
    """Run one episode of ``policy`` on ``env`` reset with ``seed``; return its scores.

    ``policy`` has SB3's ``predict(obs, state, episode_start, deterministic)``. ``record``
    keeps poses, torques (or, for robots without motors, the commanded inputs), goal and
    reference for plots; ``render`` keeps ``env.render()`` frames (the env must have
    ``render_mode="rgb_array"``).
    """
    obs, info = env.reset(seed=seed)
    _reset_policy(policy, seed)
    ep = Episode(seed=seed, dt=float(getattr(env.unwrapped, "dt", 1.0) or 1.0))
    tally = _Tally(env, ep, record, info)
    if render:
        ep.frames.append(env.render())
    state = None
    start = np.ones((1,), dtype=bool)
    while True:
        action, state = policy.predict(obs, state=state, episode_start=start,
                                       deterministic=deterministic)
        start = np.zeros((1,), dtype=bool)
        obs, reward, terminated, truncated, info = env.step(action)
        tally.step(action, reward, info)
        if render:
            ep.frames.append(env.render())
        if terminated or truncated:
            ep.terminated = bool(terminated)
            break
    return tally.finish(info)


def evaluate_policy_episodes(
    env: gym.Env,
    policy: Any,
    seeds: Sequence[int],
    *,
    record: bool = True,
    deterministic: bool = True,
) -> list[Episode]:
    """:func:`run_episode` for each seed; traces kept for the first :data:`TRACE_EPISODES`."""
    return [
        run_episode(env, policy, int(s), record=record and i < TRACE_EPISODES,
                    deterministic=deterministic)
        for i, s in enumerate(seeds)
    ]


def check_episodes(episodes: Any) -> None:
    """``ValueError`` unless ``episodes`` is an int >= 1."""
    if isinstance(episodes, bool) or not isinstance(episodes, int) or episodes < 1:
        raise ValueError(f"episodes must be an int >= 1, got {episodes!r}")


def make_eval_venv(config: TrainConfig, n: int, perturbation: Any,
                   controller_model: str = "nominal") -> Any:
    """``n`` rows of ``config``'s env as one native vector env for :func:`run_episodes_vector`
    (autoreset on the next step), its ``perturbation`` replaced by ``perturbation`` and, when
    not ``"nominal"``, the velocity mode's ``controller_model`` set."""
    from gymnasium.vector import AutoresetMode

    ensure_registered(config.env_id)
    kwargs = {**config.env_kwargs, "perturbation": perturbation}
    if controller_model != "nominal":
        kwargs["controller_model"] = controller_model
    return gym.make_vec(config.env_id, num_envs=n, vectorization_mode="vector_entry_point",
                        autoreset_mode=AutoresetMode.NEXT_STEP, **kwargs)


def nominal_success(agent: Any, config: TrainConfig, *, episodes: int = 50,
                    seed: int = 100_000) -> float:
    """The success rate (0-1) of ``agent`` on the nominal robot: ``config``'s env with its
    ``perturbation`` taken out (the robustness sweep's combined level ``none``), ``episodes``
    episodes with seeds ``seed ..``, one batch of the native vector env
    (:func:`run_episodes_vector`, deterministic actions).

    What a robust agent keeps when the robot is the model; the export of a perturbed config
    ranks tied seeds by it (:func:`wheelgym.agents.pretrained.best_row`).
    """
    check_episodes(episodes)
    from wheelgym.envs.perturbation import Perturbation

    venv = make_eval_venv(config, episodes, Perturbation())
    try:
        eps = run_episodes_vector(venv, agent, [seed + i for i in range(episodes)])
    finally:
        venv.close()
    return sum(bool(e.success) for e in eps) / episodes


def run_episodes_vector(venv: Any, policy: Any, seeds: Sequence[int], *,
                        deterministic: bool = True) -> list[Episode]:
    """One episode per sub-env of a native vector env (``num_envs == len(seeds)``), all
    stepped together with one ``policy.predict`` per step on the batch of observations: sub-env
    i is reset with ``seeds[i]`` and scored as :func:`run_episode` scores the single env reset
    with that seed (the same metrics, without traces; ``tests/agents/test_robustness.py``
    checks that the two agree). ``venv`` must autoreset on the next step (the default): a
    sub-env that ended keeps stepping but is no longer scored.
    """
    n = len(seeds)
    if getattr(venv, "num_envs", None) != n:
        raise ValueError(f"run_episodes_vector needs num_envs == len(seeds) = {n}, got "
                         f"{getattr(venv, 'num_envs', None)}")
    obs, _ = venv.reset(seed=[int(s) for s in seeds])
    _reset_policy(policy, int(seeds[0]) if n else 0)
    core = getattr(venv, "core", None)
    spec = getattr(core, "spec", None)
    motors = spec is None or getattr(spec, "n_motor", 1) > 0
    dt = float(getattr(venv, "dt", 1.0) or 1.0)
    alive = np.ones(n, dtype=bool)
    ret, err2, f_sum = (np.zeros(n) for _ in range(3))  # return, squared error, force sums
    length, n_err, n_force, n_sat = (np.zeros(n, dtype=np.int64) for _ in range(4))  # counts
    success, failure, ended_by_task = (np.zeros(n, dtype=bool) for _ in range(3))
    peak, energy = np.full(n, -np.inf), np.full(n, np.nan)
    keys: set[str] = set()
    state = None
    start = np.ones(n, dtype=bool)
    while alive.any():
        action, state = policy.predict(obs, state=state, episode_start=start,
                                       deterministic=deterministic)
        start = np.zeros(n, dtype=bool)
        obs, reward, terminated, truncated, info = venv.step(action)
        keys |= set(info)
        a = alive
        ret[a] += np.asarray(reward, dtype=np.float64)[a]
        length[a] += 1
        if "tracking_error" in info:  # as _pos_error: |e| of a scalar, hypot of (x, y)
            e = np.asarray(info["tracking_error"], dtype=np.float64).reshape(n, -1)
            e = np.abs(e[:, 0]) if e.shape[1] == 1 else np.hypot(e[:, 0], e[:, 1])
            err2[a] += (e * e)[a]
            n_err[a] += 1
        if motors and "motor_torque" in info:
            tau = np.asarray(info["motor_torque"], dtype=np.float64).reshape(n, -1)
            if tau.shape[1]:
                peak[a] = np.maximum(peak[a], np.max(np.abs(tau), axis=1)[a])
        if "internal_force" in info and info["internal_force"] is not None:
            xf = np.asarray(info["internal_force"], dtype=np.float64).reshape(n, -1)
            f_sum[a] += np.sqrt(np.sum(xf * xf, axis=1))[a]
            n_force[a] += 1
        if "saturated" in info:
            s_ = np.asarray(info["saturated"]).reshape(n, -1)
            n_sat[a] += np.any(s_, axis=1)[a]
        if "energy" in info:
            energy[a] = np.asarray(info["energy"], dtype=np.float64)[a]
        if "numerical_failure" in info:
            failure[a] |= np.asarray(info["numerical_failure"], dtype=bool)[a]
        done = a & (np.asarray(terminated) | np.asarray(truncated))
        if "is_success" in info:
            success[done] = np.asarray(info["is_success"], dtype=bool)[done]
        ended_by_task[done] = np.asarray(terminated, dtype=bool)[done]
        alive = a & ~done
    out = []
    for i, sd in enumerate(seeds):
        L = int(length[i])
        out.append(Episode(
            seed=int(sd), ret=float(ret[i]), length=L,
            success=bool(success[i]) if "is_success" in keys else None,
            rms_tracking_error=math.sqrt(err2[i] / n_err[i]) if n_err[i] else None,
            energy=None if math.isnan(energy[i]) else float(energy[i]),
            peak_torque=float(peak[i]) if np.isfinite(peak[i]) else None,
            mean_internal_force=f_sum[i] / n_force[i] if n_force[i] else None,
            saturation=n_sat[i] / L if "saturated" in keys and L else None,
            numerical_failure=bool(failure[i]), terminated=bool(ended_by_task[i]), dt=dt))
    return out


def summarize(episodes: Sequence[Episode]) -> dict[str, tuple[float, float] | None]:
    """Mean and standard deviation over episodes of each metric in :data:`METRICS`."""
    out: dict[str, tuple[float, float] | None] = {}
    for attr, _, scale in METRICS:
        vals = [getattr(e, attr) for e in episodes if getattr(e, attr) is not None]
        if not vals:
            out[attr] = None
            continue
        a = np.asarray(vals, dtype=np.float64) * scale
        out[attr] = (float(a.mean()), float(a.std()))
    out["length"] = (
        float(np.mean([e.length for e in episodes])),
        float(np.std([e.length for e in episodes])),
    )
    return out


def _fmt(v: float) -> str:
    if v == 0:
        return "0"
    mag = abs(v)
    if mag >= 1000:
        return f"{v:.0f}"
    if mag >= 10:
        return f"{v:.1f}"
    if mag >= 0.01:
        return f"{v:.3g}"
    return f"{v:.2e}"


def _selected(metrics: Sequence[str] | None) -> list[tuple[str, str, float]]:
    if metrics is None:
        return list(METRICS)
    known = [a for a, _, _ in METRICS]
    bad = sorted(set(metrics) - set(known))
    if bad:
        raise ValueError(f"metrics {bad} unknown; valid metrics: {known}")
    return [m for m in METRICS if m[0] in metrics]


def format_markdown(rows: dict[str, dict[str, tuple[float, float] | None]],
                    n_episodes: int | None = None,
                    metrics: Sequence[str] | None = None) -> str:
    """A Markdown table: one row per policy, ``mean ± std`` cells, ``n/a`` where not reported.

    ``metrics``: the :data:`METRICS` attributes to show (default all), in table order.
    """
    chosen = _selected(metrics)
    head = ["policy", *(h for _, h, _ in chosen)]
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for name, stats in rows.items():
        cells = [name]
        for attr, _, _ in chosen:
            s = stats.get(attr)
            if s is None:
                cells.append("n/a")
            elif attr == "success":
                cells.append(f"{s[0]:.0f}")
            else:
                cells.append(f"{_fmt(s[0])} ± {_fmt(s[1])}")
        lines.append("| " + " | ".join(cells) + " |")
    if n_episodes is not None:
        lines.append("")
        lines.append(f"mean ± std over {n_episodes} episodes per policy, same seeds for all.")
    return "\n".join(lines)


def write_csv(path: str | Path, rows: dict[str, dict[str, tuple[float, float] | None]],
              metrics: Sequence[str] | None = None) -> None:
    """The table as CSV: ``policy, <metric>_mean, <metric>_std, ...`` (empty: not reported).

    ``metrics``: the :data:`METRICS` attributes to write (default all); ``length`` always.
    """
    names = [a for a, _, _ in _selected(metrics)] + ["length"]
    with Path(path).open("w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["policy", *(f"{n}_{s}" for n in names for s in ("mean", "std"))])
        for policy, stats in rows.items():
            cells: list[str] = [policy]
            for n in names:
                s = stats.get(n)
                cells += ["", ""] if s is None else [f"{s[0]:.6g}", f"{s[1]:.6g}"]
            w.writerow(cells)


# --------------------------------------------------------------------------------------------
# plots (matplotlib imported here only, through the object API: no global backend change)
# --------------------------------------------------------------------------------------------


def _figure(w: float, h: float):
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=(w, h), dpi=100)
    FigureCanvasAgg(fig)
    return fig


def plot_trajectories(results: dict[str, list[Episode]], path: str | Path) -> Path:
    """x-y paths of the recorded episodes of each policy, against the goal or reference."""
    n = len(results)
    fig = _figure(4.2 * n, 4.2)
    axes = fig.subplots(1, n, squeeze=False)[0]
    colors = ["C0", "C1", "C2", "C3", "C4", "C5"]
    for ax, (name, episodes) in zip(axes, results.items(), strict=True):
        shown = [e for e in episodes if e.poses is not None][:TRACE_EPISODES]
        for k, e in enumerate(shown):
            c = colors[k % len(colors)]
            ax.plot(e.poses[:, 0], e.poses[:, 1], color=c, lw=1.5,
                    label=f"seed {e.seed}" + (" ✓" if e.success else ""))
            ax.plot(e.poses[0, 0], e.poses[0, 1], "o", color=c, ms=5)
            if e.reference is not None and e.reference.shape[1] >= 2:
                ax.plot(e.reference[:, 0], e.reference[:, 1], "--", color=c, lw=1, alpha=0.7)
            if e.goal is not None and e.goal.size >= 2:
                ax.plot(e.goal[0], e.goal[1], "*", color=c, ms=13, mec="k")
                if e.goal.size >= 3:
                    ax.annotate("", xy=(e.goal[0] + 0.25 * math.cos(e.goal[2]),
                                        e.goal[1] + 0.25 * math.sin(e.goal[2])),
                                xytext=(e.goal[0], e.goal[1]),
                                arrowprops={"arrowstyle": "->", "color": c})
        if not shown:
            ax.text(0.5, 0.5, "no pose in info", ha="center", va="center",
                    transform=ax.transAxes)
        else:
            ax.set_aspect("equal", adjustable="datalim")
            ax.legend(fontsize=7, loc="best")
        ax.set_title(name)
        ax.set_xlabel("x [m]")
        ax.set_ylabel("y [m]")
        ax.grid(alpha=0.3)
    fig.suptitle("trajectories (o start, * goal, -- reference)")
    fig.tight_layout()
    fig.savefig(path)
    return Path(path)


def _plot_series(results: dict[str, list[Episode]], path: str | Path, attr: str,
                 names: Sequence[str], units: Sequence[str], missing: str, ylabel: str) -> Path:
    n = len(results)
    fig = _figure(8.0, 2.4 * n)
    axes = fig.subplots(n, 1, squeeze=False)[:, 0]
    for ax, (name, episodes) in zip(axes, results.items(), strict=True):
        e = next((e for e in episodes if getattr(e, attr) is not None), None)
        series = None if e is None else getattr(e, attr)
        if series is None or series.ndim != 2 or series.shape[1] == 0:
            ax.text(0.5, 0.5, missing, ha="center", va="center", transform=ax.transAxes)
        else:
            t = np.arange(1, len(series) + 1) * e.dt
            k = series.shape[1]
            labels = list(names)[:k] + [f"{attr} {j + 1}" for j in range(len(names), k)]
            ulabels = list(units)[:k] + ["-"] * (k - len(units))
            for j in range(k):
                unit = "" if len(set(units)) <= 1 else f" [{ulabels[j]}]"
                ax.plot(t, series[:, j], lw=1, label=labels[j] + unit)
            ax.legend(fontsize=7, ncol=min(k, 6), loc="upper right")
            ax.set_title(f"{name} (seed {e.seed})", fontsize=9)
        same = len(set(units)) == 1
        ax.set_ylabel(f"{ylabel} [{units[0]}]" if same else ylabel)
        ax.grid(alpha=0.3)
    axes[-1].set_xlabel("time [s]")
    fig.tight_layout()
    fig.savefig(path)
    return Path(path)


def plot_torques(results: dict[str, list[Episode]], path: str | Path,
                 motor_names: Sequence[str] = ()) -> Path:
    """Applied motor torques over the first recorded episode of each policy, one line per motor
    (labelled by ``motor_names``, e.g. the robot spec's)."""
    return _plot_series(results, path, "torques", motor_names, ("N·m",),
                        "no motor torques recorded", "torque")


def plot_inputs(results: dict[str, list[Episode]], path: str | Path,
                names: Sequence[str] = (), units: Sequence[str] = ()) -> Path:
    """Commanded inputs of robots without motors (e.g. ``v``, ``w``) over the first recorded
    episode of each policy."""
    return _plot_series(results, path, "inputs", names, units, "no commanded inputs recorded",
                        "commanded input")


def save_video(frames: list, path: str | Path, fps: float) -> Path:
    """Write RGB frames as MP4 (imageio-ffmpeg) or, failing that, as an animated GIF."""
    path = Path(path)
    frames = [np.asarray(f, dtype=np.uint8) for f in frames if f is not None]
    if not frames:
        raise ValueError("no frames to write (is render_mode 'rgb_array' supported?)")
    if path.suffix == ".mp4":
        try:
            import imageio.v2 as imageio

            with imageio.get_writer(path, fps=fps, macro_block_size=1) as w:
                for f in frames:
                    w.append_data(f)
            return path
        except Exception:  # no ffmpeg: fall back to GIF
            path = path.with_suffix(".gif")
    from PIL import Image

    images = [Image.fromarray(f) for f in frames]
    images[0].save(path, save_all=True, append_images=images[1:],
                   duration=max(int(1000 / fps), 20), loop=0)
    return path


# --------------------------------------------------------------------------------------------
# evaluate a run folder
# --------------------------------------------------------------------------------------------


@dataclass
class EvaluationResult:
    """Paths and numbers of one evaluation."""

    out_dir: Path
    table: str
    rows: dict[str, dict[str, tuple[float, float] | None]]
    episodes: dict[str, list[Episode]]
    files: dict[str, Path]
    notes: list[str]


def _check_episodes(episodes: Any) -> None:
    if not isinstance(episodes, int) or isinstance(episodes, bool) or episodes < 1:
        raise ValueError(f"episodes must be an integer >= 1, got {episodes!r}")


def evaluate_run(
    run: str | Path,
    *,
    episodes: int = 50,
    seed: int = 100_000,
    video: bool = False,
    out_dir: str | Path | None = None,
    model: str = "final",
    include_random: bool = True,
    include_baseline: bool = True,
) -> EvaluationResult:
    """Evaluate a run folder: agent vs baseline vs random on seeds ``seed .. seed+episodes-1``.

    Writes ``results.md``, ``results.csv``, ``episodes.csv``, ``trajectories.png``,
    ``torques.png`` (dynamic robots) or ``inputs.png`` (kinematic robots), and
    ``video_<policy>.mp4`` with ``video``, into ``out_dir`` (default ``<run>/eval``, made new if
    it exists). ``model``: ``"final"`` (model.zip) or ``"best"``. The run's agent and config
    go to :func:`evaluate_agent`.
    """
    _check_episodes(episodes)
    if model not in ("final", "best"):
        raise ValueError(f"model must be 'final' or 'best', got {model!r}")
    run = Path(run)
    if not (run / "config.yml").is_file():
        raise ValueError(f"{run}: not a run folder (no config.yml)")
    config = load_run_config(run / "config.yml")
    stem = "model" if model == "final" else "best_model"
    stats = "vecnormalize.pkl" if model == "final" else "best_vecnormalize.pkl"
    if not (run / f"{stem}.zip").is_file():
        raise ValueError(f"{run}: no {stem}.zip")
    agent = load_agent(run / f"{stem}.zip", config.algo, run / stats, device=config.device)
    return evaluate_agent(agent, config, run / "eval" if out_dir is None else out_dir,
                          episodes=episodes, seed=seed, video=video,
                          include_random=include_random, include_baseline=include_baseline,
                          label=f"run {run.name}")


def evaluate_agent(
    agent: Any,
    config: TrainConfig,
    out_dir: str | Path,
    *,
    episodes: int = 50,
    seed: int = 100_000,
    video: bool = False,
    include_random: bool = True,
    include_baseline: bool = True,
    label: str = "agent",
) -> EvaluationResult:
    """Evaluate a loaded agent (a ``predict`` policy, e.g. :func:`load_agent`'s) on its config's
    env against the baseline and random on seeds ``seed .. seed+episodes-1``.

    Writes the files listed in :func:`evaluate_run` into ``out_dir`` (made new if it exists and
    holds files). ``label`` names the agent in ``results.md``'s title (e.g. ``run <name>``).
    """
    _check_episodes(episodes)
    out = _fresh_dir(Path(out_dir))
    seeds = [seed + i for i in range(episodes)]
    notes: list[str] = []
    results: dict[str, list[Episode]] = {}
    agent_name = getattr(agent, "name", "agent")

    env = make_single_env(config)
    try:
        metrics = applicable_metrics(env)
        kind, channel_names, channel_units = input_channels(env)
        policies: dict[str, Any] = {agent_name: agent}
        if include_baseline:
            try:
                policies["baseline"] = make_baseline(env)
            except ValueError as e:
                notes.append(f"baseline skipped: {e}")
        if include_random:
            policies["random"] = RandomPolicy(env.action_space)
        for name, policy in policies.items():
            results[name] = evaluate_policy_episodes(env, policy, seeds)
    finally:
        env.close()

    rows = {name: summarize(eps) for name, eps in results.items()}
    table = format_markdown(rows, episodes, metrics)
    files = {
        "results.md": out / "results.md",
        "results.csv": out / "results.csv",
        "episodes.csv": out / "episodes.csv",
    }
    header = f"# {config.env_id} {config.env_kwargs}, {config.algo.upper()} {label}\n\n"
    files["results.md"].write_text(header + table + "\n" + "".join(f"\n{n}" for n in notes))
    write_csv(files["results.csv"], rows, metrics)
    _write_episodes_csv(files["episodes.csv"], results, metrics)
    files["trajectories.png"] = plot_trajectories(results, out / "trajectories.png")
    if kind == "torque":
        files["torques.png"] = plot_torques(results, out / "torques.png", channel_names)
    else:
        files["inputs.png"] = plot_inputs(results, out / "inputs.png", channel_names,
                                          channel_units)
    if video:
        for name in results:
            vid_env = make_single_env(config, render_mode="rgb_array")
            try:
                policy = (make_baseline(vid_env) if name == "baseline" else
                          RandomPolicy(vid_env.action_space) if name == "random" else agent)
                ep = run_episode(vid_env, policy, seeds[0], record=False, render=True)
                fps = float(vid_env.metadata.get("render_fps", 0) or 1.0 / max(ep.dt, 1e-3))
                key = "video_" + name.split(" ")[0]
                files[key] = save_video(ep.frames, out / f"{key}.mp4", fps)
            finally:
                vid_env.close()
    return EvaluationResult(out, table, rows, results, files, notes)


def _fresh_dir(path: Path) -> Path:
    if not path.exists() or (path.is_dir() and not any(path.iterdir())):
        path.mkdir(parents=True, exist_ok=True)
        return path
    for i in range(2, 1000):
        p = path.with_name(f"{path.name}-{i}")
        if not p.exists():
            p.mkdir(parents=True)
            return p
    raise RuntimeError(f"could not create an output folder next to {path}")


def _write_episodes_csv(path: Path, results: dict[str, list[Episode]],
                        metrics: Sequence[str] | None = None) -> None:
    attrs = ["seed", "length", *(a for a, _, _ in _selected(metrics)), "numerical_failure"]
    with path.open("w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["policy", *attrs])
        for name, eps in results.items():
            for e in eps:
                vals = [getattr(e, a) for a in attrs]
                w.writerow([name, *("" if v is None else (int(v) if isinstance(v, bool) else v)
                                    for v in vals)])
