"""The ``wheelgym`` command.

======================================= ==================================================
command                                 what it does
======================================= ==================================================
``wheelgym main``                       train the default config (ThreeWheel, goal task),
                                        evaluate it, print agent vs baseline vs random
``wheelgym train CONFIG``               train from a YAML config into a new run folder
``wheelgym train --resume RUN``         continue a run from its last model or checkpoint
``wheelgym evaluate RUN``               table (Markdown + CSV), plots, optional video
``wheelgym evaluate --pretrained NAME`` the same for a shipped agent (agents/pretrained/)
``wheelgym tune CONFIG``                Optuna hyperparameter search; writes the best config
                                        (``--storage URL``: workers on many machines)
``wheelgym tune --export NAME``         write the best config of an existing study
``wheelgym benchmark [CONFIGS]``        configs x seeds -> one CSV row each (resumable;
                                        ``--ray ADDRESS``: as Ray tasks on a cluster)
``wheelgym benchmark --table``          the results table (Markdown) from that CSV
``wheelgym benchmark --rescore``        score that CSV's runs again (a changed evaluation)
``wheelgym benchmark --curves OUT``     learning curves of the configs given, from that CSV
``wheelgym pretrained list|export``     the shipped agents; export the best seeds of the
                                        benchmark CSV into agents/pretrained/
``wheelgym demo ID``                    watch (or save a GIF/MP4 of) the baseline driving
                                        (``--agent NAME``: a shipped agent instead)
``wheelgym validate``                   the physics validation report
``wheelgym robustness TARGET``          perturbation sweep of a shipped agent or run: agent
                                        vs nominal- and true-model baseline vs random
``wheelgym configs [NAME]``             the shipped configs' names, or one config's YAML
``wheelgym export SOURCE --onnx FILE``  a run's or shipped agent's deterministic policy,
                                        normalisation included, as one ONNX graph
======================================= ==================================================

A ``CONFIG`` argument is a config file, or the name of a shipped config
(``ThreeWheel-goal-velocity``; :mod:`wheelgym.resources`): a file given by path wins, the
current folder is never searched. Output folders default to ``runs/`` in the current folder.

Training commands need the ``train`` extra; ``--ray`` and PostgreSQL storages the ``cluster``
extra.

Exit status: 0 on success; 2 for an error in the arguments, a config or a run folder, and for
files that cannot be read or written (one line on stderr: ``wheelgym <command>: error: ...``);
1 for any other failure (also one line, naming the exception; a training run that raised is
recorded as ``failed`` in its run.json); 130 after Ctrl-C (SIGINT): a training run stops at the
next step, saves its model and statistics, records ``interrupted`` and exits with 130, also
with a ``subproc`` vector env. ``--debug`` (before or after the command) or ``WHEELGYM_DEBUG=1``
shows the traceback instead.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import sys
import time
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING

from wheelgym import resources

if TYPE_CHECKING:
    from typing import TypeAlias

    #: The parser's subcommands (what ``add_subparsers`` returns).
    _Commands: TypeAlias = "argparse._SubParsersAction[argparse.ArgumentParser]"

__all__ = ["main"]


#: Largest accepted integer argument (seeds need < 2**32; step counts beyond this are typos).
MAX_INT = 2**32 - 1


def _int_arg(text: str, lo: int) -> int:
    """An integer argument in ``[lo, MAX_INT]``; ``2e5`` style accepted when it is whole."""
    text = text.strip()
    try:
        value = int(text)
    except ValueError:
        try:
            f = float(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"expected an integer, got {text!r}") from None
        if math.isfinite(f) and not f.is_integer():
            raise argparse.ArgumentTypeError(f"expected a whole number, got {text!r}") from None
        if not math.isfinite(f) or abs(f) > MAX_INT:
            raise argparse.ArgumentTypeError(
                f"expected an integer in [{lo}, {MAX_INT}], got {text!r}") from None
        value = int(f)
    if value < lo or value > MAX_INT:
        raise argparse.ArgumentTypeError(f"expected an integer in [{lo}, {MAX_INT}], got {text!r}")
    return value


def _positive_int(text: str) -> int:
    return _int_arg(text, 1)


def _nonneg_int(text: str) -> int:
    return _int_arg(text, 0)


def _positive_float(text: str) -> float:
    try:
        value = float(text.strip())
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number, got {text!r}") from None
    if not (math.isfinite(value) and value > 0):
        raise argparse.ArgumentTypeError(f"expected a positive number, got {text!r}")
    return value


class _Parser(argparse.ArgumentParser):
    """``ArgumentParser`` whose errors are one line on stderr (exit status 2)."""

    def error(self, message: str):  # type: ignore[override]
        self.exit(2, f"{self.prog}: error: {' '.join(message.split())} "
                     f"(see {self.prog} --help)\n")


def _add_debug(p: argparse.ArgumentParser, default: object) -> None:
    p.add_argument("--debug", action="store_true", default=default,
                   help="show the Python traceback of an error")


def _add_main(sub: _Commands) -> argparse.ArgumentParser:
    """``wheelgym main``'s arguments."""
    m = sub.add_parser("main", help="train the default agent, evaluate it, print the table")
    m.add_argument("--config", type=Path, default=None,
                   help="config file or shipped config name (default: "
                        f"{resources.DEFAULT_CONFIG}; see `wheelgym configs`)")
    m.add_argument("--total-timesteps", type=_positive_int, default=None)
    m.add_argument("--seed", type=_nonneg_int, default=None)
    m.add_argument("--episodes", type=_positive_int, default=50,
                   help="evaluation episodes per policy (default 50)")
    m.add_argument("--runs-root", type=Path, default=resources.runs_dir())
    m.add_argument("--no-progress", action="store_true")
    return m


