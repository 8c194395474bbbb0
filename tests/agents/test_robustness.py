"""``wheelgym robustness``: the batched evaluation, the sweep's CSV (resumable) and figures."""

from __future__ import annotations

import csv

import gymnasium as gym
import pytest

import wheelgym  # noqa: F401  (registers the ids)
from wheelgym.agents import robustness as rob
from wheelgym.agents.evaluate import nominal_success, run_episode, run_episodes_vector
from wheelgym.cli import main
from wheelgym.envs.baseline import baseline

AGENT = "DiffDrive-goal-VehicleSpeedHeadingRate"


@pytest.mark.parametrize("robot,task,mode,pert", [
    ("DiffDrive", "goal", "VehicleSpeedHeadingRate", "medium"),
    ("ThreeWheel", "track", "torque", {"scales": {"mass": (1.3, 1.3)}, "action_delay": 1}),
])
def test_vector_evaluation_equals_single_episodes(robot, task, mode, pert):
    """run_episodes_vector scores sub-env i as run_episode scores the single env with seed i
    (the baseline is batched bit for bit)."""
    seeds = [7, 8, 9]
    kw = dict(task=task, action_mode=mode, perturbation=pert, max_episode_steps=60)
    venv = gym.make_vec(f"wheelgym/{robot}-v0", num_envs=3,
                        vectorization_mode="vector_entry_point", **kw)
    batch = run_episodes_vector(venv, baseline(venv), seeds)
    venv.close()
    env = gym.make(f"wheelgym/{robot}-v0", **kw)
    for s, b in zip(seeds, batch, strict=True):
        e = run_episode(env, baseline(env), s, record=False)
        for attr in ("ret", "length", "success", "rms_tracking_error", "energy", "peak_torque",
                     "mean_internal_force", "saturation", "numerical_failure", "terminated"):
            assert getattr(e, attr) == getattr(b, attr), (s, attr)
    env.close()


def test_sweep_resumes_and_plots(tmp_path):
    kw = dict(out=tmp_path, episodes=2, axes=["action_delay", "mass"],
              policies=("agent", "baseline-nom"))
    loaded = rob.load_target(AGENT)
    r1 = rob.sweep(AGENT, loaded=loaded, **kw)
    # DiffDrive has no mass group: only the delay axis, 5 levels x 2 policies
    assert r1["ran"] == 10 and r1["skipped"] == 0
    rows = rob.read_rows(r1["csv"])
    assert [r["level"] for r in rows[::2]] == ["0", "1", "2", "3", "5"]
    assert all(r["status"] == "ok" for r in rows)
    r2 = rob.sweep(AGENT, loaded=loaded, **kw)
    assert r2["ran"] == 0 and r2["skipped"] == 10
    # drop the last row: only it runs again, with the same numbers
    lines = r1["csv"].read_text().splitlines(keepends=True)
    r1["csv"].write_text("".join(lines[:-1]))
    r3 = rob.sweep(AGENT, loaded=loaded, **kw)
    assert r3["ran"] == 1
    again = rob.read_rows(r1["csv"])
    assert len(again) == 10
    keep = ("success", "energy", "return", "length")
    assert [again[-1][k] for k in keep] == [rows[-1][k] for k in keep]
    files = rob.plot(r1["csv"])
    assert {p.name for p in files} == {f"{AGENT}-success.png"}  # goal, kinematic: no rms/energy
    assert "action_delay" in rob.summary_table(r1["csv"])


