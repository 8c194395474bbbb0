"""The main job (``wheelgym main``) at its default budget: the agent reaches >= 80% success."""

from __future__ import annotations

import csv

import pytest

pytest.importorskip("stable_baselines3")

from wheelgym.cli import main  # noqa: E402


@pytest.mark.slow
def test_main_job_reaches_80_percent_success(tmp_path, capsys):
    assert main(["main", "--runs-root", str(tmp_path), "--no-progress", "--episodes", "50"]) == 0
    out = capsys.readouterr().out
    assert "| agent (PPO) |" in out and "| baseline |" in out
    (results,) = tmp_path.glob("*/eval/results.csv")
    with results.open() as f:
        rows = {r["policy"]: r for r in csv.DictReader(f)}
    assert float(rows["agent (PPO)"]["success_mean"]) >= 80.0, rows
    assert float(rows["random"]["success_mean"]) < 20.0
