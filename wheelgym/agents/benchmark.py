"""The results benchmark (``wheelgym benchmark``), one module per job:

========================== ===================================================================
module                     job
========================== ===================================================================
:mod:`~.grid`              the grid of (config, seed) jobs: local serial, a process pool, or
                           Ray tasks (:mod:`~.cluster`); one CSV row per finished job
:mod:`~.scoring`           agent, baseline and random on the same evaluation seeds; steps to
                           the baseline's level
:mod:`~.store`             the results CSV: locked appends, rewrites, ``config_sha`` digests
:mod:`~.rescore`           scoring a CSV's runs again from their folders
:mod:`~.table`             the Markdown table (IQM, bootstrap CI, worst seed, recipe,
                           targets from ``targets.yml``), the results page, the README summary,
                           the planning page's navigate seeds
:mod:`~.plots`             learning curves from the runs' eval.csv
========================== ===================================================================

This module gathers their public names under the one name the command line and older code use.
"""

from __future__ import annotations

from wheelgym.agents.grid import BenchmarkSummary, default_configs, run_benchmark, run_jobs
from wheelgym.agents.plots import plot_curves
from wheelgym.agents.rescore import rescore
from wheelgym.agents.scoring import EVAL_SEED, steps_to_baseline
from wheelgym.agents.store import COLUMNS, DEFAULT_CSV, config_digest, read_rows
from wheelgym.agents.table import (
    NAVIGATE_BEGIN,
    NAVIGATE_END,
    README_BEGIN,
    README_END,
    between,
    format_table,
    load_targets,
    navigate_rows,
    readme_summary,
    readme_table,
    results_page,
    target_misses,
    update_between,
    update_readme,
)

__all__ = [
    "COLUMNS",
    "DEFAULT_CSV",
    "EVAL_SEED",
    "README_BEGIN",
    "README_END",
    "NAVIGATE_BEGIN",
    "NAVIGATE_END",
    "run_benchmark",
    "run_jobs",
    "read_rows",
    "format_table",
    "results_page",
    "readme_summary",
    "readme_table",
    "update_readme",
    "navigate_rows",
    "between",
    "update_between",
    "load_targets",
    "target_misses",
    "plot_curves",
    "steps_to_baseline",
    "default_configs",
    "config_digest",
    "BenchmarkSummary",
    "rescore",
]