def test_a_changed_agent_s_rows_are_stale(tmp_path, capsys):
    """The agent's rows carry its model.zip's digest: rows of another model are refused until
    --drop-stale, which sweeps the agent again and keeps the baseline's rows; a CSV from before
    the column gets it (empty) and resumes."""
    kw = dict(out=tmp_path, episodes=2, axes=["action_delay"],
              policies=("agent", "baseline-nom"))
    loaded = rob.load_target(AGENT)
    r1 = rob.sweep(AGENT, loaded=loaded, **kw)
    rows = rob.read_rows(r1["csv"])
    sha = rob.agent_digest(AGENT)
    assert len(sha) == 12 and {r["agent_sha"] for r in rows if r["policy"] == "agent"} == {sha}
    assert {r["agent_sha"] for r in rows if r["policy"] != "agent"} == {""}
    env = rob.env_digest(loaded[2])
    assert {r["env_sha"] for r in rows} == {env}
    # rows written by another model.zip (a retrained or re-exported agent)
    text = r1["csv"].read_text()
    r1["csv"].write_text(text.replace(f",{sha},{env}\n", f",0123456789ab,{env}\n"))
    with pytest.raises(ValueError, match="5 agent row.*--drop-stale"):
        rob.sweep(AGENT, loaded=loaded, **kw)
    # a sweep of the baseline alone leaves the agent's rows as they are
    assert rob.sweep(AGENT, loaded=loaded, **{**kw, "policies": ("baseline-nom",)})["ran"] == 0
    capsys.readouterr()
    assert main(["robustness", AGENT, "--episodes", "2", "--axes", "action_delay", "--policies",
                 "agent,baseline-nom", "--out", str(tmp_path)]) == 2
    assert "--drop-stale" in capsys.readouterr().err
    r2 = rob.sweep(AGENT, loaded=loaded, drop_stale=True, **kw)
    assert r2["ran"] == 5 and r2["skipped"] == 5  # the agent again, not the baseline
    again = rob.read_rows(r1["csv"])
    assert len(again) == 10 and {r["agent_sha"] for r in again if r["policy"] == "agent"} == {sha}
    # a CSV from before the digests: the columns are added, empty for the old rows, nothing
    # reruns
    lines = r1["csv"].read_text().splitlines()
    r1["csv"].write_text("".join(line.rsplit(",", 2)[0] + "\n" for line in lines))
    r3 = rob.sweep(AGENT, loaded=loaded, **kw)
    assert r3["ran"] == 0 and r3["skipped"] == 10
    assert r1["csv"].read_text().splitlines()[0].endswith(",status,agent_sha,env_sha")
    assert {(r["agent_sha"], r["env_sha"]) for r in rob.read_rows(r1["csv"])} == {("", "")}


def test_rows_of_another_env_are_stale(tmp_path):
    """Every row records a digest of the env its policy was scored on: after the config's
    env_kwargs change (here a reward weight, which changes the return and nothing else), the
    baseline's rows are stale as well as the agent's."""
    import dataclasses

    kw = dict(out=tmp_path, episodes=2, axes=["action_delay"], policies=("baseline-nom",))
    name, agent, config = rob.load_target(AGENT)
    r1 = rob.sweep(AGENT, loaded=(name, agent, config), **kw)
    changed = dataclasses.replace(config, env_kwargs={**config.env_kwargs,
                                                      "reward_weights": {"progress": 2.0}})
    assert rob.env_digest(changed) != rob.env_digest(config)
    with pytest.raises(ValueError, match="5 row.*another env.*env_sha.*--drop-stale"):
        rob.sweep(AGENT, loaded=(name, agent, changed), **kw)
    r2 = rob.sweep(AGENT, loaded=(name, agent, changed), drop_stale=True, **kw)
    assert r2["ran"] == 5 and r2["skipped"] == 0
    old, new = ({r["level"]: r for r in x["rows"]} for x in (r1, r2))
    assert {r["env_sha"] for r in new.values()} == {rob.env_digest(changed)}
    assert all(old[lv]["success"] == new[lv]["success"] for lv in old)
    assert any(old[lv]["return"] != new[lv]["return"] for lv in old)