def _add_train(sub: _Commands) -> argparse.ArgumentParser:
    """``wheelgym train``'s arguments."""
    t = sub.add_parser("train", help="train an SB3 agent from a YAML config")
    t.add_argument("config", nargs="?", type=Path,
                   help="config file or shipped config name (see `wheelgym configs`)")
    t.add_argument("--seed", type=_nonneg_int, default=None, help="override the config's seed")
    t.add_argument("--total-timesteps", type=_positive_int, default=None,
                   help="override n_timesteps (with --resume: the new total)")
    t.add_argument("--run-dir", type=Path, default=None,
                   help="run folder to create (default runs/<name>-s<seed>-<time>)")
    t.add_argument("--runs-root", type=Path, default=resources.runs_dir())
    t.add_argument("--resume", type=Path, default=None, metavar="RUN",
                   help="continue this run folder instead of starting one")
    t.add_argument("--no-progress", action="store_true")
    t.add_argument("--verbose", type=int, default=0, choices=(0, 1, 2))
    return t


def _add_evaluate(sub: _Commands) -> argparse.ArgumentParser:
    """``wheelgym evaluate``'s arguments."""
    e = sub.add_parser("evaluate", help="score a run against the baseline and a random policy")
    e.add_argument("run", nargs="?", type=Path,
                   help="run folder (holds config.yml and model.zip)")
    e.add_argument("--pretrained", default=None, metavar="NAME",
                   help="evaluate the shipped agent NAME (a config name, see `wheelgym "
                        "pretrained list`) instead of a run folder")
    e.add_argument("--episodes", type=_positive_int, default=50)
    e.add_argument("--seed", type=_nonneg_int, default=100_000,
                   help="first episode seed (episodes use seed, seed+1, ...)")
    e.add_argument("--video", action="store_true", help="also write one video per policy")
    e.add_argument("--best", action="store_true", help="use best_model.zip, not model.zip")
    e.add_argument("--out", type=Path, default=None,
                   help="output folder (default RUN/eval, or runs/pretrained-eval/NAME)")
    return e


def _add_tune(sub: _Commands) -> argparse.ArgumentParser:
    """``wheelgym tune``'s arguments."""
    u = sub.add_parser("tune", help="hyperparameter search with Optuna (writes the best config)")
    u.add_argument("config", nargs="?", type=Path,
                   help="config file or shipped config name to tune (see `wheelgym configs`)")
    u.add_argument("--trials", type=_positive_int, default=None,
                   help="trials this call runs (default 20; unlimited with --timeout)")
    u.add_argument("--timesteps", type=_positive_int, default=None,
                   help="training steps per trial (default: the config's n_timesteps)")
    u.add_argument("--timeout", type=_positive_float, default=None, metavar="SECONDS",
                   help="start no trial after this many seconds")
    u.add_argument("--storage", default=None, metavar="URL",
                   help="Optuna storage shared by the study's workers: SQLAlchemy URL "
                        "(sqlite:///F.db, postgresql+psycopg://U:P@HOST/DB, mysql+pymysql://...), "
                        "journal:///PATH.log or a .log path (a journal file on a shared file "
                        "system), or a SQLite file (default RUNS_ROOT/STUDY/study.db)")
    u.add_argument("--max-saturation", type=float, default=None, metavar="SHARE",
                   help="constraint: a trial whose final model saturates (an action or a "
                        "controller torque clipped) on more than this share of the steps "
                        "(0..1, e.g. 0.25) is infeasible; the best config is the best feasible "
                        "trial's")
    u.add_argument("--heartbeat", type=_positive_int, default=None, metavar="SECONDS",
                   help="seconds between a running trial's heartbeats (default 30); a trial "
                        "silent for 4x that is marked failed by the next worker")
    u.add_argument("--study-name", default=None,
                   help="study to create or continue (default <Robot>-<task>-<mode>-<algo>)")
    u.add_argument("--runs-root", type=Path, default=resources.runs_dir("tune"),
                   help="study folders (trial runs, study.db, best.yml) go here")
    u.add_argument("--seed", type=_nonneg_int, default=0,
                   help="sampler seed; trial n trains with seed + n")
    u.add_argument("--algo", default=None, choices=("ppo", "sac", "td3"),
                   help="tune this algorithm instead of the config's")
    u.add_argument("--metric", default="return", choices=("return", "success", "rms"),
                   help="objective: last evaluation's mean return, success rate (maximised) "
                        "or RMS tracking error (minimised)")
    u.add_argument("--pruner", default="median", choices=("median", "halving", "none"))
    u.add_argument("--evals", type=_positive_int, default=5,
                   help="evaluations per trial (pruning points; default 5)")
    u.add_argument("--eval-episodes", type=_positive_int, default=None,
                   help="episodes per evaluation (default: the config's)")
    u.add_argument("--no-enqueue", action="store_true",
                   help="do not make the config's own hyperparameters the first trial")
    u.add_argument("--export", default=None, metavar="NAME",
                   help="only write the best config of study NAME (with --storage, --out)")
    u.add_argument("--out", type=Path, default=None,
                   help="best config file (default RUNS_ROOT/STUDY/best.yml)")
    return u


