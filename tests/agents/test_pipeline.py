"""The training pipeline (``wheelgym.agents.pipeline``): stage schemas, the refusal of the old
flat keys, the same weights bit for bit in the old and the new spelling, and the results
CSV's digests unchanged by the respelling."""

from __future__ import annotations

import hashlib
import json

import pytest

pytest.importorskip("stable_baselines3")

from tests.agents.test_agents_train import tiny_config, tiny_config_flat  # noqa: E402
from tests.agents.test_clone import _nav_config, _torque_config  # noqa: E402
from wheelgym.agents.config import configs_dir, load_config, parse_config  # noqa: E402
from wheelgym.agents.pipeline import (  # noqa: E402
    LEGACY_KEYS,
    STAGES,
    legacy_form,
    migrate,
    parse_pipeline,
)
from wheelgym.agents.store import DEFAULT_CSV, config_digest, read_rows  # noqa: E402
from wheelgym.agents.train import resume, train  # noqa: E402

SCHED = {"saturation": [[0, 0.05], [512, 0.1]]}

#: SHA-256 (16 hex digits) of the final policy's state dict of each recipe's seeded short run,
#: computed with main's code before the pipeline (commit 9be646b, old flat keys: e.g.
#: ``_nav_config(clone_baseline=512, clone_rounds=2, clone_epochs=2, mean_bound=1.5)`` parsed
#: as it was), torch 2.13.0 CPU; twice each, the same bits. torch's CPU kernels give other bits
#: on another CPU, so there is one set per kind of machine it was computed on; the scratch
#: recipe (plain PPO, a path the pipeline only wraps) tells which set is this machine's.
FROZEN_SETS: tuple[dict[str, str], ...] = (
    {  # the development machine of 2026-12-03
        "scratch": "279775ee9e3f33fc",
        "reward_schedule_mean_bound": "e89e1681473ca3fa",
        "clone": "6416c18077dfb9d1",
        "clone_internal_force": "0601ac41683eca93",
        "distill": "9d34a114ccc753f3",
    },
    {  # AMD EPYC, torch CPU capability AVX512 (2026-12-05; 9be646b checked out beside main)
        "scratch": "6a1bbd1ce1d93dc3",
        "reward_schedule_mean_bound": "eaea720a5abe93b0",
        "clone": "6aeffc7ae52743e9",
        "clone_internal_force": "b5b5c5a58ffa064d",
        "distill": "3bc5f9fb2f774f9d",
    },
)
RECIPES = sorted(FROZEN_SETS[0])
FROZEN_TORCH = "2.13.0"


def _recipes() -> dict[str, dict]:
    """Each recipe in the new spelling (``migrate`` of the old keys, as the configs were)."""
    return {
        "scratch": tiny_config(),
        "reward_schedule_mean_bound": tiny_config(mean_bound=1.5, reward_schedule=SCHED),
        "clone": _nav_config(clone_baseline=512, clone_rounds=2, clone_epochs=2,
                             mean_bound=1.5),
        "clone_internal_force": _torque_config(clone_baseline=512, clone_rounds=2,
                                               clone_internal_force=10.0),
        "distill": _torque_config(distill_internal_force=512, distill_rounds=2,
                                  distill_weight=300.0),
    }


def _digest(run_dir) -> str:
    from stable_baselines3 import PPO

    model = PPO.load(str(run_dir / "model.zip"), device="cpu")
    h = hashlib.sha256()
    for k, v in model.policy.state_dict().items():
        h.update(k.encode())
        h.update(v.detach().cpu().numpy().tobytes())
    return h.hexdigest()[:16]


@pytest.fixture(scope="module")
def frozen(tmp_path_factory) -> dict[str, str]:
    """The frozen set of this machine's kind, told by the scratch recipe's digest (skip where
    torch is another version or no set was computed on this kind of CPU)."""
    import torch

    if torch.__version__.split("+")[0] != FROZEN_TORCH:
        pytest.skip(f"the frozen digests are of torch {FROZEN_TORCH}, not {torch.__version__}")
    res = train(parse_config(_recipes()["scratch"]), runs_root=tmp_path_factory.mktemp("cal"),
                progress=False)
    got = _digest(res.run_dir)
    for digests in FROZEN_SETS:
        if digests["scratch"] == got:
            return digests
    pytest.skip(f"no frozen digests of the old code for this CPU (torch capability "
                f"{torch.backends.cpu.get_cpu_capability()}; scratch gives {got}): run the "
                "recipes with commit 9be646b checked out and add a set")


@pytest.mark.parametrize("recipe", RECIPES)
def test_each_recipe_gives_the_old_spellings_weights_bit_for_bit(recipe, frozen, tmp_path):
    data = _recipes()[recipe]
    assert "pipeline" in data["wheelgym"] or recipe == "scratch"
    res = train(parse_config(data), runs_root=tmp_path, progress=False)
    assert res.status == "finished"
    assert _digest(res.run_dir) == frozen[recipe]
    info = json.loads((res.run_dir / "run.json").read_text())
    assert [r["status"] for r in info["stages"]] == ["finished"] * len(info["stages"])
    assert info["recipe"] == parse_config(data).recipe


