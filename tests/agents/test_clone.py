"""``clone_baseline`` (config key): the policy's Gaussian mean fitted to the analytic baseline."""

from __future__ import annotations

import json

import numpy as np
import pytest
import yaml

pytest.importorskip("stable_baselines3")

import torch as th  # noqa: E402

from tests.agents.test_agents_train import (  # noqa: E402
    tiny_config,
    tiny_config_flat,
    tiny_sac_config,
    train_and_interrupt,
)
from wheelgym.agents.benchmark import config_digest  # noqa: E402
from wheelgym.agents.clone import (  # noqa: E402
    clone_baseline,
    demonstrate,
    fit_mean,
    force_error,
    internal_force_rows,
    mean_error,
    returns_to_go,  # noqa: E402
)
from wheelgym.agents.common import build_model, make_train_env, wrap_normalize  # noqa: E402
from wheelgym.agents.config import parse_config  # noqa: E402
from wheelgym.agents.pipeline import migrate  # noqa: E402
from wheelgym.agents.policies import load_agent  # noqa: E402
from wheelgym.agents.train import latest_model, resume, train  # noqa: E402

NAV = {"task": "navigate", "action_mode": "VehicleSpeedHeadingRate"}


def _nav_config(**wg):
    data = tiny_config_flat(**wg)
    block = data.pop("wheelgym/ThreeWheel-v0")
    block["policy_kwargs"] = {"net_arch": [64, 64]}
    data["wheelgym/DiffDrive-v0"] = block
    data["wheelgym"]["env_kwargs"] = dict(NAV)
    data["wheelgym"]["vec_env"] = "native"
    return migrate(data)


def test_the_clone_stage_is_checked_and_written_only_when_set():
    plain = parse_config(tiny_config())
    assert plain.pipeline == () and "pipeline" not in plain.to_dict()["wheelgym"]
    cfg = parse_config(tiny_config(clone_baseline=4096))
    first = cfg.pipeline[0]
    assert (first.kind, first.teacher, first.steps) == ("imitate", "baseline", 4096)
    assert cfg.to_dict()["wheelgym"]["pipeline"][0] == {"stage": "imitate",
                                                        "teacher": "baseline", "steps": 4096}
    assert parse_config(cfg.to_dict()) == cfg
    assert config_digest(cfg) != config_digest(plain)
    assert cfg.recipe == "clone+rl" and plain.recipe == "scratch"
    for key, good in (("clone_rounds", 3), ("clone_epochs", 4), ("clone_internal_force", 10)):
        other = parse_config(tiny_config(clone_baseline=4096, **{key: good}))
        assert parse_config(other.to_dict()) == other
        assert config_digest(other) != config_digest(cfg)
    assert cfg.pipeline[0].resolved() == {"rounds": 1, "epochs": 10, "lr": 1e-3,
                                          "internal_force": 0.0}
    stage = {"stage": "imitate", "teacher": "baseline", "steps": 4096}
    for key, bad in (("steps", 0), ("steps", 1.5), ("steps", "100"), ("steps", True),
                     ("rounds", 0), ("rounds", 2.5), ("epochs", "3"), ("epochs", True),
                     ("internal_force", -1.0),
                     ("internal_force", "3"), ("lr", 0.0)):
        data = tiny_config()
        data["wheelgym"]["pipeline"] = [{**stage, key: bad}, {"stage": "rl"}]
        with pytest.raises(ValueError, match=rf"pipeline\[0\] \(imitate\): {key} "):
            parse_config(data)
    sac = tiny_sac_config()
    sac["wheelgym"]["pipeline"] = [stage, {"stage": "rl"}]
    with pytest.raises(ValueError, match=r"pipeline\[0\] \(imitate\) is for \['ppo', "
                                         r"'a2c'\].*'sac'"):
        parse_config(sac)


def test_the_fitted_mean_reproduces_the_baseline_on_states_it_did_not_see():
    cfg = parse_config(_nav_config()).replace(n_envs=16)
    th.manual_seed(0)
    venv = wrap_normalize(make_train_env(cfg), cfg)
    model = build_model(cfg, venv)
    log_std = model.policy.log_std.detach().clone()
    fit = clone_baseline(model, 16_384, seed=0)
    assert fit["steps"] == 16_384
    assert fit["mse_after"] < 0.1 * fit["mse_before"], fit
    assert fit["value_mse_after"] < 0.5 * fit["value_mse_before"], fit
    # held out: the baseline drives on from where the demonstration stopped (new episodes)
    venv.training = False  # the statistics as fitted
    obs, actions, returns = demonstrate(venv, 4096, gamma=0.5)[:3]
    assert np.all(np.abs(actions) <= 1.0) and obs.shape[0] == actions.shape[0] == 4096
    assert returns.shape == (4096,) and np.all(np.isfinite(returns))
    held_out = mean_error(model, obs, actions)
    assert held_out < 0.25 * fit["mse_before"], (held_out, fit)
    assert th.equal(model.policy.log_std.detach(), log_std)  # the log std is not fitted
    venv.close()