def _add_benchmark(sub: _Commands) -> argparse.ArgumentParser:
    """``wheelgym benchmark``'s arguments."""
    b = sub.add_parser("benchmark", help="results table: configs x seeds vs baseline/random")
    b.add_argument("configs", nargs="*", type=Path,
                   help="config files or shipped config names (default: every shipped "
                        "config); with --table or --curves: the configs to show (default all "
                        "in the CSV)")
    b.add_argument("--quick", action="store_true",
                   help="1 seed, a tenth of each budget, 5 episodes")
    b.add_argument("--seeds", type=_positive_int, default=None,
                   help="seeds FIRST .. FIRST+N-1 (5)")
    b.add_argument("--first-seed", type=_nonneg_int, default=0, metavar="FIRST",
                   help="the first seed (0: the table's; e.g. 5 for seeds that no recipe was "
                        "chosen on; their rows join the CSV's table)")
    b.add_argument("--episodes", type=_positive_int, default=None,
                   help="evaluation episodes per seed (50)")
    b.add_argument("--budget", type=_positive_int, default=None,
                   help="training steps per run (default: each config's n_timesteps)")
    b.add_argument("--workers", type=_positive_int, default=None,
                   help="parallel training processes (1 torch and 1 numba thread each; "
                        "default 1); with --ray: tasks at a time (local: its CPUs)")
    b.add_argument("--ray", default=None, metavar="ADDRESS",
                   help="run each (config, seed) as a Ray task: 'local' (a Ray instance in "
                        "this process on 127.0.0.1), 'auto' (the cluster of `ray start` here) "
                        "or HOST:PORT of a head node; needs the cluster extra")
    b.add_argument("--csv", type=Path, default=None,
                   help="results CSV, appended row by row; rows present are skipped "
                        "(default: a checkout's benchmarks/results/training.csv, else "
                        "runs/benchmark/training.csv)")
    b.add_argument("--drop-stale", action="store_true",
                   help="remove the CSV's rows of the configs given that were made with other "
                        "settings than their files now have (column config_sha), and, without "
                        "--budget, those at another budget than n_timesteps; then train them")
    b.add_argument("--table", action="store_true",
                   help="only print the Markdown table of the CSV (no training)")
    b.add_argument("--curves", type=Path, default=None, metavar="OUT.png",
                   help="only draw learning curves of the configs given from the CSV's runs")
    b.add_argument("--rescore", action="store_true",
                   help="train nothing: score the CSV's rows (of the configs given; default "
                        "all) again from their run folders, after a change to the evaluation, "
                        "and replace their score columns")
    b.add_argument("--runs-root", type=Path, default=resources.runs_dir("benchmark"))
    b.add_argument("--out", type=Path, default=None, help="also write the table here (.md)")
    b.add_argument("--readme", type=Path, default=None, metavar="README.md",
                   help="also put the short results summary between the results-summary "
                        "markers of this file")
    b.add_argument("--page", type=Path, default=None, metavar="RESULTS.md",
                   help="also write the results page (the full table and the curves), e.g. "
                        "docs/topics/results.md")
    b.add_argument("--navigate-page", type=Path, default=None, metavar="PAGE.md",
                   help="also put the navigate configs' seeds between the navigate-rows "
                        "markers of this file, e.g. docs/topics/planning.md")
    return b


def _add_pretrained(sub: _Commands) -> argparse.ArgumentParser:
    """``wheelgym pretrained``'s arguments."""
    r = sub.add_parser("pretrained", help="list the shipped agents, or export them from the "
                                          "benchmark CSV")
    r.add_argument("action", choices=("list", "export"),
                   help="list: the agents and their cards; export: copy the best seed of each "
                        "config from the CSV")
    r.add_argument("configs", nargs="*", type=Path,
                   help="export: the configs (names or files) to export, those that met their "
                        "targets (default: every config in the CSV)")
    r.add_argument("--csv", type=Path, default=None,
                   help="export: results CSV (default as for `wheelgym benchmark`)")
    r.add_argument("--root", type=Path, default=None,
                   help="folder of agents (default $WHEELGYM_PRETRAINED, else the shipped "
                        "agents; export: a checkout's agents/pretrained)")
    r.add_argument("--size-limit", type=_positive_float, default=None, metavar="MB",
                   help="export: refuse to make the folder larger than this (default 15)")
    return r