def test_cli_robustness(tmp_path, capsys):
    rc = main(["robustness", AGENT, "--episodes", "2", "--axes", "combined", "--policies",
               "baseline-nom,baseline-true,random", "--out", str(tmp_path)])
    assert rc == 0
    with (tmp_path / "robustness.csv").open() as f:
        rows = list(csv.DictReader(f))
    assert b"\r" not in (tmp_path / "robustness.csv").read_bytes()  # "\n" ends, as committed
    assert {r["level"] for r in rows} == {"none", "easy", "medium", "hard"}
    assert {r["policy"] for r in rows} == {"baseline-nom", "baseline-true", "random"}
    # the nominal plant: the nominal and the true model agree exactly
    none = {r["policy"]: r for r in rows if r["level"] == "none"}
    assert none["baseline-nom"]["return"] == none["baseline-true"]["return"]
    (tmp_path / f"{AGENT}-success.png").unlink()
    assert main(["robustness", AGENT, "--plots-only", "--out", str(tmp_path)]) == 0
    assert (tmp_path / f"{AGENT}-success.png").is_file()
    assert main(["robustness", AGENT, "--axes", "weight", "--out", str(tmp_path)]) == 2
    assert "valid axes" in capsys.readouterr().err


def test_axes_per_robot():
    _, _, cfg = rob.load_target(AGENT)
    names = [a.name for a in rob.applicable_axes(cfg)]
    assert "wheel_radius" in names and "mass" not in names and "combined" in names
    for a in rob.AXES.values():  # each axis holds its nominal level
        nominal = {"combined": "none", "medium_without": "nothing"}.get(a.name)
        if nominal is None:
            nominal = 0.0 if a.unit in ("steps", "s", "m") or a.name.startswith(
                ("obs", "action")) else 1.0
        assert nominal in a.levels, a.name


def test_medium_without_removes_one_component():
    """Each level of the axis medium_without is medium with exactly the fields of one
    component changed, to values that change nothing; "nothing" is medium."""
    import dataclasses

    from wheelgym.envs.perturbation import FAULT_FIELDS, LEVELS

    med = LEVELS["medium"]
    fields = {
        "parameters": {"scales"}, "action_delay": {"action_delay"},
        "actuator_lag": {"actuator_lag"}, "obs_noise": {"obs_noise"},
        "action_noise": {"action_noise"}, "signal_faults": set(FAULT_FIELDS)}
    assert rob.medium_without("nothing") == med
    assert set(rob.MEDIUM_COMPONENTS) == {"nothing", *fields}
    for comp, changed in fields.items():
        p = rob.medium_without(comp)
        diff = {f.name for f in dataclasses.fields(p)
                if getattr(p, f.name) != getattr(med, f.name)}
        assert diff == changed, comp
    par = rob.medium_without("parameters").scales
    assert set(par) == set(med.scales)
    assert all(v == ((0.0, 0.0) if g == "x_icr" else (1.0, 1.0)) for g, v in par.items())
    assert rob.medium_without("action_delay").action_delay == (0, 0)
    assert rob.medium_without("actuator_lag").actuator_lag == 0.0
    assert rob.medium_without("obs_noise").obs_noise == rob.VANISHING < 1e-200
    faults = rob.medium_without("signal_faults")
    assert all(getattr(faults, f) == (rob.VANISHING, getattr(med, f)[1]) for f in FAULT_FIELDS)
    with pytest.raises(ValueError, match="valid components"):
        rob.medium_without("friction")


def test_medium_without_pairs_each_episode_with_medium(tmp_path):
    """The axis keeps the removed component's random draws: its level "nothing" gives the
    combined medium's rows, a baseline (which reads the state) scores exactly as at medium
    without an observation component, and without the parameters the nominal-model baseline
    is the true-model one. (With the draws gone, the action faults would strike other steps.)"""
    r = rob.sweep(AGENT, out=tmp_path, episodes=4, axes=["combined", "medium_without"],
                  policies=("baseline-nom", "baseline-true"), loaded=rob.load_target(AGENT))
    rows = {(x["axis"], x["level"], x["policy"]): x for x in r["rows"]}
    cols = ("success", "energy", "return", "length", "saturation")

    def same(a, b):
        return all(rows[a][c] == rows[b][c] for c in cols)

    for pol in ("baseline-nom", "baseline-true"):
        assert same(("medium_without", "nothing", pol), ("combined", "medium", pol))
        assert same(("medium_without", "obs_noise", pol), ("combined", "medium", pol))
        assert not same(("medium_without", "action_delay", pol), ("combined", "medium", pol))
    assert same(("medium_without", "parameters", "baseline-nom"),
                ("medium_without", "parameters", "baseline-true"))
    assert not same(("combined", "medium", "baseline-nom"), ("combined", "medium", "baseline-true"))
    # the figures draw the unordered axis; the first-failure table leaves it out
    assert {p.name for p in rob.plot(r["csv"])} == {f"{AGENT}-success.png"}
    assert "medium_without" not in rob.summary_table(r["csv"])


