"""Carry the best hyperparameters of an Optuna study (``wheelgym tune``) into configs.

``wheelgym tune`` writes the best trial as a config for the study's own base config; this script
puts the tuned keys (the search space's: learning rate, rollout, epochs, discounting, clipping,
entropy, network, initial log std) into other configs of the same family, keeping each one's
env, seed, evaluation settings, pipeline and RL Zoo comment, sets an optional budget, writes a
one-line ``# Numbers:`` header naming the study (and prints the study's figures for the
config's section of docs/topics/research-log-configs.md), and appends the study's summary to
``benchmarks/results/studies.csv``.

Usage::

    python benchmarks/apply_study.py STUDY_DB STUDY_NAME CONFIG [CONFIG ...] \\
        [--budget STEPS] [--why "text"] [--copy-db]

``--copy-db`` copies the study's SQLite file to ``benchmarks/results/studies/<study>.db`` (open
it with ``optuna-dashboard sqlite:///...``), a folder git ignores: the study's results stay in
studies.csv.
"""

from __future__ import annotations

import argparse
import csv
import json
import shutil
import sys
import textwrap
from datetime import datetime, timezone
from pathlib import Path

import yaml

from wheelgym.agents.config import WHEELGYM_BLOCK, parse_config
from wheelgym.agents.tune import POLICY_KEYS, SEARCH_SPACES, _load_study

RESULTS = Path(__file__).resolve().parent / "results"
STUDIES_CSV = RESULTS / "studies.csv"
COLUMNS = ("study", "base_config", "algo", "metric", "max_saturation", "timesteps_per_trial",
           "trials", "complete", "pruned", "failed", "best_trial", "best_value",
           "best_saturation", "best_params", "trial_wall_s_total", "applied_to", "date")


def _summary(study) -> dict:
    from optuna.trial import TrialState

    trials = study.get_trials(deepcopy=False)
    best = study.best_trial
    attrs = study.user_attrs
    env_id = next(k for k in best.user_attrs["config"] if k != WHEELGYM_BLOCK)
    return {
        "study": study.study_name,
        "base_config": attrs.get("source"),
        "algo": attrs.get("algo"),
        "metric": attrs.get("metric"),
        "max_saturation": attrs.get("max_saturation"),
        "timesteps_per_trial": attrs.get("timesteps"),
        "trials": len(trials),
        "complete": sum(t.state == TrialState.COMPLETE for t in trials),
        "pruned": sum(t.state == TrialState.PRUNED for t in trials),
        "failed": sum(t.state == TrialState.FAIL for t in trials),
        "best_trial": best.number,
        "best_value": f"{best.value:.6g}",
        "best_saturation": best.user_attrs.get("saturation"),
        "best_params": json.dumps(best.params, sort_keys=True),
        "trial_wall_s_total": round(sum(t.user_attrs.get("wall_s", 0.0) for t in trials), 1),
        "_block": best.user_attrs["config"][env_id],
    }


def _tuned_keys(block: dict, algo: str) -> dict:
    space = SEARCH_SPACES[algo]
    out = {k: block[k] for k in space if k in block and k not in POLICY_KEYS}
    if algo == "td3" and "noise_std" in block:
        out["noise_type"] = block.get("noise_type", "normal")
    if algo in ("sac", "td3") and "gradient_steps" in block:
        out["gradient_steps"] = block["gradient_steps"]
    pk = {k: v for k, v in block.get("policy_kwargs", {}).items() if k in POLICY_KEYS}
    return {"_policy": pk, **out}


def apply(config_path: Path, tuned: dict, header: list[str], budget: int | None) -> None:
    text = config_path.read_text()
    data = yaml.safe_load(text)
    env_id = next(k for k in data if k != WHEELGYM_BLOCK)
    block = data[env_id]
    for k, v in tuned.items():
        if k != "_policy":
            block[k] = v
    pk = {k: v for k, v in block.get("policy_kwargs", {}).items() if k not in POLICY_KEYS}
    pk.update(tuned["_policy"])
    block["policy_kwargs"] = pk
    if budget is not None:
        old = int(block["n_timesteps"])
        block["n_timesteps"] = budget
        wb = data[WHEELGYM_BLOCK]
        for key in ("eval_freq", "checkpoint_freq"):  # the same number of points per run
            if wb.get(key):
                wb[key] = max(int(wb[key] * budget / old), 1)
    parse_config(data, source=str(config_path))  # a clear error before anything is written
    robot = env_id.split("/")[-1].rsplit("-v", 1)[0]
    lines = text.splitlines()
    start = next(i for i, line in enumerate(lines) if line.startswith(f"# {robot} ("))
    end = next(i for i, line in enumerate(lines) if not line.startswith("#"))
    kept = [line for line in lines[start:end] if not line.startswith("# Numbers:")]
    numbers = next((i for i, line in enumerate(kept) if line.startswith("# history:")), None)
    if numbers is not None:  # the old provenance line's wrapped tail
        del kept[numbers]
    desc = next((i for i, line in enumerate(kept) if line == "#"), len(kept))
    body = yaml.safe_dump(data, sort_keys=False, default_flow_style=None, width=100)
    config_path.write_text("\n".join(kept[:desc] + header + kept[desc:]) + "\n" + body)


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("storage", help="the study's storage (SQLite file or URL)")
    p.add_argument("study", help="study name")
    p.add_argument("configs", nargs="+", type=Path)
    p.add_argument("--budget", type=int, default=None, help="new n_timesteps of the configs")
    p.add_argument("--why", default="", help="one line: why this budget / family")
    p.add_argument("--copy-db", action="store_true")
    a = p.parse_args(argv)
    study = _load_study(a.study, a.storage)
    s = _summary(study)
    tuned = _tuned_keys(s.pop("_block"), s["algo"])
    date = datetime.now(timezone.utc).strftime("%Y-%m-%d")
    constraint = (f", saturation <= {100 * s['max_saturation']:.0f}%"
                  if s["max_saturation"] is not None else "")
    for path in a.configs:
        own = Path(s["base_config"]).name == path.name
        scope = "searched for this config" if own else f"searched on {Path(s['base_config']).name}"
        text = (f"Numbers: hyperparameters from Optuna study '{s['study']}', as of {date}; "
                f"history: docs/topics/research-log-configs.md")
        header = ["# " + line for line in textwrap.wrap(text, 97, break_on_hyphens=False)]
        apply(path, tuned, header, a.budget)
        print(f"wrote {path}; add to its section of docs/topics/research-log-configs.md: "
              f"study '{s['study']}' ({scope}; TPE, {s['complete']} complete of {s['trials']} "
              f"trials of {s['timesteps_per_trial']} steps, metric {s['metric']}{constraint}; "
              f"best trial {s['best_trial']}: {s['best_value']}; {date}; "
              f"benchmarks/results/studies.csv). {a.why}")
    s["applied_to"] = " ".join(p.stem for p in a.configs)
    s["date"] = date
    new = not STUDIES_CSV.is_file()
    with STUDIES_CSV.open("a", newline="") as f:
        w = csv.DictWriter(f, fieldnames=COLUMNS)
        if new:
            w.writeheader()
        w.writerow({k: ("" if s.get(k) is None else s[k]) for k in COLUMNS})
    if a.copy_db:
        src = Path(a.storage.removeprefix("sqlite:///"))
        dst = RESULTS / "studies" / f"{s['study']}.db"
        dst.parent.mkdir(parents=True, exist_ok=True)
        shutil.copyfile(src, dst)
        print(f"copied {src} -> {dst}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