def _add_demo(sub: _Commands) -> argparse.ArgumentParser:
    """``wheelgym demo``'s arguments."""
    d = sub.add_parser("demo", help="render the analytic baseline (or a shipped agent) driving "
                                    "an environment")
    d.add_argument("env_id", metavar="ID", help="e.g. ThreeWheel-v0 or wheelgym/ThreeWheel-v0")
    d.add_argument("--task", default=None, help="goal, track or navigate")
    d.add_argument("--action-mode", default=None,
                   help="the robot's action mode (dynamic robots: torque, velocity or "
                        "voltage; kinematic robots: their input modes)")
    d.add_argument("--agent", default=None, metavar="NAME",
                   help="drive with the shipped agent NAME (a config name; the env is made "
                        "with its config's env kwargs) instead of the baseline")
    d.add_argument("--seed", type=_nonneg_int, default=0)
    d.add_argument("--episodes", type=_positive_int, default=1)
    d.add_argument("--out", type=Path, default=None,
                   help="save instead of opening a window: .gif, .mp4, or a folder of PNGs "
                        "(the default without a display: runs/demo/<ID>.gif)")
    return d


def _add_validate(sub: _Commands) -> argparse.ArgumentParser:
    """``wheelgym validate``'s arguments."""
    v = sub.add_parser("validate", help="run the physics validation report")
    v.add_argument("args", nargs="*", help="passed on to wheelgym.validate")
    return v


def _add_robustness(sub: _Commands) -> argparse.ArgumentParser:
    """``wheelgym robustness``'s arguments."""
    rb = sub.add_parser("robustness", help="sweep perturbations: agent vs nominal- and "
                                           "true-model baseline vs random")
    rb.add_argument("target", metavar="TARGET", nargs="?", default=None,
                    help="a shipped agent's name (agents/pretrained/) or a run folder "
                         "(optional with --page)")
    rb.add_argument("--episodes", type=_positive_int, default=50,
                    help="episodes per level and policy, one batch (default 50)")
    rb.add_argument("--seed", type=_nonneg_int, default=100_000,
                    help="first seed (default 100000)")
    rb.add_argument("--axes", default=None,
                    help="comma-separated axes (default: every axis the robot has)")
    rb.add_argument("--policies", default=None,
                    help="comma-separated of agent, baseline-nom, baseline-true, random "
                         "(default: all)")
    rb.add_argument("--out", type=Path, default=None,
                    help="folder of the CSV and figures (default: the checkout's "
                         "benchmarks/results/robustness, else runs/robustness)")
    rb.add_argument("--csv", type=Path, default=None,
                    help="CSV to append to and resume from (default OUT/robustness.csv)")
    rb.add_argument("--drop-stale", action="store_true",
                    help="remove the CSV's stale rows of TARGET: agent rows that another "
                         "model.zip made (column agent_sha: the agent was retrained or "
                         "re-exported) and rows scored on another env (column env_sha: the "
                         "config's env_kwargs changed), then sweep them again")
    rb.add_argument("--plots-only", action="store_true",
                    help="redraw the figures and the summary from the CSV, run nothing")
    rb.add_argument("--page", type=Path, default=None, metavar="PAGE.md",
                    help="also write the results page from the whole CSV (e.g. "
                         "docs/topics/robustness-results.md); without TARGET only that")
    return rb


def _add_configs(sub: _Commands) -> argparse.ArgumentParser:
    """``wheelgym configs``'s arguments."""
    c = sub.add_parser("configs", help="list the shipped configs, or print one (to copy and "
                                       "edit: wheelgym configs NAME > my.yml)")
    c.add_argument("name", nargs="?", default=None, metavar="NAME",
                   help="print this config's YAML instead of the list")
    return c


def _add_export(sub: _Commands) -> argparse.ArgumentParser:
    """``wheelgym export``'s arguments."""
    x = sub.add_parser("export", help="write a trained agent's deterministic policy (with its "
                                      "observation normalisation) as one ONNX graph")
    x.add_argument("source", metavar="CONFIG_OR_RUN",
                   help="run folder (holds config.yml and model.zip), or a shipped agent's "
                        "name or config path (see `wheelgym pretrained list`)")
    x.add_argument("--onnx", type=Path, required=True, metavar="FILE",
                   help="the .onnx file to write")
    x.add_argument("--best", action="store_true", help="a run's best_model.zip, not model.zip")
    x.add_argument("--check", type=_nonneg_int, default=1000, metavar="N",
                   help="compare ONNX Runtime's actions with SB3's predict(deterministic=True) "
                        "on N observations drawn from the observation space (default 1000; "
                        "0: no check)")
    return x


def _parser() -> argparse.ArgumentParser:
    p = _Parser(
        prog="wheelgym",
        description="Wheeled-robot Gymnasium environments: train, evaluate, demo, validate.",
    )
    _add_debug(p, False)
    sub = p.add_subparsers(dest="command", required=True, metavar="COMMAND")
    for add in (_add_main, _add_train, _add_evaluate, _add_tune, _add_benchmark, _add_pretrained,
                _add_demo, _add_validate, _add_robustness, _add_configs, _add_export):
        # after the command too; keeps a --debug given before
        _add_debug(add(sub), argparse.SUPPRESS)
    return p


# --------------------------------------------------------------------------------------------


def _print(*args) -> None:
    print(*args, flush=True)


