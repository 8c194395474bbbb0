"""``wheelgym benchmark``: resumable CSV rows, steps to the baseline's level, the Markdown table
from a CSV, learning curves, and the configs it runs."""

from __future__ import annotations

import csv
import json
import os
from pathlib import Path

import pytest
import yaml

pytest.importorskip("stable_baselines3")

import wheelgym.agents.train as train_mod  # noqa: E402
from wheelgym.agents.benchmark import (  # noqa: E402
    COLUMNS,
    DEFAULT_CSV,
    config_digest,
    default_configs,
    format_table,
    plot_curves,
    read_rows,
    readme_table,
    run_jobs,
    steps_to_baseline,
    target_misses,
    update_readme,
)
from wheelgym.agents.config import load_config  # noqa: E402
from wheelgym.agents.grid import _scaled_eval_freq, worker_init  # noqa: E402
from wheelgym.agents.store import append_row as _append_row  # noqa: E402
from wheelgym.agents.table import TABLE_HEAD  # noqa: E402
from wheelgym.cli import main  # noqa: E402

ENV_ID = "wheelgym/ThreeWheel-v0"


def _write_config(tmp_path: Path, name: str, task: str) -> Path:
    data = {
        ENV_ID: {"policy": "MlpPolicy", "n_envs": 2, "n_timesteps": 100_000, "normalize": True,
                 "n_steps": 128, "batch_size": 128, "n_epochs": 1,
                 "policy_kwargs": {"net_arch": [16, 16]}},
        "wheelgym": {"algo": "ppo", "env_kwargs": {"task": task, "action_mode": "velocity"},
                     "seed": 0, "eval_freq": 25_000, "eval_episodes": 2, "checkpoint_freq": 0},
    }
    path = tmp_path / f"{name}.yml"
    path.write_text(yaml.safe_dump(data))
    return path