def test_page_shows_what_each_component_of_medium_costs(tmp_path):
    from wheelgym.agents.robustness_page import render_page

    values = {"nothing": 78, "parameters": 92, "action_delay": 100, "actuator_lag": 92,
              "obs_noise": 78, "action_noise": 90, "signal_faults": 86}
    path = tmp_path / "r.csv"
    with path.open("w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=rob.COLUMNS, restval="")
        w.writeheader()
        w.writerows({"target": "A-goal-torque", "config": "A-goal-torque",
                     "axis": "medium_without", "level": comp, "unit": "component removed",
                     "policy": pol, "episodes": "50", "seed": "100000",
                     "success": str(s - (10 if pol == "agent" else 0)), "status": "ok"}
                    for pol in ("agent", "baseline-nom") for comp, s in values.items())
    lines = render_page(path, tmp_path / "page.md").splitlines()
    at = lines.index("## What `medium` costs, component by component")
    row = next(ln for ln in lines[at:] if ln.startswith("| A-goal-torque | "))
    assert row.split(" | ")[1:] == ["68%", "82%", "**90%**", "82%", "68%", "80%", "76% |"]
    row = next(ln for ln in lines if ln.startswith("| baseline-nom | 78%"))
    assert row.split(" | ")[3] == "**100%**"


def _comb_rows(target: str, pol: str, values: dict[str, tuple[float, float | None]]):
    return [{"target": target, "config": target, "axis": "combined", "level": lv,
             "policy": pol, "episodes": "50", "seed": "100000", "success": str(s),
             "rms": "" if rms is None else str(rms), "status": "ok"}
            for lv, (s, rms) in values.items()]


def test_falls_at_reads_the_first_combined_level_that_fails():
    from wheelgym.agents.robustness_page import falls_at

    goal = _comb_rows("X-goal-torque", "agent", {"none": (100, None), "easy": (96, None),
                                                "medium": (78, None), "hard": (20, None)})
    assert falls_at(goal, "agent", track=False) == "medium (78%)"
    assert falls_at(goal, "baseline-nom", track=False) == "n/a"
    held = _comb_rows("X-goal-torque", "agent", {lv: (92, None) for lv in
                                                 ("none", "easy", "medium", "hard")})
    assert falls_at(held, "agent", track=False) == "beyond hard"
    # track: against the policy's own nominal RMS (4 mm): 7.9 mm holds, 8.1 mm does not
    track = _comb_rows("X-track-torque", "agent", {"none": (100, 0.004), "easy": (100, 0.0079),
                                                  "medium": (100, 0.0081)})
    assert falls_at(track, "agent", track=True) == "medium (8 mm)"


def test_results_page_is_the_committed_csv_written_out(tmp_path):
    """docs/topics/robustness-results.md is what `wheelgym robustness --page` writes from the
    committed CSV (run the command after a sweep), and the CLI writes it without a TARGET."""
    from pathlib import Path

    from wheelgym.agents.robustness_page import render_page

    root = Path(__file__).resolve().parents[2]
    page = root / "docs" / "topics" / "robustness-results.md"
    csv_path = root / "benchmarks" / "results" / "robustness" / "robustness.csv"
    assert page.read_text() == render_page(csv_path, page)
    out = tmp_path / "page.md"
    assert main(["robustness", "--page", str(out), "--csv", str(csv_path)]) == 0
    assert "## Summary" in out.read_text() and "ThreeWheel-goal-torque" in out.read_text()
    assert main(["robustness"]) == 2  # neither a TARGET nor --page


def test_robust_table_shows_the_robust_agent_on_the_nominal_robot(tmp_path):
    from wheelgym.agents.robustness_page import render_page

    def rows(target, none, medium, rms=("", "")):
        return [{"target": target, "config": target, "axis": "combined", "level": lvl,
                 "unit": "level", "policy": pol, "episodes": "50", "seed": "100000",
                 "success": str(succ), "rms": r, "status": "ok"}
                for pol in ("agent", "baseline-nom", "baseline-true")
                for lvl, succ, r in (("none", none, rms[0]), ("medium", medium, rms[1]))]

    path = tmp_path / "r.csv"
    with path.open("w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=rob.COLUMNS, restval="")
        w.writeheader()
        w.writerows(rows("A-goal-robust", 86, 100) + rows("A-goal", 100, 98)
                    + rows("B-track-robust", 20, 90, ("0.0696", "0.0248")))
    page = render_page(path, tmp_path / "page.md")
    lines = page.splitlines()
    line = next(ln for ln in lines if ln.startswith("| A-goal-robust | success at medium"))
    assert line.split(" | ")[2:5] == ["100% [93, 100]", "86%", "98% [90, 100]"]
    line = next(ln for ln in lines if ln.startswith("| B-track-robust | RMS medium"))
    assert line.split(" | ")[2:4] == ["0.4x (25 mm)", "20% (70 mm)"]
    # the ratio is met, but the agent fails the robot it was not perturbed on
    assert line.endswith("| met; **fails the nominal robot** (20%) |")
    line = next(ln for ln in lines if ln.startswith("| A-goal-robust | success at medium"))
    assert line.endswith("| met; **fails the nominal robot** (86%) |")


def test_wilson_interval_solves_its_defining_quadratic():
    """The endpoints are the two rates p with (k/n - p)^2 = z^2 p (1 - p) / n; 43 of 50 gives
    [0.7381, 0.9305] (scipy.stats.binomtest(43, 50).proportion_ci(method="wilson"))."""
    from wheelgym.agents.robustness_page import wilson_interval

    lo, hi = wilson_interval(43, 50)
    assert (lo, hi) == pytest.approx((0.7381380628941446, 0.9304916657298371), abs=1e-12)
    for k, n in ((43, 50), (181, 200), (1, 7)):
        for p in wilson_interval(k, n):
            assert (k / n - p) ** 2 == pytest.approx(1.959963984540054 ** 2 * p * (1 - p) / n,
                                                rel=1e-9)
    assert wilson_interval(50, 50)[1] == 1.0 and wilson_interval(0, 50)[0] == 0.0
    with pytest.raises(ValueError, match="n must be >= 1"):
        wilson_interval(0, 0)


def test_nominal_success_scores_the_agent_without_its_perturbation():
    # SkidSteer track torque robust: trained and scored at `medium`, it leads its commands by
    # the level's two-step delay and fails most episodes on the nominal robot (robustness.md)
    name, episodes = "SkidSteer-track-torque-robust", 6
    agent, config = rob.load_target(name)[1:]
    assert config.env_kwargs["perturbation"] == "medium"
    seeds = [100_000 + i for i in range(episodes)]
    kw = {k: v for k, v in config.env_kwargs.items() if k != "perturbation"}
    env = gym.make(config.env_id, **kw)
    nominal = [run_episode(env, agent, s, record=False).success for s in seeds]
    env.close()
    env = gym.make(config.env_id, **config.env_kwargs)
    medium = [run_episode(env, agent, s, record=False).success for s in seeds]
    env.close()
    assert sum(nominal) != sum(medium)  # the case tells the two apart
    assert nominal_success(agent, config, episodes=episodes) == sum(nominal) / episodes
    with pytest.raises(ValueError, match="episodes"):
        nominal_success(agent, config, episodes=0)