def _cmd_train(a: argparse.Namespace) -> int:
    from wheelgym.agents.train import resume, train

    if a.resume is not None:
        if a.config is not None or a.seed is not None or a.run_dir is not None:
            raise ValueError("--resume RUN takes no CONFIG, --seed or --run-dir "
                             "(the run's own config.yml is used)")
        result = resume(a.resume, total_timesteps=a.total_timesteps,
                        progress=not a.no_progress, verbose=a.verbose)
    else:
        if a.config is None:
            raise ValueError("give a CONFIG (a file or a shipped name, see `wheelgym configs`) "
                             "or --resume RUN")
        a.config = resources.config_path(a.config, "CONFIG")
        result = train(a.config, seed=a.seed, total_timesteps=a.total_timesteps,
                       run_dir=a.run_dir, runs_root=a.runs_root, progress=not a.no_progress,
                       verbose=a.verbose)
    _print(f"{result.status}: {result.timesteps} steps in {result.wall_s:.1f} s -> "
           f"{result.run_dir}")
    return 130 if result.status == "interrupted" else 0


def _cmd_evaluate(a: argparse.Namespace) -> int:
    from wheelgym.agents.evaluate import evaluate_agent, evaluate_run

    t0 = time.perf_counter()
    if a.pretrained is not None:
        if a.run is not None or a.best:
            raise ValueError("--pretrained NAME takes no RUN folder and no --best (a shipped "
                             "agent is one final model)")
        from wheelgym.agents.pretrained import load_pretrained

        agent, config = load_pretrained(a.pretrained)
        name = Path(config.source).parent.name
        out = a.out if a.out is not None else resources.runs_dir("pretrained-eval", name)
        res = evaluate_agent(agent, config, out, episodes=a.episodes, seed=a.seed,
                             video=a.video, label=f"pretrained {name}")
    elif a.run is None:
        raise ValueError("give a RUN folder or --pretrained NAME")
    else:
        res = evaluate_run(a.run, episodes=a.episodes, seed=a.seed, video=a.video,
                           out_dir=a.out, model="best" if a.best else "final")
    _print(res.table)
    for note in res.notes:
        _print(note)
    _print(f"\nwrote {', '.join(sorted(p.name for p in res.files.values()))} to {res.out_dir} "
           f"({time.perf_counter() - t0:.1f} s)")
    return 0


def _cmd_main(a: argparse.Namespace) -> int:
    from wheelgym.agents.config import default_config_path, load_config
    from wheelgym.agents.evaluate import evaluate_run
    from wheelgym.agents.train import train

    path = (resources.config_path(a.config, "--config") if a.config is not None
            else default_config_path())
    config = load_config(path, "--config")
    steps = a.total_timesteps or config.n_timesteps
    _print(f"wheelgym main: training {config.algo.upper()} on {config.env_id} "
           f"{config.env_kwargs} for {steps} steps ({path})")
    t0 = time.perf_counter()
    result = train(config, seed=a.seed, total_timesteps=a.total_timesteps,
                   runs_root=a.runs_root, progress=not a.no_progress)
    t_train = time.perf_counter() - t0
    if result.status == "interrupted":
        _print(f"interrupted at {result.timesteps} steps; model saved in {result.run_dir}")
        return 130
    _print(f"trained {result.timesteps} steps in {t_train:.0f} s -> {result.run_dir}")
    t1 = time.perf_counter()
    res = evaluate_run(result.run_dir, episodes=a.episodes)
    t_eval = time.perf_counter() - t1
    _print("")
    _print(res.table)
    for note in res.notes:
        _print(note)
    _print(f"\nevaluation {t_eval:.0f} s; total {time.perf_counter() - t0:.0f} s. "
           f"Table, CSV and plots in {res.out_dir}")
    return 0


def _cmd_tune(a: argparse.Namespace) -> int:
    try:
        from wheelgym.agents.tune import export_best, tune
    except ImportError as e:
        raise ValueError(f"wheelgym tune needs optuna (pip install -e '.[train]'): {e}") from None

    if a.out is not None:
        _check_writable_file(a.out, "--out")
    if a.export is not None:
        if a.config is not None:
            raise ValueError("--export NAME takes no CONFIG (the study holds its config)")
        path = export_best(a.export, storage=a.storage, out=a.out, runs_root=a.runs_root)
        _print(f"wrote the best config of study {a.export!r} to {path}")
        return 0
    if a.config is None:
        raise ValueError("give a CONFIG (a file or a shipped name, see `wheelgym configs`) or "
                         "--export NAME")
    a.config = resources.config_path(a.config, "CONFIG")
    tune(a.config, trials=a.trials, timesteps=a.timesteps, timeout=a.timeout, storage=a.storage,
         study_name=a.study_name, runs_root=a.runs_root, seed=a.seed, algo=a.algo,
         metric=a.metric, pruner=a.pruner, n_evals=a.evals, eval_episodes=a.eval_episodes,
         out=a.out, enqueue_config=not a.no_enqueue, heartbeat=a.heartbeat,
         max_saturation=a.max_saturation, log=_print)
    return 0