def test_benchmark_resumes_and_skips_finished_rows(tmp_path, monkeypatch, capsys):
    goal = _write_config(tmp_path, "tiny-goal", "goal")
    track = _write_config(tmp_path, "tiny-track", "track")
    out = tmp_path / "results" / "training.csv"
    runs = tmp_path / "runs"
    calls: list[int] = []
    real_train = train_mod.train

    def counting_train(*args, **kwargs):
        calls.append(1)
        return real_train(*args, **kwargs)

    monkeypatch.setattr(train_mod, "train", counting_train)
    kw = dict(seeds=1, episodes=2, budget=512, csv_path=out, runs_root=runs)
    first = run_jobs([goal, track], **kw)
    assert first.written == 2 and first.skipped == 0 and not first.failed and len(calls) == 2
    rows = read_rows(out)
    assert [r["config"] for r in rows] == ["tiny-goal", "tiny-track"]
    with out.open() as f:
        assert tuple(next(csv.reader(f))) == COLUMNS
    by = {r["config"]: r for r in rows}
    assert by["tiny-goal"]["agent_rms"] == "" and by["tiny-goal"]["baseline_rms"] == ""
    assert float(by["tiny-track"]["agent_rms"]) > 0 and float(by["tiny-track"]["baseline_rms"]) > 0
    for r in rows:
        assert r["n_timesteps"] == "512" and r["episodes"] == "2" and r["seed"] == "0"
        assert float(r["train_s"]) > 0 and float(r["cpu_s"]) > 0
        assert r["baseline_internal_force"] != ""  # ThreeWheel has one
        run_dir = Path(r["run_dir"])
        assert run_dir.parent == runs and (run_dir / "eval.csv").is_file()

    # Again, through the command line: nothing trains, the table comes from the CSV.
    capsys.readouterr()
    rc = main(["benchmark", str(goal), str(track), "--seeds", "1", "--episodes", "2",
               "--budget", "512", "--csv", str(out), "--runs-root", str(runs)])
    text = capsys.readouterr().out
    assert rc == 0 and len(calls) == 2, text
    assert "0 run(s) to do, 2 already" in text
    assert "| tiny-track | scratch | PPO | 512 | 1 | 2 |" in text
    assert len(read_rows(out)) == 2
    # Another budget is another row.
    again = run_jobs([goal], **{**kw, "budget": 256})
    assert again.written == 1 and again.skipped == 0 and len(calls) == 3

    png = tmp_path / "curves.png"
    assert plot_curves(read_rows(out), [str(goal), "tiny-track"], png) == png
    assert png.stat().st_size > 1000
    capsys.readouterr()
    assert main(["benchmark", "--table", "--csv", str(out), str(track)]) == 0
    table = capsys.readouterr().out
    assert "tiny-track" in table and "tiny-goal" not in table

    # Scored again from the run folders (a changed evaluation), training nothing: the
    # evaluation is deterministic, so the spoilt score columns come back as they were, the
    # other configs' rows are untouched, and the changed success is reported.
    before = read_rows(out)
    spoilt = [dict(r, agent_saturation="0.777", baseline_return="-1e9", agent_success="0.123")
              if r["config"] == "tiny-track" else r for r in before]
    with out.open("w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=COLUMNS)
        w.writeheader()
        w.writerows(spoilt)
    capsys.readouterr()
    assert main(["benchmark", "--rescore", "--csv", str(out), str(track)]) == 0
    text = capsys.readouterr().out
    assert len(calls) == 3 and read_rows(out) == before, text
    assert "tiny-track: 1 row(s) re-scored, 1 changed" in text
    assert f"changed: tiny-track seed 0: agent_success 0.123 -> {before[1]['agent_success']}" \
        in text
    assert _run_main(["benchmark", "--rescore", "--seeds", "2", "--csv", str(out)]) == 2
    assert "--rescore scores the CSV's runs again" in capsys.readouterr().err
    assert _run_main(["benchmark", "--rescore", "--csv", str(out), "nope.yml"]) == 2
    assert "configs ['nope'] have no rows" in capsys.readouterr().err


def test_first_seed_trains_the_seeds_after_it(tmp_path, capsys):
    """``--first-seed 3 --seeds 1`` trains seed 3 alone (seeds no recipe was chosen on), its run
    seeded with 3; the table printed is that seed's; a negative first seed is refused."""
    goal = _write_config(tmp_path, "tiny-goal", "goal")
    out, runs = tmp_path / "training.csv", tmp_path / "runs"
    rc = main(["benchmark", str(goal), "--first-seed", "3", "--seeds", "1", "--episodes", "2",
               "--budget", "512", "--csv", str(out), "--runs-root", str(runs)])
    text = capsys.readouterr().out
    assert rc == 0 and "1 run(s) to do, 0 already" in text, text
    rows = read_rows(out)
    assert [r["seed"] for r in rows] == ["3"]
    run = json.loads((Path(rows[0]["run_dir"]) / "run.json").read_text())
    assert run["seed"] == 3
    assert "| tiny-goal | scratch | PPO | 512 | 1 | 2 |" in text
    assert "(s3)" in text  # the worst (only) seed is seed 3
    with pytest.raises(ValueError, match="first_seed must be an integer >= 0"):
        run_jobs([goal], seeds=1, episodes=2, budget=512, csv_path=out, runs_root=runs,
                 first_seed=-1)
    assert _run_main(["benchmark", "--table", "--first-seed", "2", "--csv", str(out)]) == 2
    assert "--table and --curves read the CSV and train nothing; drop --first-seed" in \
        capsys.readouterr().err


def test_table_from_a_known_csv(tmp_path):
    path = tmp_path / "t.csv"
    common = {"algo": "ppo", "episodes": "10", "random_success": "0", "baseline_success": "1"}
    rows = [
        {**common, "config": "ThreeWheel-goal-velocity", "seed": "0", "n_timesteps": "1000000",
         "train_s": "10", "cpu_s": "12", "steps_to_baseline": "400000", "agent_success": "0.8",
         "agent_return": "10", "baseline_return": "12", "random_return": "-5",
         "agent_energy": "20", "baseline_energy": "10", "agent_internal_force": "0.5",
         "baseline_internal_force": "0.1", "agent_saturation": "0.1"},
        {**common, "config": "ThreeWheel-goal-velocity", "seed": "1", "n_timesteps": "1000000",
         "train_s": "14", "cpu_s": "18", "steps_to_baseline": "", "agent_success": "0.6",
         "agent_return": "8", "baseline_return": "12", "random_return": "-5",
         "agent_energy": "30", "baseline_energy": "10", "agent_internal_force": "0.7",
         "baseline_internal_force": "0.1", "agent_saturation": "0.3"},
        {**common, "config": "ThreeWheel-track-velocity", "seed": "0", "n_timesteps": "500000",
         "train_s": "100", "cpu_s": "110", "steps_to_baseline": "250000", "agent_success": "1",
         "agent_rms": "0.009", "baseline_rms": "0.017", "agent_return": "-5.5",
         "baseline_return": "-8.3", "random_return": "-60"},
    ]
    for r in reversed(rows):  # the table sorts by config
        _append_row(path, r)
    table = format_table(read_rows(path), recipes={"ThreeWheel-goal-velocity": "scratch"})
    lines = table.splitlines()
    assert lines[0] == "| " + " | ".join(TABLE_HEAD) + " |"
    goal = [c.strip() for c in lines[2].strip("|").split("|")]
    track = [c.strip() for c in lines[3].strip("|").split("|")]
    cell = dict(zip(TABLE_HEAD, goal, strict=True))
    # 2 seeds at 80 and 60%: the mean 70, the IQM of 2 values their mean, the worst seed 1
    assert (cell["config"], cell["recipe"], cell["n"], cell["success mean [%]"]) == (
        "ThreeWheel-goal-velocity", "scratch", "2", "70")
    assert cell["success IQM [95% CI] [%]"].startswith("70 [60, 80]")
    assert cell["worst seed success [%]"] == "60 (s1)"
    assert (cell["energy / baseline"], cell["internal force / baseline"]) == ("2.50x", "6.00x")
    assert (cell["steps to baseline"], cell["train [s/seed]"]) == ("400k (1/2)", "12")
    assert cell["targets (mean)"] == "**success**"
    assert cell["targets (worst seed)"] == "**success**, **saturation**"  # seed 1: 30%
    cell = dict(zip(TABLE_HEAD, track, strict=True))
    assert (cell["recipe"], cell["n"], cell["RMS IQM [95% CI] [m]"]) == (
        "?", "1", "0.009 [0.009, 0.009]")
    assert cell["targets (mean)"] == "met" == cell["targets (worst seed)"]
    assert lines[-1].endswith("Total CPU time 2.3 min (3 runs).")
    assert "of 3 seeds the middle one" in lines[-1]


def test_on_track_the_lowest_success_seed_is_not_hidden_by_the_largest_rms_one(tmp_path):
    """Seed 0 has the largest RMS error and 92% success, seed 1 88%: the worst-seed success
    target (90%) is judged on seed 1, the RMS targets on seed 0, each shown with its seed."""
    path = tmp_path / "t.csv"
    common = {"algo": "ppo", "episodes": "50", "random_success": "0", "baseline_success": "0.4",
              "config": "SkidSteer-track-velocity", "n_timesteps": "1000", "train_s": "10",
              "baseline_rms": "0.02", "agent_saturation": "0.1"}
    for seed, success, rms in (("0", "0.92", "0.03"), ("1", "0.88", "0.01"),
                               ("2", "1", "0.02")):
        _append_row(path, {**common, "seed": seed, "agent_success": success, "agent_rms": rms})
    line = format_table(read_rows(path)).splitlines()[2]
    cell = dict(zip(TABLE_HEAD, [c.strip() for c in line.strip("|").split("|")], strict=True))
    assert cell["worst seed success [%]"] == "88 (s1)"
    assert cell["worst seed RMS [m]"] == "0.030 (s0)"
    assert cell["targets (mean)"] == "met"  # 93.3% >= 90%, RMS 0.02 <= max(0.04, 0.02)
    assert cell["targets (worst seed)"] == "**success**"
    # The RMS target on the largest-RMS seed: 0.05 m > max(2 x 0.02, 0.02) m.
    _append_row(path, {**common, "seed": "3", "agent_success": "0.96", "agent_rms": "0.05"})
    line = format_table(read_rows(path)).splitlines()[2]
    cell = dict(zip(TABLE_HEAD, [c.strip() for c in line.strip("|").split("|")], strict=True))
    assert cell["worst seed RMS [m]"] == "0.050 (s3)"
    assert cell["targets (worst seed)"] == "**success**, **RMS**"


def test_iqm_and_its_bootstrap_interval():
    from wheelgym.agents.table import bootstrap_ci, iqm

    assert iqm([0.2, 1.0, 0.9]) == 0.9  # of 3: the middle one
    assert iqm([1, 2, 3, 4]) == 2.5  # of 4: the middle two
    assert iqm([0.0, 0.5, 0.6, 0.7, 1.0]) == pytest.approx(0.6)  # of 5: the middle three
    assert iqm([3.0]) == 3.0
    with pytest.raises(ValueError, match="no values"):
        iqm([])
    vals = [0.7, 1.0, 1.0, 0.9, 0.2]
    lo, hi = bootstrap_ci(vals, "k")
    assert (lo, hi) == bootstrap_ci(vals, "k")  # seeded: the same interval every time
    assert 0.2 <= lo <= iqm(vals) <= hi <= 1.0
    assert bootstrap_ci([0.5, 0.5, 0.5], "k") == (0.5, 0.5)


def test_the_targets_are_data():
    from wheelgym.agents.table import load_targets

    t = load_targets()
    assert t["goal_success"] == 0.95 and t["train_s"] == 600.0
    assert target_misses("CasterAGV-goal-torque", _col({"agent_saturation": [0.3]}),
                         {**t, "saturation": 0.5}) == []


def test_steps_to_baseline_reads_the_evaluation_history(tmp_path):
    path = tmp_path / "eval.csv"
    path.write_text("timesteps,wall_s,mean_return,std_return,success_rate,mean_length,"
                    "rms_tracking_error\n"
                    "100,1,0,0,0.5,10,0.1\n200,2,0,0,0.95,10,0.05\n300,3,0,0,1.0,10,0.039\n")
    assert steps_to_baseline(path, 1.0, None) == 200  # within 5 points
    assert steps_to_baseline(path, 0.4, None) == 100
    assert steps_to_baseline(path, 1.0, 0.02) == 300  # track: RMS within 2x
    assert steps_to_baseline(path, None, 0.01) is None
    assert steps_to_baseline(tmp_path / "missing.csv", 1.0, None) is None
    # Older eval.csv files (no RMS column) read too.
    old = tmp_path / "old.csv"
    old.write_text("timesteps,wall_s,mean_return,std_return,success_rate,mean_length\n"
                   "100,1,0,0,1.0,10\n")
    assert steps_to_baseline(old, 1.0, None) == 100 and steps_to_baseline(old, 1.0, 0.1) is None


def test_a_retuned_configs_old_rows_are_stale(tmp_path, capsys):
    cfg = _write_config(tmp_path, "tiny-goal", "goal")
    out, runs = tmp_path / "training.csv", tmp_path / "runs"
    kw = dict(seeds=1, episodes=1, csv_path=out, runs_root=runs)
    data = yaml.safe_load(cfg.read_text())
    data[ENV_ID]["n_timesteps"] = 512
    cfg.write_text(yaml.safe_dump(data))
    assert run_jobs([cfg], **kw).written == 1
    (row,) = read_rows(out)
    assert row["config_sha"] == config_digest(load_config(cfg)) and len(row["config_sha"]) == 12
    # The seed and the checkpoint period do not make a row stale; a hyperparameter does.
    data["wheelgym"].update(seed=7, checkpoint_freq=256)
    cfg.write_text(yaml.safe_dump(data))
    assert run_jobs([cfg], **kw).skipped == 1
    data[ENV_ID]["learning_rate"] = 1e-3
    cfg.write_text(yaml.safe_dump(data))
    with pytest.raises(ValueError, match="made with other settings.*--drop-stale"):
        run_jobs([cfg], **kw)
    assert read_rows(out) == [row]  # nothing touched
    again = run_jobs([cfg], **kw, drop_stale=True)
    assert again.written == 1 and again.skipped == 0
    (new,) = read_rows(out)
    assert new["config_sha"] == config_digest(load_config(cfg)) != row["config_sha"]
    # A stale row beside a current one of the same seed (CSVs merged): only the stale one goes.
    with out.open("a", newline="") as f:
        csv.DictWriter(f, fieldnames=list(row)).writerow(row)
    merged = run_jobs([cfg], **kw, drop_stale=True)
    assert merged.written == 0 and merged.skipped == 1 and read_rows(out) == [new]
    # A new budget: --drop-stale also removes the rows at the old one (not with --budget).
    data[ENV_ID]["n_timesteps"] = 768
    cfg.write_text(yaml.safe_dump(data))
    assert run_jobs([cfg], **kw, budget=512).skipped == 1  # an explicit budget: still there
    rc = main(["benchmark", str(cfg), "--seeds", "1", "--episodes", "1", "--csv", str(out),
               "--runs-root", str(runs), "--drop-stale"])
    assert rc == 0 and "dropped 1 stale row(s)" in capsys.readouterr().out
    assert [r["n_timesteps"] for r in read_rows(out)] == ["768"]
    # A row from before the column (empty config_sha) counts as finished.
    legacy = tmp_path / "legacy.csv"
    legacy.write_text(out.read_text().replace(new["config_sha"], "").replace(
        read_rows(out)[0]["config_sha"], ""))
    assert run_jobs([cfg], **{**kw, "csv_path": legacy}).skipped == 1


def test_rows_are_appended_whole_and_a_torn_line_is_skipped(tmp_path):
    path = tmp_path / "r.csv"
    _append_row(path, {"config": "a", "seed": 0, "n_timesteps": 10, "episodes": 1})
    with path.open("a") as f:
        f.write("b,ppo,0,1")  # a writer killed mid-line
    _append_row(path, {"config": "c", "seed": 0, "n_timesteps": 10, "episodes": 1})
    assert [r["config"] for r in read_rows(path)] == ["a", "c"]
    other = tmp_path / "other.csv"
    other.write_text("config,seed,n_timesteps\n")
    with pytest.raises(ValueError, match="lacks columns"):
        _append_row(other, {"config": "a"})


def test_every_config_loads_and_scales_its_evaluation():
    paths = default_configs()
    assert len(paths) >= 30
    for p in paths:
        c = load_config(p)
        assert _scaled_eval_freq(c, c.n_timesteps) == c.eval_freq
        small = _scaled_eval_freq(c, 10_000)
        assert 1 <= small <= max(10_000, c.n_envs * c.hyperparams.get("n_steps", 1))


def test_benchmark_errors_are_one_line(tmp_path, capsys):
    cfg = _write_config(tmp_path, "tiny-goal", "goal")
    missing = tmp_path / "none.csv"
    afile = tmp_path / "afile"
    afile.write_text("x")
    bad = [
        ["benchmark", "--table", "--csv", str(missing)],
        ["benchmark", "--table", "--budget", "5", "--csv", str(missing)],
        ["benchmark", "--curves", str(tmp_path), str(cfg)],
        ["benchmark", str(cfg), "--csv", str(tmp_path)],
        ["benchmark", str(cfg), "--workers", "0"],
        ["benchmark", str(cfg), "--runs-root", str(afile), "--csv", str(missing)],
    ]
    for argv in bad:
        capsys.readouterr()
        rc = _run_main(argv)
        err = capsys.readouterr().err.strip().splitlines()
        assert rc == 2, argv
        assert len(err) == 1 and err[0].startswith("wheelgym"), (argv, err)
    assert not missing.exists() and not os.path.exists(tmp_path / "runs")


def _run_main(argv: list[str]) -> int:
    try:
        return main(argv)
    except SystemExit as e:  # argparse
        return e.code if isinstance(e.code, int) else 1


def _col(values: dict[str, list[float | None]]):
    return lambda c: values.get(c, [None])


@pytest.mark.parametrize("config, values, misses", [
    ("ThreeWheel-goal-velocity", {"agent_success": [1.0, 0.96], "baseline_success": [1.0]},
     []),
    ("ThreeWheel-goal-velocity", {"agent_success": [1.0, 0.8], "baseline_success": [1.0]},
     ["success"]),  # mean 0.90 < 0.95
    ("SkidSteer-navigate-torque", {"agent_success": [0.7], "baseline_success": [0.74]}, []),
    ("SkidSteer-navigate-torque", {"agent_success": [0.6], "baseline_success": [0.74]},
     ["success"]),
    ("DiffDrive-track-WheelSpeeds", {"agent_success": [0.9], "agent_rms": [0.05],
                                     "baseline_rms": [0.02]}, ["RMS"]),  # 5 cm > 4 cm
    ("DiffDrive-track-WheelSpeeds", {"agent_success": [0.9], "agent_rms": [0.019],
                                     "baseline_rms": [0.001]}, []),  # the 2 cm floor
    ("ThreeWheel-goal-torque", {"agent_success": [1.0], "baseline_success": [1.0],
                                "agent_internal_force": [0.4], "baseline_internal_force": [0.1],
                                "agent_energy": [10.0], "baseline_energy": [8.0]},
     ["internal force"]),
    ("ThreeWheel-goal-torque", {"agent_success": [1.0], "baseline_success": [1.0],
                                "agent_internal_force": [0.2], "baseline_internal_force": [0.1],
                                "agent_energy": [13.0], "baseline_energy": [8.0]},
     ["energy"]),
    ("CasterAGV-goal-torque", {"agent_success": [1.0], "baseline_success": [1.0],
                               "agent_energy": [30.0], "baseline_energy": [8.0],
                               "agent_saturation": [0.3], "train_s": [700.0]},
     ["saturation", "time"]),  # no internal force: energy is reported, not a target
])
def test_target_misses(config, values, misses):
    assert target_misses(config, _col(values)) == misses


@pytest.mark.parametrize("config, values, misses", [
    # goal and track: >= 90% (not the mean's 95%), goal also >= baseline - 10 points
    ("ThreeWheel-goal-velocity", {"agent_success": [0.92], "baseline_success": [1.0]}, []),
    ("ThreeWheel-goal-velocity", {"agent_success": [0.88], "baseline_success": [1.0]},
     ["success"]),
    ("DiffDrive-track-WheelSpeeds", {"agent_success": [0.90]}, []),
    ("DiffDrive-track-WheelSpeeds", {"agent_success": [0.86]}, ["success"]),
    # navigate: >= baseline - 10 (not - 5)
    ("SkidSteer-navigate-velocity", {"agent_success": [0.86], "baseline_success": [0.94]}, []),
    ("CasterAGV-navigate-velocity", {"agent_success": [0.86], "baseline_success": [1.0]},
     ["success"]),
    # the other targets are the mean's
    ("Unicycle-navigate-WheelSpeedHeadingRate",
     {"agent_success": [0.96], "baseline_success": [0.96], "agent_saturation": [0.9]},
     ["saturation"]),
])
def test_the_worst_seed_is_judged_on_its_own_success_targets(config, values, misses):
    assert target_misses(config, _col(values), worst_seed=True) == misses
    # the same rows judged as means: the stricter 95% and baseline - 5
    if config in ("ThreeWheel-goal-velocity", "SkidSteer-navigate-velocity"):
        assert "success" in target_misses(config, _col(values))


def test_the_results_page_and_the_readme_summary_are_the_csv_s(tmp_path):
    """docs/topics/results.md is what the generator makes of the committed CSV; --page and
    --readme write it and the README summary in place."""
    from wheelgym.agents.table import README_BEGIN, README_END, readme_summary, results_page

    root = Path(__file__).resolve().parents[2]
    rows = read_rows(root / DEFAULT_CSV)
    page = root / "docs" / "topics" / "results.md"
    shipped = [p.stem for p in default_configs()]
    assert page.read_text() == results_page(rows, configs=shipped) + "\n"
    assert "Configs without rows yet: `nowhere`." in results_page(rows, configs=[*shipped,
                                                                               "nowhere"])
    readme = tmp_path / "README.md"
    readme.write_text(f"# x\n{README_BEGIN}\nstale\n{README_END}\nrest\n")
    out = tmp_path / "results.md"
    assert main(["benchmark", "--table", "--csv", str(root / DEFAULT_CSV), "--readme",
                 str(readme), "--page", str(out)]) == 0
    assert readme_table(readme.read_text()) == readme_summary(rows)
    assert readme.read_text().endswith(f"{README_END}\nrest\n")
    assert out.read_text() == page.read_text()
    summary = readme_summary(rows)
    assert "| goal |" in summary and "docs/topics/results.md" in summary
    shown = readme_table((root / "README.md").read_text())
    if shown is not None:  # the README carries the summary between its markers
        assert shown == summary
    plain = tmp_path / "x.md"
    plain.write_text("# x\n")
    with pytest.raises(ValueError, match="no results markers"):
        update_readme(plain, "t")


def _compile_something_new(k: int) -> tuple[int, int]:
    """Runs in a pool worker: compiles a function numba has never seen (no cache), as a worker
    does on a fresh checkout, and reports the thread settings."""
    import numba

    @numba.njit(parallel=True)
    def total(n):
        s = 0
        for i in numba.prange(n):
            s += i
        return s

    return int(total(k)), int(numba.config.NUMBA_NUM_THREADS)


def test_pool_worker_compiles_with_one_numba_thread():
    """The benchmark's workers set NUMBA_NUM_THREADS=1 after numba was imported; compiling in
    the worker must not trip numba's 'Cannot set NUMBA_NUM_THREADS ... once the threads have
    been launched' (which failed every job of a run on a cold cache)."""
    import multiprocessing as mp
    from concurrent.futures import ProcessPoolExecutor


    env = {k: os.environ.get(k) for k in ("NUMBA_NUM_THREADS",)}
    os.environ["NUMBA_NUM_THREADS"] = "2"  # what the parent (2 cores) has
    try:
        with ProcessPoolExecutor(max_workers=1, mp_context=mp.get_context("spawn"),
                                 initializer=worker_init) as pool:
            assert pool.submit(_compile_something_new, 10).result(timeout=300) == (45, 1)
    finally:
        for k, v in env.items():
            if v is None:
                os.environ.pop(k, None)
            else:
                os.environ[k] = v


def test_the_planning_page_s_navigate_seeds_are_the_csv_s(tmp_path, capsys):
    """The navigate seeds tables of docs/topics/planning.md are what the generator makes of the
    committed CSV; --navigate-page writes them between the markers and refuses a file without
    them before training anything."""
    from wheelgym.agents.table import NAVIGATE_BEGIN, NAVIGATE_END, between, navigate_rows

    root = Path(__file__).resolve().parents[2]
    rows = read_rows(root / DEFAULT_CSV)
    body = navigate_rows(rows)
    assert between((root / "docs/topics/planning.md").read_text(), NAVIGATE_BEGIN,
                   NAVIGATE_END) == body
    # one line per navigate config with rows, random arenas first, then the maps
    names = [line.split(" | ")[0][2:] for line in body.splitlines()
             if line.startswith("| ") and not line.startswith("| config")]
    assert sorted(names) == sorted({r["config"] for r in rows if "-navigate-" in r["config"]})
    first_map = next(i for i, n in enumerate(names) if "-office-" in n or "-warehouse-" in n)
    assert all("-office-" in n or "-warehouse-" in n for n in names[first_map:])
    one = [r for r in rows if r["config"] == names[0]]
    seeds = " / ".join(f"{100 * float(r['agent_success']):.0f}"
                       for r in sorted(one, key=lambda r: int(float(r["seed"]))))
    assert f"| {names[0]} | " in body and f" | {seeds}% | " in body
    page = tmp_path / "p.md"
    page.write_text(f"# p\n{NAVIGATE_BEGIN}\nstale\n{NAVIGATE_END}\nrest\n")
    assert main(["benchmark", "--table", "--csv", str(root / DEFAULT_CSV), "--navigate-page",
                 str(page)]) == 0
    assert between(page.read_text(), NAVIGATE_BEGIN, NAVIGATE_END) == body
    assert page.read_text().endswith(f"{NAVIGATE_END}\nrest\n")
    plain = tmp_path / "x.md"
    plain.write_text("# x\n")
    assert _run_main(["benchmark", "configs/nowhere.yml", "--navigate-page", str(plain)]) == 2
    err = capsys.readouterr().err
    assert "--navigate-page" in err and "x.md: not a file with the markers" in err

