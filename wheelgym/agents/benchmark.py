"""The results table: for each config (id x task x action mode), the trained agent over several
seeds against the analytic baseline and a random policy, on the same evaluation seeds.

Agent cells are the mean ± standard deviation over training seeds of each seed's mean over
evaluation episodes; baseline and random cells are over evaluation episodes (they do not train).
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from pathlib import Path

import numpy as np

from wheelgym.agents.config import TrainConfig, configs_dir, load_config

__all__ = ["run_benchmark", "benchmark_config", "default_configs"]

EVAL_SEED = 200_000


def default_configs() -> list[Path]:
    """Every ``*.yml`` file in ``configs/``, sorted."""
    return sorted(configs_dir().glob("*.yml"))


def _cell(values: Sequence[float | None], scale: float = 1.0, digits: int = 2) -> str:
    vals = [v for v in values if v is not None]
    if not vals:
        return "n/a"
    a = np.asarray(vals, dtype=np.float64) * scale
    if len(a) == 1:
        return f"{a[0]:.{digits}f}"
    return f"{a.mean():.{digits}f} ± {a.std():.{digits}f}"


def _mean(xs: Sequence[float | None]) -> float | None:
    vals = [x for x in xs if x is not None]
    return float(np.mean(vals)) if vals else None


def benchmark_config(
    config: TrainConfig,
    *,
    seeds: Sequence[int],
    episodes: int,
    budget: int,
    runs_root: Path,
    log: Callable[[str], None] | None = None,
) -> dict:
    """Train ``len(seeds)`` agents and score them, the baseline and random on the same seeds."""
    from wheelgym.agents.evaluate import evaluate_policy_episodes
    from wheelgym.agents.policies import RandomPolicy, load_agent, make_baseline
    from wheelgym.agents.train import make_single_env, train

    eval_seeds = [EVAL_SEED + i for i in range(episodes)]
    per_seed = []
    train_s = []
    for s in seeds:
        t0 = time.perf_counter()
        result = train(config, seed=s, total_timesteps=budget, runs_root=runs_root,
                       progress=False)
        train_s.append(time.perf_counter() - t0)
        if result.status != "finished":
            raise KeyboardInterrupt
        agent = load_agent(result.run_dir / "model.zip", config.algo,
                           result.run_dir / "vecnormalize.pkl", device=config.device)
        env = make_single_env(config)
        try:
            eps = evaluate_policy_episodes(env, agent, eval_seeds, record=False)
        finally:
            env.close()
        per_seed.append(eps)
        if log is not None:
            succ = _mean([e.success for e in eps])
            log(f"  {config.name} seed {s}: {budget} steps in {train_s[-1]:.0f} s, success "
                f"{'n/a' if succ is None else f'{100 * succ:.0f}%'}, "
                f"return {np.mean([e.ret for e in eps]):.1f}")
    env = make_single_env(config)
    others = {}
    try:
        try:
            others["baseline"] = evaluate_policy_episodes(env, make_baseline(env), eval_seeds,
                                                          record=False)
        except ValueError:
            others["baseline"] = None
        others["random"] = evaluate_policy_episodes(env, RandomPolicy(env.action_space),
                                                    eval_seeds, record=False)
    finally:
        env.close()

    def agent_stat(attr: str) -> list[float | None]:
        return [_mean([getattr(e, attr) for e in eps]) for eps in per_seed]

    def episode_stat(eps, attr: str) -> list[float | None]:
        return [] if eps is None else [getattr(e, attr) for e in eps]

    return {
        "config": config,
        "budget": budget,
        "n_seeds": len(seeds),
        "train_s": float(np.mean(train_s)),
        "agent": {a: agent_stat(a) for a in ("success", "ret", "rms_tracking_error")},
        "baseline": {a: episode_stat(others["baseline"], a)
                     for a in ("success", "ret", "rms_tracking_error")},
        "random": {a: episode_stat(others["random"], a)
                   for a in ("success", "ret", "rms_tracking_error")},
    }


def format_table(rows: list[dict], episodes: int, wall_s: float) -> str:
    head = [
        "robot", "task", "action", "algo", "budget [steps]", "seeds",
        "agent success [%]", "baseline success [%]", "random success [%]",
        "agent return", "baseline return", "random return",
        "agent RMS err [m]", "baseline RMS err [m]", "train [s/seed]",
    ]
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for r in rows:
        c: TrainConfig = r["config"]
        robot = c.env_id.split("/")[-1]
        lines.append("| " + " | ".join([
            robot, str(c.task or "-"), str(c.action_mode or "-"), c.algo.upper(),
            str(r["budget"]), str(r["n_seeds"]),
            _cell(r["agent"]["success"], 100, 0), _cell(r["baseline"]["success"], 100, 0),
            _cell(r["random"]["success"], 100, 0),
            _cell(r["agent"]["ret"], 1, 1), _cell(r["baseline"]["ret"], 1, 1),
            _cell(r["random"]["ret"], 1, 1),
            _cell(r["agent"]["rms_tracking_error"], 1, 3),
            _cell(r["baseline"]["rms_tracking_error"], 1, 3),
            f"{r['train_s']:.0f}",
        ]) + " |")
    lines.append("")
    lines.append(
        f"Agent: mean ± std over training seeds of the success rate (return, error) over "
        f"{episodes} evaluation episodes; baseline and random: mean ± std over the same "
        f"episodes. Total wall time {wall_s / 60:.1f} min."
    )
    return "\n".join(lines)


def run_benchmark(
    configs: Sequence[str | Path] | None = None,
    *,
    quick: bool = False,
    seeds: int | None = None,
    episodes: int | None = None,
    budget: int | None = None,
    runs_root: str | Path = "runs/benchmark",
    log: Callable[[str], None] | None = None,
) -> str:
    """Train and score each config; return the Markdown table (with its wall time).

    Defaults: 3 seeds, 20 evaluation episodes, each config's ``n_timesteps``. ``quick``: 1 seed,
    5 episodes, a tenth of each budget (at least 2048 steps).
    """
    paths = [Path(p) for p in configs] if configs else default_configs()
    n_seeds = seeds if seeds is not None else (1 if quick else 3)
    n_eps = episodes if episodes is not None else (5 if quick else 20)
    t0 = time.perf_counter()
    rows = []
    for path in paths:
        config = load_config(path)
        steps = budget if budget is not None else (
            max(config.n_timesteps // 10, 2048) if quick else config.n_timesteps)
        if log is not None:
            log(f"{path.name}: {n_seeds} seed(s) x {steps} steps")
        rows.append(benchmark_config(config, seeds=list(range(n_seeds)), episodes=n_eps,
                                     budget=steps, runs_root=Path(runs_root), log=log))
    return format_table(rows, n_eps, time.perf_counter() - t0)