def _cmd_benchmark(a: argparse.Namespace) -> int:
    from wheelgym.agents.benchmark import DEFAULT_CSV, run_benchmark

    csv_path = a.csv if a.csv is not None else DEFAULT_CSV
    _check_benchmark_outputs(a)
    if a.rescore:
        table = _benchmark_rescore(a, csv_path)
    elif a.table or a.curves is not None:
        table = _benchmark_from_csv(a, csv_path)
        if table is None:
            return 0
    else:
        configs = [resources.config_path(p, "CONFIGS") for p in a.configs]
        table = run_benchmark(configs or None, quick=a.quick, seeds=a.seeds,
                              first_seed=a.first_seed, episodes=a.episodes, budget=a.budget,
                              runs_root=a.runs_root,
                              csv_path=csv_path, workers=a.workers, ray=a.ray,
                              drop_stale=a.drop_stale, log=_print)
    _print(table)
    if a.out is not None:
        a.out.write_text(table + "\n")
    _benchmark_pages(a, csv_path)
    return 0


def _check_benchmark_outputs(a: argparse.Namespace) -> None:
    """The benchmark's output files, checked before any training: a typo costs nothing."""
    from wheelgym.agents.benchmark import NAVIGATE_BEGIN, NAVIGATE_END, between

    if a.out is not None:
        _check_writable_file(a.out, "--out")
    if a.curves is not None:
        _check_writable_file(a.curves, "--curves")
    if a.page is not None:
        _check_writable_file(a.page, "--page")
    if a.navigate_page is not None and (
            not a.navigate_page.is_file()
            or between(a.navigate_page.read_text(), NAVIGATE_BEGIN, NAVIGATE_END) is None):
        raise ValueError(f"--navigate-page {a.navigate_page}: not a file with the markers "
                         f"{NAVIGATE_BEGIN!r} ... {NAVIGATE_END!r}")


def _benchmark_rescore(a: argparse.Namespace, csv_path: Path) -> str:
    """``--rescore``: the CSV's runs scored again; the table of the configs given."""
    from wheelgym.agents.benchmark import format_table, read_rows, rescore

    given = [n for n, v in (("--quick", a.quick), ("--seeds", a.seeds),
                            ("--first-seed", a.first_seed),
                            ("--episodes", a.episodes), ("--budget", a.budget),
                            ("--ray", a.ray is not None), ("--drop-stale", a.drop_stale),
                            ("--table", a.table), ("--curves", a.curves is not None))
             if v]
    if given:
        raise ValueError(f"--rescore scores the CSV's runs again and trains nothing; drop "
                         f"{', '.join(given)}")
    notes = rescore(csv_path, [p.stem for p in a.configs] or None, workers=a.workers,
                    log=_print)
    for note in notes:
        _print(f"changed: {note}")
    names = {p.stem for p in a.configs}
    return format_table([r for r in read_rows(csv_path) if not names or r["config"] in names])


def _benchmark_from_csv(a: argparse.Namespace, csv_path: Path) -> str | None:
    """``--table`` and ``--curves``: read the CSV, train nothing; the table, or None without
    ``--table``."""
    from wheelgym.agents.benchmark import format_table, plot_curves, read_rows

    given = [n for n, v in (("--quick", a.quick), ("--seeds", a.seeds),
                            ("--first-seed", a.first_seed),
                            ("--episodes", a.episodes), ("--budget", a.budget),
                            ("--workers", a.workers is not None),
                            ("--ray", a.ray is not None)) if v]
    if given:
        raise ValueError(f"--table and --curves read the CSV and train nothing; drop "
                         f"{', '.join(given)}")
    rows = read_rows(csv_path)
    names = {p.stem for p in a.configs}
    if names:
        known = sorted({r["config"] for r in rows})
        bad = sorted(names - set(known))
        if bad:
            raise ValueError(f"configs {bad} have no rows in {csv_path}; configs there: "
                             f"{known}")
    if a.curves is not None:
        out = plot_curves(rows, [str(p) for p in a.configs], a.curves, log=_print)
        _print(f"wrote {out}")
    if not a.table:
        return None
    return format_table([r for r in rows if not names or r["config"] in names])


def _benchmark_pages(a: argparse.Namespace, csv_path: Path) -> None:
    """``--readme``, ``--navigate-page`` and ``--page``, written from the CSV's rows."""
    from wheelgym.agents.benchmark import (
        NAVIGATE_BEGIN,
        NAVIGATE_END,
        default_configs,
        navigate_rows,
        read_rows,
        readme_summary,
        results_page,
        update_between,
        update_readme,
    )

    if a.readme is None and a.page is None and a.navigate_page is None:
        return
    names = {p.stem for p in a.configs}
    rows = [r for r in read_rows(csv_path) if not names or r["config"] in names]
    if a.readme is not None:
        update_readme(a.readme, readme_summary(rows))
    if a.navigate_page is not None:
        update_between(a.navigate_page, NAVIGATE_BEGIN, NAVIGATE_END, navigate_rows(rows),
                       what="navigate-rows")
    if a.page is not None:
        shipped = [p.stem for p in default_configs()] if not names else sorted(names)
        a.page.write_text(results_page(rows, configs=shipped) + "\n")