def test_dagger_rounds_label_the_clones_own_states():
    cfg = parse_config(_nav_config()).replace(n_envs=16)
    th.manual_seed(0)
    venv = wrap_normalize(make_train_env(cfg), cfg)
    model = build_model(cfg, venv)
    fit = clone_baseline(model, 16_384, seed=0, rounds=2)
    assert fit["steps"] == 16_384
    first, second = fit["rounds"]
    assert first["driver"] == "baseline" and second["driver"] == "clone"
    assert first["episodes"] > 0 and 0.5 <= first["success"] <= 1.0, first
    # refitted on the states the clone reached, it errs less there than before the refit
    venv.training = False
    own = demonstrate(venv, 4096, actor=lambda o: model.predict(o, deterministic=True)[0])
    assert mean_error(model, own.obs, own.actions) < 0.8 * second["mse_on_its_states"], fit
    # the actor drives, the baseline only labels: a robot held still gives the same
    # observation row after row, labelled with the baseline's (moving) actions
    still = demonstrate(venv, 16 * 5, actor=lambda o: np.zeros((len(o), 2), np.float32))
    rows = still.obs.reshape(5, 16, -1)
    np.testing.assert_allclose(rows[1:], rows[:1].repeat(4, axis=0), atol=1e-6)
    assert np.all(np.abs(still.actions).max(axis=1) > 0.05)  # it asks to move or turn
    venv.close()


def test_a_cloned_run_records_the_fit_and_trains_on(tmp_path):
    cfg = parse_config(_nav_config(clone_baseline=2048))
    res = train(cfg, runs_root=tmp_path, progress=False)
    assert res.status == "finished" and res.timesteps == 1024  # demonstration not counted
    info = json.loads((res.run_dir / "run.json").read_text())
    assert info["stages"][0]["steps"] == 2048
    assert info["stages"][0]["mse_after"] < info["stages"][0]["mse_before"]
    assert info["wall_s"] >= info["stages"][0]["wall_s"]
    written = yaml.safe_load((res.run_dir / "config.yml").read_text())
    assert written["wheelgym"]["pipeline"][0]["steps"] == 2048
    assert info["stages"][0]["epochs"] == 10  # clone.EPOCHS
    # clone_epochs: fewer passes over the same rows (same seed) leave a larger error
    one = train(parse_config(_nav_config(clone_baseline=2048, clone_epochs=1)),
                runs_root=tmp_path / "one", progress=False)
    fit_one = json.loads((one.run_dir / "run.json").read_text())["stages"][0]
    assert fit_one["epochs"] == 1 and fit_one["mse_before"] == info["stages"][0]["mse_before"]
    assert fit_one["mse_after"] > info["stages"][0]["mse_after"], (fit_one, info["stages"][0])


def test_returns_to_go_discount_to_each_rows_episode_end():
    r = np.array([[1.0, 2.0], [1.0, 2.0], [1.0, 2.0]])
    done = np.array([[False, True], [True, False], [False, False]])
    g = returns_to_go(r, done, 0.5)
    # row 0 ends at t = 1, then a new episode (cut at t = 2); row 1 ends at t = 0
    np.testing.assert_allclose(g[:, 0], [1.5, 1.0, 1.0])
    np.testing.assert_allclose(g[:, 1], [2.0, 3.0, 2.0])


def test_ctrl_c_during_the_clone_keeps_the_model_and_resume_clones_again(tmp_path):
    data = _nav_config(clone_baseline=50_000_000, eval_freq=0, checkpoint_freq=0)
    cfg_path = tmp_path / "c.yml"
    cfg_path.write_text(yaml.safe_dump(data))
    run = tmp_path / "run"
    train_and_interrupt(cfg_path, run, "cloning")
    info = json.loads((run / "run.json").read_text())
    assert info["status"] == "interrupted" and info["timesteps"] == 0, info
    clone = info["stages"][0]
    assert clone["interrupted"] and 0 < clone["steps"] < 50_000_000, clone
    model_path, stats = latest_model(run)
    assert load_agent(model_path, "ppo", stats).obs_norm is not None
    # resume clones again (a short demonstration now) and then trains
    written = yaml.safe_load((run / "config.yml").read_text())
    written["wheelgym"]["pipeline"][0]["steps"] = 2048
    (run / "config.yml").write_text(yaml.safe_dump(written))
    res = resume(run, progress=False)
    assert res.status == "finished" and res.timesteps == 1024
    info = json.loads((run / "run.json").read_text())
    assert info["stages"][0]["steps"] == 2048 and "interrupted" not in info["stages"][0], info
    assert info["stages"][0]["mse_after"] < info["stages"][0]["mse_before"]