def test_the_old_keys_are_refused_with_their_new_spelling():
    for key in LEGACY_KEYS:
        value = {"reward_schedule": SCHED, "mean_bound": 1.1}.get(key, 100)
        extra = {} if key in ("clone_baseline", "distill_internal_force", "mean_bound",
                              "reward_schedule") else (
            {"clone_baseline": 100} if key.startswith("clone") else
            {"distill_internal_force": 100})
        with pytest.raises(ValueError, match=rf"\['?.*{key}.*\] are no longer read"):
            parse_config(tiny_config_flat(**extra, **{key: value}))
    with pytest.raises(ValueError) as e:
        parse_config(tiny_config_flat(clone_baseline=512, clone_rounds=2, mean_bound=1.5))
    msg = str(e.value)
    assert ("pipeline: [{stage: imitate, teacher: baseline, steps: 512, rounds: 2}, "
            "{stage: rl}]") in msg and "policy_kwargs: mean_bound: 1.5" in msg
    # the spelling the message gives is the one migrate writes, and it loads
    assert parse_config(migrate(tiny_config_flat(clone_baseline=512, clone_rounds=2)))


def test_stage_errors_name_the_stage_the_key_and_the_valid_keys():
    def bad(pipeline):
        data = tiny_config()
        data["wheelgym"]["pipeline"] = pipeline
        return data

    cases = [
        ([], "pipeline must be a non-empty list"),
        ([{"stage": "rl"}, {"stage": "dance"}], r"pipeline\[1\]: stage must be one of "
                                                r"\['imitate', 'rl'\], got 'dance'"),
        ([{"stage": "rl", "steps": 5}], r"pipeline\[0\] \(rl\): unknown key 'steps'; valid "
                                        r"keys: \['stage', 'reward_schedule'\]"),
        ([{"stage": "imitate", "steps": 5}, {"stage": "rl"}],
         r"pipeline\[0\] \(imitate\): missing key\(s\) \['teacher'\]"),
        ([{"stage": "imitate", "teacher": "me", "steps": 5}, {"stage": "rl"}],
         r"pipeline\[0\] \(imitate\): teacher must be one of \['baseline', 'baseline_true', "
         r"'planner', 'self_without_internal_force'\]"),
        ([{"stage": "rl"}, {"stage": "rl"}], "exactly one 'rl' stage"),
        ([{"stage": "imitate", "teacher": "baseline", "steps": 5}], "exactly one 'rl' stage"),
        ([{"stage": "rl", "reward_schedule": {"saturation": [[5, 0.1], [1, 0.2]]}}],
         r"pipeline\[0\] \(rl\): reward_schedule saturation: steps must increase"),
        (["rl"], r"pipeline\[0\] must be a mapping"),
    ]
    for pipeline, match in cases:
        with pytest.raises(ValueError, match=match):
            parse_config(bad(pipeline))
    assert set(STAGES) == {"imitate", "rl"}


def test_the_legacy_form_is_the_old_file_form_and_keeps_the_digest():
    """``recipe_form`` of a respelled config is its old file form; a pipeline without such a
    form (a baseline stage after rl, or a key the flat keys lacked) digests its own form."""
    old = tiny_config_flat(clone_baseline=512, clone_rounds=2, mean_bound=1.5,
                           reward_schedule=SCHED, distill_internal_force=256)
    cfg = parse_config(migrate(old))
    form = cfg.recipe_form()
    assert form["wheelgym"]["clone_baseline"] == 512 and form["wheelgym"]["mean_bound"] == 1.5
    assert "mean_bound" not in form["wheelgym/ThreeWheel-v0"]["policy_kwargs"]
    assert "pipeline" not in form["wheelgym"]
    stages = cfg.pipeline
    assert legacy_form(tuple(reversed(stages))) is None  # baseline after rl: no flat form
    data = migrate(old)
    data["wheelgym"]["pipeline"][0]["lr"] = 1e-4  # no flat key for the clone's lr
    other = parse_config(data)
    assert "pipeline" in other.recipe_form()["wheelgym"]
    assert config_digest(other) != config_digest(cfg)
    assert parse_pipeline(data["wheelgym"]["pipeline"], "x", "ppo", ("ppo",))