def _cmd_pretrained(a: argparse.Namespace) -> int:
    from wheelgym.agents.pretrained import (
        SIZE_LIMIT_MB,
        available,
        export_best,
        pretrained_root,
        read_card,
    )

    if a.action == "list":
        given = [n for n, v in (("CONFIGS", a.configs), ("--csv", a.csv is not None),
                                ("--size-limit", a.size_limit is not None)) if v]
        if given:
            raise ValueError(f"list takes no {', '.join(given)}")
        names = available(a.root)
        if not names:
            _print(f"no pretrained agents in {pretrained_root(a.root)}")
            return 0
        for name in names:
            card = read_card(name, a.root)
            sc = card.get("scores", {})
            succ = sc.get("agent_success")
            _print(f"{name}: {str(card.get('algo', '?')).upper()}, seed {card.get('seed', '?')}, "
                   f"{card.get('n_timesteps', '?')} steps, success "
                   f"{'n/a' if succ is None else f'{100 * succ:.0f}%'}")
        return 0
    from wheelgym.agents.benchmark import DEFAULT_CSV

    csv_path = a.csv if a.csv is not None else DEFAULT_CSV
    limit = a.size_limit if a.size_limit is not None else SIZE_LIMIT_MB
    written = export_best(csv_path, [str(c) for c in a.configs] or None, out_root=a.root,
                          size_limit_mb=limit, log=_print)
    for path in written:
        card = json.loads((path / "card.json").read_text())
        nominal = card.get("nominal_success", {}).get("by_seed", {})
        ranked = ("; nominal robot: " + ", ".join(f"seed {k} {100 * v:.0f}%"
                                                   for k, v in nominal.items())) if nominal else ""
        _print(f"{card['config']}: seed {card['seed']} ({card['n_timesteps']} steps) -> {path}"
               f"{ranked}")
    return 0


def _check_writable_file(path: Path, what: str) -> None:
    """Refuse an output file path that cannot be written, before any work is done."""
    if path.is_dir():
        raise ValueError(f"{what} {str(path)!r} is a folder; give a file name")
    if not path.parent.is_dir():
        raise ValueError(f"{what} {str(path)!r}: folder {str(path.parent)!r} does not exist")