TORQUE_NAV = {"task": "navigate", "action_mode": "torque"}


def _torque_config(**wg):
    data = tiny_config_flat(**wg)
    data["wheelgym"]["env_kwargs"] = dict(TORQUE_NAV)
    data["wheelgym"]["vec_env"] = "native"
    data["wheelgym/ThreeWheel-v0"]["policy_kwargs"] = {"net_arch": [64, 64]}
    return migrate(data)


def test_internal_force_rows_measure_the_null_space_part_of_an_action():
    """``|W a|`` is the internal force ``|P tau| / |tau_max|`` of the torque ``tau = a tau_max``
    (TW-6): zero for torques ``J u`` that move the robot, ``|c| / |tau_max|`` for ``N c``."""
    from wheelgym.control.distribution import internal_force, null_space_basis
    from wheelgym.envs.baseline import baseline

    cfg = parse_config(_torque_config()).replace(n_envs=4)
    venv = make_train_env(cfg)
    venv.reset()
    core = baseline(venv).core
    rng = np.random.default_rng(0)
    core.X[:, 6:9] = rng.uniform(-np.pi, np.pi, (4, 3))  # steering angles away from 0
    W = internal_force_rows(core).astype(np.float64)
    assert W.shape == (4, 3, 6)
    J = core.model.jacobian(core.X[:, 6:9])
    scale = float(np.linalg.norm(core.base_params.tau_max))
    hi = core.HI
    moving = np.einsum("nij,nj->ni", J, rng.normal(size=(4, 3)))  # J u: range of J
    np.testing.assert_allclose(np.einsum("nkm,nm->nk", W, moving / hi), 0.0, atol=1e-6)
    N = null_space_basis(J)
    c = rng.normal(size=(4, 3))
    inner = np.einsum("nmk,nk->nm", N, c)  # internal: moves nothing (J^T tau = 0)
    np.testing.assert_allclose(np.einsum("nij,ni->nj", J, inner), 0.0, atol=1e-12)
    np.testing.assert_allclose(np.linalg.norm(np.einsum("nkm,nm->nk", W, inner / hi), axis=1),
                               np.linalg.norm(c, axis=1) / scale, rtol=1e-5)
    a = rng.uniform(-1, 1, (4, 6))  # any action: the projector's formula
    np.testing.assert_allclose(np.linalg.norm(np.einsum("nkm,nm->nk", W, a), axis=1),
                               np.linalg.norm(internal_force(J, a * hi), axis=1) / scale,
                               rtol=1e-5)
    venv.close()
    nav = make_train_env(parse_config(_nav_config()))
    nav.reset()
    with pytest.raises(ValueError, match="clone_internal_force: needs a robot with an "
                                         "internal force in action mode 'torque'"):
        internal_force_rows(baseline(nav).core)
    nav.close()


def test_weighting_the_internal_force_of_the_error_lowers_the_clones_internal_force():
    cfg = parse_config(_torque_config()).replace(n_envs=16)
    venv = wrap_normalize(make_train_env(cfg), cfg)
    demo = demonstrate(venv, 16_384, internal_force=True)
    held = demonstrate(venv, 4096, internal_force=True)
    assert demo.force_rows.shape == (16_384, 3, 6) and demo.force_rows.dtype == np.float32
    # the baseline distributes its load with almost no internal force
    assert np.mean(np.linalg.norm(np.einsum("nkm,nm->nk", held.force_rows, held.actions),
                                  axis=1)) < 0.01
    errs = {}
    for w in (0.0, 30.0):
        th.manual_seed(0)
        model = build_model(cfg, venv)
        fit_mean(model, demo.obs, demo.actions, epochs=5, seed=0,
                 force_rows=demo.force_rows, force_weight=w)
        errs[w] = (mean_error(model, held.obs, held.actions),
                   force_error(model, held.obs, held.actions, held.force_rows))
    # held-out rows: the weighted fit's error has less internal force, the motion part alike
    assert errs[30.0][1] < 0.7 * errs[0.0][1], errs
    assert errs[30.0][0] < 1.5 * errs[0.0][0], errs
    venv.close()


def test_a_run_with_clone_internal_force_records_the_force_error(tmp_path):
    cfg = parse_config(_torque_config(clone_baseline=2048, clone_internal_force=10.0))
    res = train(cfg, runs_root=tmp_path, progress=False)
    fit = json.loads((res.run_dir / "run.json").read_text())["stages"][0]
    assert fit["internal_force_weight"] == 10.0
    # an untrained mean near 0 errs by the baseline's action, which has almost no internal
    # force; the figures are the held measure of the fit (the weighted test above)
    assert 0.0 <= fit["force_error_before"] < 0.05 and 0.0 <= fit["force_error_after"] < 0.05
    assert fit["mse_after"] < fit["mse_before"], fit