def test_teacher_kwargs_are_checked_for_baseline_teachers_and_digested():
    """An ``imitate`` stage's ``teacher_kwargs`` (``wheelgym.baseline`` keywords) are checked
    at load (the stage, the key, the valid keys), refused for the policy as its own teacher,
    have no flat form and change the recipe's digest."""
    def cfg(teacher_kwargs, teacher="baseline"):
        data = tiny_config_flat(clone_baseline=512)
        data = migrate(data)
        data["wheelgym"]["pipeline"][0]["teacher"] = teacher
        if teacher_kwargs is not None:
            data["wheelgym"]["pipeline"][0]["teacher_kwargs"] = teacher_kwargs
        return parse_config(data)

    plain = cfg(None)
    tuned = cfg({"w_cap": 1.0, "twist_gains": {"k_v": 14, "k_i": 20.0}})
    assert tuned.pipeline[0].teacher_kwargs == {"w_cap": 1.0,
                                                "twist_gains": {"k_v": 14.0, "k_i": 20.0}}
    assert legacy_form(tuned.pipeline) is None
    assert config_digest(tuned) != config_digest(plain)
    cases = [
        ({"gain": 1.0}, r"pipeline\[0\] \(imitate\): teacher_kwargs unknown key 'gain'; "
                        r"valid keys: \['v_cap', 'w_cap', 'twist_gains'\]"),
        ({"w_cap": -1.0}, r"teacher_kwargs w_cap must be a finite number > 0"),
        ({"twist_gains": {"k_p": 1.0}}, r"teacher_kwargs twist_gains: .*k_p"),
        ({"twist_gains": {"k_v": -1.0}}, r"teacher_kwargs twist_gains: must be a finite"),
        ({}, r"teacher_kwargs must be a non-empty mapping"),
    ]
    for kwargs, match in cases:
        with pytest.raises(ValueError, match=match):
            cfg(kwargs)
    with pytest.raises(ValueError, match=r"teacher_kwargs is for the baseline teachers"):
        cfg({"w_cap": 1.0}, teacher="self_without_internal_force")


def test_every_committed_row_keeps_its_config_sha():
    """Nothing is re-run for the respelling: every row of the committed results CSV whose
    config is shipped has the digest of the config file as it is now."""
    rows = read_rows(configs_dir().parent / DEFAULT_CSV)
    names = {p.stem for p in configs_dir().glob("*.yml")}
    digests = {n: config_digest(load_config(configs_dir() / f"{n}.yml")) for n in names}
    checked = [r for r in rows if r["config"] in names]
    assert checked
    assert [r["config"] for r in checked if r["config_sha"] != digests[r["config"]]] == []
    recipes = {n: load_config(configs_dir() / f"{n}.yml").recipe for n in names}
    assert all(r["recipe"] == recipes[r["config"]] for r in checked)


def test_no_config_keeps_an_old_key_and_only_plain_ones_advertise_rl_zoo3():
    for path in sorted(configs_dir().glob("*.yml")):
        text = path.read_text()
        cfg = load_config(path)
        plain = (not cfg.pipeline and cfg.mean_bound is None and not cfg.train_env_kwargs
                 # and SB3's own classes
                 and cfg.hyperparams.get("replay_buffer_class") != "TerminatingHerReplayBuffer")
        assert ("rl_zoo3.train" in text) == plain, path.name
        header = [line for line in text.splitlines() if line.startswith("#")]
        if not plain:
            assert len(header) <= 6, (path.name, header)


def test_ctrl_c_at_the_rl_stage_then_resume_runs_the_later_stage(tmp_path):
    """A run interrupted at its rl stage (here: stopped by its on_eval hook) resumes there and
    then runs the distillation after it; the clone before it is not run again."""
    data = _torque_config(clone_baseline=256, distill_internal_force=256, distill_rounds=1)
    data["wheelgym/ThreeWheel-v0"]["n_timesteps"] = 2048
    res = train(parse_config(data), runs_root=tmp_path, progress=False,
                on_eval=lambda row: row["timesteps"] < 1024)
    assert res.status == "stopped"
    info = json.loads((res.run_dir / "run.json").read_text())
    assert [r["status"] for r in info["stages"]] == ["finished", "stopped", "pending"]
    clone_wall = info["stages"][0]["wall_s"]
    done = resume(res.run_dir, progress=False)
    assert done.status == "finished" and done.timesteps >= 2048
    info = json.loads((res.run_dir / "run.json").read_text())
    assert [r["status"] for r in info["stages"]] == ["finished"] * 3
    assert info["stages"][0]["wall_s"] == clone_wall  # the clone kept, not run again
    assert info["stages"][2]["steps"] > 0


def test_the_configs_page_lists_every_key():
    """docs/topics/configs.md has a table row for every key of the wheelgym block and of each
    stage, with the stage's defaults as its schema states them."""
    import dataclasses

    from wheelgym.agents.config import _WHEELGYM_KEYS

    page = (configs_dir().parent / "docs" / "topics" / "configs.md").read_text()
    for key in _WHEELGYM_KEYS:
        assert f"| `{key}` |" in page, key
    for kind, cls in STAGES.items():
        assert f"### `{kind}`" in page
        for f in dataclasses.fields(cls):
            assert f"| `{f.name}` | {f.metadata['type']} | {f.metadata['default']} |" in page
    assert "| `mean_bound` |" in page and "| `n_timesteps` |" in page