def _display_available() -> bool:
    if sys.platform in ("darwin", "win32"):
        return True
    return bool(os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY"))


def _cmd_demo(a: argparse.Namespace) -> int:
    import gymnasium as gym

    import wheelgym  # noqa: F401  (registers the ids)
    from wheelgym.agents.evaluate import run_episode, save_video
    from wheelgym.agents.policies import make_baseline

    env_id = a.env_id if "/" in a.env_id else f"wheelgym/{a.env_id}"
    if env_id not in gym.registry and f"{env_id}-v0" in gym.registry:
        env_id = f"{env_id}-v0"  # "ThreeWheel" -> "wheelgym/ThreeWheel-v0"
    if env_id not in gym.registry:
        known = sorted(k for k in gym.registry if k.startswith("wheelgym/"))
        raise ValueError(f"unknown id {a.env_id!r}; valid ids: {known}")
    kwargs = {}
    if a.task is not None:
        kwargs["task"] = a.task
    if a.action_mode is not None:
        kwargs["action_mode"] = a.action_mode
    agent = None
    if a.agent is not None:
        from wheelgym.agents.pretrained import load_pretrained

        agent, config = load_pretrained(a.agent)
        if config.env_id != env_id:
            raise ValueError(f"agent {a.agent!r} was trained on {config.env_id}, not {env_id}; "
                             f"run `wheelgym demo {config.env_id} --agent {a.agent}`")
        clash = {k: v for k, v in kwargs.items() if config.env_kwargs.get(k) != v}
        if clash:
            raise ValueError(f"agent {a.agent!r} was trained with {config.env_kwargs}; drop "
                             f"{', '.join('--' + k.replace('_', '-') for k in clash)}")
        kwargs = dict(config.env_kwargs)
    if a.out is not None and a.out.suffix in (".gif", ".mp4"):
        _check_writable_file(a.out, "--out")
    elif a.out is not None and a.out.exists() and not a.out.is_dir():
        raise ValueError(f"--out {str(a.out)!r} exists and is not a folder (for PNG frames); "
                         "give a folder, or a .gif or .mp4 file")
    human = a.out is None and _display_available()
    env = gym.make(env_id, render_mode="human" if human else "rgb_array", **kwargs)
    try:
        policy = make_baseline(env) if agent is None else agent
        frames: list = []
        for k in range(a.episodes):
            ep = run_episode(env, policy, a.seed + k, record=False, render=not human)
            frames += ep.frames
            _print(f"episode {k}: seed {a.seed + k}, {ep.length} steps, return {ep.ret:.2f}, "
                   f"success {ep.success}")
        if human:
            return 0
        out = a.out or resources.runs_dir("demo", f"{env_id.split('/')[-1]}.gif")
        if a.out is None:
            out.parent.mkdir(parents=True, exist_ok=True)
        fps = float(env.metadata.get("render_fps", 0) or 20)
    finally:
        env.close()
    if out.suffix in (".gif", ".mp4"):
        written = save_video(frames, out, fps)
        _print(f"wrote {len(frames)} frames to {written}")
    else:
        from PIL import Image

        out.mkdir(parents=True, exist_ok=True)
        for i, f in enumerate(frames):
            Image.fromarray(f).save(out / f"frame_{i:05d}.png")
        _print(f"wrote {len(frames)} PNG frames to {out}")
    return 0


def _cmd_configs(a: argparse.Namespace) -> int:
    if a.name is not None:
        path = resources.config_path(a.name, "NAME")
        sys.stdout.write(path.read_text(encoding="utf-8"))
        return 0
    for name in resources.config_names():
        _print(name)
    print(f"({len(resources.config_names())} configs in {resources.configs_dir()}; "
          "`wheelgym configs NAME > my.yml` copies one to edit)", file=sys.stderr)
    return 0


def _cmd_export(a: argparse.Namespace) -> int:
    try:
        from wheelgym.agents.export import (
            check_export,
            check_onnx_path,
            export_onnx,
            load_source,
            sample_observations,
        )
    except ImportError as e:
        raise ValueError(f"wheelgym export needs the train and onnx extras (pip install "
                         f"'wheelgym[train,onnx]'): {e}") from None

    check_onnx_path(a.onnx)
    agent, config, label = load_source(a.source, best=a.best)
    res = export_onnx(agent, a.onnx, config=config)
    ins = ", ".join(f"{k} {dt} {list(shape)}" for k, (dt, shape) in res.inputs.items())
    _print(f"{config.algo.upper()} agent {label} ({config.env_id}) -> {res.path} "
           f"({res.path.stat().st_size / 1e3:.1f} kB; inputs {ins}; output action float32 "
           f"[{res.action_dim}]; batch axis dynamic)")
    if a.check:
        err = check_export(res.path, agent, sample_observations(agent, a.check))
        _print(f"ONNX Runtime vs SB3 predict(deterministic=True) on {a.check} observations: "
               f"max |difference| {err:.3g}")
        if not err <= 1e-5:
            raise RuntimeError(f"the exported graph's actions differ from SB3's by {err:.3g} "
                               "(more than 1e-5)")
    return 0


def _cmd_validate(a: argparse.Namespace) -> int:
    try:
        from wheelgym.validate import main as validate_main
    except ImportError as e:
        raise ValueError(f"the validation report is not available: {e}") from None
    rc = validate_main(list(a.args))
    return int(rc or 0)


_COMMANDS = {
    "main": _cmd_main,
    "train": _cmd_train,
    "evaluate": _cmd_evaluate,
    "tune": _cmd_tune,
    "benchmark": _cmd_benchmark,
    "pretrained": _cmd_pretrained,
    "demo": _cmd_demo,
    "validate": _cmd_validate,
    "configs": _cmd_configs,
    "export": _cmd_export,
}


def _cmd_robustness(a: argparse.Namespace) -> int:
    from wheelgym.agents import robustness as rob

    out = rob.DEFAULT_OUT if a.out is None else a.out
    csv_path = out / "robustness.csv" if a.csv is None else a.csv

    def split(text: str | None) -> list[str] | None:
        return None if text is None else [x.strip() for x in text.split(",") if x.strip()]

    if a.target is None:
        if a.page is None:
            raise ValueError("robustness: give a TARGET (a shipped agent's name or a run "
                             "folder), or --page PAGE.md to write the results page alone")
        from wheelgym.agents.robustness_page import write_page

        _print(f"wrote {write_page(csv_path, a.page)}")
        return 0
    if a.plots_only:
        name = a.target if not (Path(a.target) / "config.yml").is_file() else Path(a.target).name
        targets = [name]
    else:
        res = rob.sweep(a.target, out=out, csv_path=csv_path, episodes=a.episodes, seed=a.seed,
                        axes=split(a.axes), policies=split(a.policies) or rob.POLICIES,
                        log=_print, drop_stale=a.drop_stale)
        _print(rob.timing_note(res))
        targets = [res["target"]]
    files = rob.plot(csv_path, out, targets)
    _print(rob.summary_table(csv_path, targets))
    _print(f"wrote {', '.join(p.name for p in files)} to {out}")
    if a.page is not None:
        from wheelgym.agents.robustness_page import write_page

        _print(f"wrote {write_page(csv_path, a.page)}")
    return 0


_COMMANDS["robustness"] = _cmd_robustness


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``wheelgym`` console script; returns the exit status."""
    parser = _parser()
    args, extra = parser.parse_known_args(argv)
    if extra:
        if args.command != "validate":
            parser.error(f"unrecognized arguments: {' '.join(extra)}")
        args.args = [*args.args, *extra]
    debug = bool(getattr(args, "debug", False) or os.environ.get("WHEELGYM_DEBUG"))
    prefix = f"wheelgym {args.command}"
    try:
        return _COMMANDS[args.command](args)
    except KeyboardInterrupt:
        if debug:
            raise
        print(f"{prefix}: interrupted", file=sys.stderr)
        return 130
    except (ValueError, TypeError, OSError) as e:  # arguments, configs, files
        if debug:
            raise
        msg = e.strerror if isinstance(e, OSError) and e.strerror else str(e)
        if isinstance(e, OSError) and e.filename is not None:
            msg = f"{e.filename}: {msg}"
        print(f"{prefix}: error: {_one_line(msg)}", file=sys.stderr)
        return 2
    except Exception as e:  # anything else: still one line (--debug for the traceback)
        if debug:
            raise
        print(f"{prefix}: error: {type(e).__name__}: {_one_line(e)} (--debug shows the "
              "traceback)", file=sys.stderr)
        return 1


def _one_line(e: object, limit: int = 2000) -> str:
    line = " ".join(str(e).split()) or "(no message)"
    return line if len(line) <= limit else line[: limit - 3] + "..."


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