def _planner_config(steps: int = 2048, rounds: int = 2):
    data = _nav_config()
    data["wheelgym/DiffDrive-v1"] = data.pop("wheelgym/DiffDrive-v0")
    data["wheelgym"]["env_kwargs"] = {**NAV, "arena": "office"}
    data["wheelgym"]["pipeline"] = [
        {"stage": "imitate", "teacher": "planner", "steps": steps, "rounds": rounds},
        {"stage": "rl"}]
    return parse_config(data)


def test_the_planner_teacher_labels_with_the_planning_baseline():
    """``teacher: planner`` demonstrates with ``wheelgym.baseline(env, planner="auto")``: on the
    office map it reaches goals the reactive baseline does not (docs/topics/planning.md: 100%
    against 27% for DiffDrive), and its labels differ from the reactive ones on the same states."""
    cfg = _planner_config().replace(n_envs=8)
    assert cfg.recipe == "plan-clone+rl"
    venv = wrap_normalize(make_train_env(cfg, seed=0), cfg)
    venv.training = False
    plan = demonstrate(venv, 8 * 600, planner="auto")
    venv.reset()
    react = demonstrate(venv, 8 * 600)
    assert plan.episodes >= 8 and plan.successes / plan.episodes >= 0.9, plan.episodes
    assert react.successes / max(react.episodes, 1) < plan.successes / plan.episodes
    # the same states (the robot held still), labelled by each teacher
    still = lambda o: np.zeros((len(o), 2), np.float32)  # noqa: E731
    venv.reset()
    a_plan = demonstrate(venv, 8 * 3, actor=still, planner="auto").actions
    venv.reset()
    a_react = demonstrate(venv, 8 * 3, actor=still).actions
    assert np.abs(a_plan - a_react).max() > 0.05
    venv.close()


def test_a_planner_cloned_run_records_the_teacher_and_the_fit(tmp_path):
    res = train(_planner_config(), runs_root=tmp_path, progress=False)
    assert res.status == "finished" and res.timesteps == 1024
    stage = json.loads((res.run_dir / "run.json").read_text())["stages"][0]
    assert stage["teacher"] == "planner" and stage["status"] == "finished"
    assert [r["driver"] for r in stage["rounds"]] == ["planner", "clone"]
    assert stage["mse_after"] < stage["mse_before"]


def _true_teacher_config(**env_kwargs):
    data = tiny_config_flat()
    data["wheelgym"]["env_kwargs"].update(env_kwargs)
    data["wheelgym"]["vec_env"] = "native"
    data["wheelgym"]["pipeline"] = [
        {"stage": "imitate", "teacher": "baseline_true", "steps": 512}, {"stage": "rl"}]
    return parse_config(data)


@pytest.mark.parametrize("perturbed", [False, True])
def test_the_true_model_teacher_labels_with_each_rows_true_parameters(perturbed):
    """``teacher: baseline_true`` labels with ``wheelgym.baseline(env, model="true")``: in the
    torque mode on the nominal plant the same actions as the nominal-model baseline, on a
    perturbed one (the ``medium`` level: mass, friction, torque limits, ...) different ones."""
    cfg = _true_teacher_config(action_mode="torque",
                               **({"perturbation": "medium"} if perturbed else {}))
    assert cfg.recipe == "clone-true+rl"
    venv = wrap_normalize(make_train_env(cfg, seed=0), cfg)
    venv.training = False
    labels = {}
    for kind in ("nominal", "true"):
        venv.seed(3)
        venv.reset()
        labels[kind] = demonstrate(venv, 2 * 40, model_kind=kind).actions
    differ = np.abs(labels["true"] - labels["nominal"]).max()
    assert (differ > 1e-3) if perturbed else (differ == 0.0)
    venv.close()


def test_the_teachers_kwargs_set_the_baseline_that_labels():
    """An ``imitate`` stage's ``teacher_kwargs`` reach ``wheelgym.baseline``: the deadbeat gain
    given explicitly labels as the default teacher does, a softer twist loop otherwise."""
    cfg = _true_teacher_config(action_mode="torque")
    venv = wrap_normalize(make_train_env(cfg, seed=0), cfg)
    venv.training = False
    from wheelgym.envs.baseline import baseline

    dt = baseline(venv).core.dt
    labels = {}
    for name, kw in (("default", None), ("deadbeat", {"twist_gains": {"k_v": 1.0 / dt}}),
                     ("soft", {"twist_gains": {"k_v": 0.5 / dt}})):
        venv.seed(3)
        venv.reset()
        labels[name] = demonstrate(venv, 2 * 40, teacher_kwargs=kw).actions
    assert np.array_equal(labels["default"], labels["deadbeat"])
    assert np.abs(labels["soft"] - labels["default"]).max() > 1e-3
    venv.close()
