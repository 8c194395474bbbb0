"""The training pipeline: a config's ``pipeline:`` list of named stages, one schema per stage.

A config's ``wheelgym`` block may hold ``pipeline:``, a list of stages that
:func:`wheelgym.agents.train.train` runs in order on one model::

    wheelgym:
      algo: ppo
      pipeline:
        - {stage: imitate, teacher: baseline, steps: 200000, rounds: 4}
        - {stage: rl, reward_schedule: {saturation: [[200000, 0.05]]}}
        - {stage: imitate, teacher: self_without_internal_force, steps: 300000, rounds: 6}

Without ``pipeline`` a config is plain RL (one ``rl`` stage). Each stage kind is a frozen
dataclass in :data:`STAGES` whose fields are its keys; a field's ``metadata`` holds its checker,
its YAML type, its default's meaning and its description (``docs/topics/configs.md`` lists them,
and a test checks that page against this table). :func:`parse_pipeline` validates a list: an
error names the stage's index and kind, the key and the valid keys or values.

========= =========================================================================================
stage     what it does
========= =========================================================================================
imitate   fits the policy's Gaussian mean (and, with the baseline, its value network) to a
          teacher's actions on the training envs, in DAgger rounds
          (:func:`wheelgym.agents.clone.clone_baseline`,
          :func:`wheelgym.agents.clone.distill_internal_force`); PPO/A2C only; its ``steps`` are
          not counted in ``n_timesteps``
rl        the algorithm's own training for the RL Zoo block's ``n_timesteps`` (the budget
          ``--budget`` and ``--timesteps`` change), with an optional reward curriculum
========= =========================================================================================

Teachers of ``imitate`` (:data:`TEACHERS`): ``baseline`` (the analytic baseline drives the first
round, the clone the later ones, the baseline labels every state), ``baseline_true`` (the same
with the baseline computing with each row's true, perturbed parameters: a privileged teacher,
``wheelgym.baseline(env, model="true")``; docs/topics/robustness.md), ``planner`` (the same with the
planning baseline, ``wheelgym.baseline(env, planner="auto")``: navigate only;
docs/topics/planning.md) and
``self_without_internal_force`` (the policy as it is, its actions less their internal force,
labels the states it reaches: torque mode on a robot with an internal force, the native vector
env).

:func:`legacy_form` writes a pipeline in the flat keys that configs used before it
(``clone_baseline``, ``distill_internal_force``, ...) where it has such a form: the results
CSV's ``config_sha`` is a digest of that form, so a recipe's rows stay valid whatever its
spelling. :func:`from_legacy` is the other direction, for the loader's message that refuses
those keys.
"""

from __future__ import annotations

import copy
import dataclasses
import math
from collections.abc import Mapping, Sequence
from typing import Any, ClassVar

__all__ = [
    "STAGES",
    "TEACHERS",
    "BASELINE_TEACHERS",
    "TEACHER_KWARGS",
    "LEGACY_KEYS",
    "Imitate",
    "RL",
    "parse_pipeline",
    "pipeline_to_list",
    "legacy_form",
    "from_legacy",
    "legacy_message",
]

#: The teachers of an ``imitate`` stage.
TEACHERS: tuple[str, ...] = ("baseline", "baseline_true", "planner",
                              "self_without_internal_force")
#: The teachers that are a baseline policy (:func:`wheelgym.agents.clone.clone_baseline`), with
#: the keywords each passes to it (``planner``, ``model_kind``: of :func:`wheelgym.baseline`).
BASELINE_TEACHERS: dict[str, dict[str, str]] = {
    "baseline": {}, "baseline_true": {"model_kind": "true"}, "planner": {"planner": "auto"}}


# --------------------------------------------------------------------------------------------
# value checkers (each returns the clean value or raises ValueError without context)
# --------------------------------------------------------------------------------------------


def _is_int(v: Any) -> bool:
    return isinstance(v, int) and not isinstance(v, bool)


def _is_num(v: Any) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)


def _pos_int(v: Any) -> int:
    if isinstance(v, float) and math.isfinite(v) and v.is_integer():
        v = int(v)  # YAML writes 2.0e5 as a float
    if not _is_int(v) or v < 1:
        raise ValueError(f"must be an integer >= 1, got {v!r}")
    return v


def _nonneg(v: Any) -> float:
    if not _is_num(v) or v < 0:
        raise ValueError(f"must be a finite number >= 0, got {v!r}")
    return float(v)


def _positive(v: Any) -> float:
    if not _is_num(v) or v <= 0:
        raise ValueError(f"must be a finite number > 0, got {v!r}")
    return float(v)


def _teacher(v: Any) -> str:
    if v not in TEACHERS:
        raise ValueError(f"must be one of {list(TEACHERS)}, got {v!r}")
    return v


#: The keys of an ``imitate`` stage's ``teacher_kwargs`` (keywords of :func:`wheelgym.baseline`).
TEACHER_KWARGS: tuple[str, ...] = ("v_cap", "w_cap", "twist_gains")


def teacher_kwargs(v: Any) -> dict[str, Any]:
    """``{v_cap, w_cap, twist_gains: {k_v, k_i}}``: the baseline teacher's settings, passed to
    :func:`wheelgym.baseline` (its speed and yaw-rate caps, the gains of its twist loop)."""
    from wheelgym.control.controllers import TwistGains

    if not isinstance(v, Mapping) or not v:
        raise ValueError(f"must be a non-empty mapping with keys of {list(TEACHER_KWARGS)}, "
                         f"got {v!r}")
    out: dict[str, Any] = {}
    for key, x in v.items():
        if key not in TEACHER_KWARGS:
            raise ValueError(f"unknown key {key!r}; valid keys: {list(TEACHER_KWARGS)}")
        if key != "twist_gains":
            try:
                out[key] = _positive(x)
            except ValueError as e:
                raise ValueError(f"{key} {e}") from None
            continue
        if not isinstance(x, Mapping) or not x:
            raise ValueError(f"twist_gains must be a mapping with keys of ['k_v', 'k_i'], "
                             f"got {x!r}")
        try:
            gains = {k: _nonneg(g) for k, g in x.items()}
            TwistGains(**gains)  # its own checks: the field names, k_v > 0
        except (TypeError, ValueError) as e:
            raise ValueError(f"twist_gains: {e}") from None
        out[key] = gains
    return out


def reward_schedule(v: Any) -> dict[str, list[list]] | None:
    """``{term: [[step, weight], ...]}``: from ``step`` training steps on, the term's weight is
    ``weight`` (piecewise constant; steps ascending, the first may be above 0, before it the
    env's own weight holds). The env checks the term names when training starts."""
    if v is None:
        return None
    if not isinstance(v, dict) or not v:
        raise ValueError(f"must be a mapping term -> [[step, weight], ...], got {v!r}")
    out: dict[str, list[list]] = {}
    for term, points in v.items():
        if not isinstance(term, str):
            raise ValueError(f"term names must be strings, got {term!r}")
        if not isinstance(points, list) or not points:
            raise ValueError(f"{term}: must be a non-empty list of [step, weight], got {points!r}")
        clean: list[list] = []
        for p in points:
            if (not isinstance(p, list) or len(p) != 2 or not _is_int(p[0]) or p[0] < 0
                    or not _is_num(p[1])):
                raise ValueError(f"{term}: each point must be [step >= 0 (integer), finite "
                                 f"weight], got {p!r}")
            if clean and p[0] <= clean[-1][0]:
                raise ValueError(f"{term}: steps must increase, got {[q[0] for q in points]}")
            clean.append([int(p[0]), float(p[1])])
        out[term] = clean
    return out


def _key(check: Any, yaml_type: str, default: str, doc: str, required: bool = False) -> Any:
    """A stage field: ``None`` by default (the stage's own default applies), or required."""
    meta = {"check": check, "type": yaml_type, "default": default, "doc": doc}
    if required:
        return dataclasses.field(metadata=meta)
    return dataclasses.field(default=None, metadata=meta)


# --------------------------------------------------------------------------------------------
# the stages
# --------------------------------------------------------------------------------------------


@dataclasses.dataclass(frozen=True)
class Imitate:
    """Fit the policy's Gaussian mean to a teacher's actions on the training envs (DAgger).

    Defaults per teacher are :mod:`wheelgym.agents.clone`'s constants (:meth:`resolved`).
    """

    teacher: str = _key(_teacher, "string", "required",
                        "who labels the states: `baseline` (the analytic baseline), "
                        "`baseline_true` (the baseline with each row's true parameters), `planner` "
                        "(the planning baseline; navigate only) or "
                        "`self_without_internal_force` (the policy itself, its actions less "
                        "their internal force)", required=True)
    steps: int = _key(_pos_int, "integer >= 1", "required",
                      "labelled environment steps over all rounds (not counted in "
                      "`n_timesteps`)", required=True)
    rounds: int | None = _key(_pos_int, "integer >= 1", "baseline: 1; self: 6 (`DISTILL_ROUNDS`)",
                              "DAgger rounds the steps come in; each refits on all rows so far")
    epochs: int | None = _key(_pos_int, "integer >= 1", "10 (`clone.EPOCHS`)",
                              "passes of each round's fit over the rows so far")
    lr: float | None = _key(_positive, "number > 0",
                            "baseline: 1e-3 (`clone.LR`); self: 1e-4 (`DISTILL_LR`)",
                            "Adam's learning rate of the fit")
    internal_force: float | None = _key(
        _nonneg, "number >= 0", "baseline: 0; self: 1000 (`DISTILL_WEIGHT`)",
        "weight of the internal force (null-space part, TW-6) of the action error in the fit; "
        "above 0 only in torque mode on a robot with an internal force (ThreeWheel)")
    teacher_kwargs: dict | None = _key(
        teacher_kwargs, "mapping", "none (the baseline's defaults)",
        "the baseline teacher's settings (`wheelgym.baseline` keywords): `v_cap` (m/s), `w_cap` "
        "(rad/s), `twist_gains` `{k_v, k_i}` of the twist loop in torque mode (SkidSteer: with "
        "its integral action); baseline teachers only")

    kind: ClassVar[str] = "imitate"
    summary: ClassVar[str] = "fit the policy's mean to a teacher (behaviour cloning, DAgger)"

    @property
    def status(self) -> str:
        """run.json's ``status`` while the stage runs."""
        return "cloning" if self.teacher in BASELINE_TEACHERS else "distilling"

    def resolved(self) -> dict[str, Any]:
        """``rounds``, ``epochs``, ``lr`` and ``internal_force`` with the teacher's defaults."""
        from wheelgym.agents import clone

        base = self.teacher in BASELINE_TEACHERS
        return {
            "rounds": self.rounds or (1 if base else clone.DISTILL_ROUNDS),
            "epochs": self.epochs or clone.EPOCHS,
            "lr": self.lr if self.lr is not None else (clone.LR if base else clone.DISTILL_LR),
            "internal_force": (self.internal_force if self.internal_force is not None else
                               (0.0 if base else clone.DISTILL_WEIGHT)),
        }


@dataclasses.dataclass(frozen=True)
class RL:
    """The algorithm's training for the RL Zoo block's ``n_timesteps``."""

    reward_schedule: dict | None = _key(
        reward_schedule, "mapping term -> [[step, weight], ...]", "none (the env's weights)",
        "reward weights changed during training, piecewise constant in training steps (a "
        "curriculum); the terms are the env's `reward_weights`")

    kind: ClassVar[str] = "rl"
    summary: ClassVar[str] = "the algorithm's own training for `n_timesteps` steps"
    status: ClassVar[str] = "running"


#: Stage kind -> its schema.
STAGES: dict[str, type] = {"imitate": Imitate, "rl": RL}

Stage = Imitate | RL


def _fields(cls: type) -> dict[str, dataclasses.Field]:
    return {f.name: f for f in dataclasses.fields(cls)}


def parse_stage(data: Any, index: int, where: str) -> Stage:
    """One stage from its mapping; ``ValueError`` naming ``pipeline[index]``, the kind and key."""
    at = f"{where}: pipeline[{index}]"
    if not isinstance(data, Mapping):
        raise ValueError(f"{at} must be a mapping with 'stage' (one of {sorted(STAGES)}), "
                         f"got {data!r}")
    kind = data.get("stage")
    if kind not in STAGES:
        raise ValueError(f"{at}: stage must be one of {sorted(STAGES)}, got {kind!r}")
    cls = STAGES[kind]
    fields = _fields(cls)
    at = f"{at} ({kind})"
    values: dict[str, Any] = {}
    for key, value in data.items():
        if key == "stage":
            continue
        if key not in fields:
            raise ValueError(f"{at}: unknown key {key!r}; valid keys: "
                             f"{['stage', *sorted(fields)]}")
        try:
            values[key] = fields[key].metadata["check"](value)
        except ValueError as e:
            raise ValueError(f"{at}: {key} {e}") from None
    missing = [k for k, f in fields.items() if f.default is dataclasses.MISSING
               and k not in values]
    if missing:
        raise ValueError(f"{at}: missing key(s) {missing}; valid keys: "
                         f"{['stage', *sorted(fields)]}")
    stage = cls(**values)
    if isinstance(stage, Imitate) and stage.teacher_kwargs is not None and \
            stage.teacher not in BASELINE_TEACHERS:
        raise ValueError(f"{at}: teacher_kwargs is for the baseline teachers "
                         f"{list(BASELINE_TEACHERS)}, not {stage.teacher!r}")
    return stage


def parse_pipeline(value: Any, where: str, algo: str, on_policy: Sequence[str]) -> tuple:
    """The stages of a ``pipeline:`` list, validated (see the module docstring).

    Exactly one ``rl`` stage; ``imitate`` stages only for the ``on_policy`` algorithms.
    """
    if not isinstance(value, list) or not value:
        raise ValueError(f"{where}: pipeline must be a non-empty list of stages "
                         f"(each a mapping with 'stage': one of {sorted(STAGES)}), got {value!r}")
    stages = tuple(parse_stage(s, i, where) for i, s in enumerate(value))
    n_rl = sum(isinstance(s, RL) for s in stages)
    if n_rl != 1:
        raise ValueError(f"{where}: pipeline needs exactly one 'rl' stage (its steps are the "
                         f"RL Zoo block's n_timesteps), got {n_rl}")
    for i, s in enumerate(stages):
        if isinstance(s, Imitate) and algo not in on_policy:
            raise ValueError(f"{where}: pipeline[{i}] (imitate) is for {list(on_policy)} (a "
                             f"Gaussian policy whose mean is fitted), not {algo!r}")
    return stages


def stage_to_dict(stage: Stage) -> dict[str, Any]:
    """The file form of a stage (keys left at their default are left out)."""
    out: dict[str, Any] = {"stage": stage.kind}
    for f in dataclasses.fields(stage):
        v = getattr(stage, f.name)
        if v is not None:
            out[f.name] = copy.deepcopy(v)
    return out


def pipeline_to_list(stages: Sequence[Stage]) -> list[dict[str, Any]]:
    return [stage_to_dict(s) for s in stages]


# --------------------------------------------------------------------------------------------
# the flat keys of configs before the pipeline
# --------------------------------------------------------------------------------------------

#: The flat keys a ``wheelgym`` block held before ``pipeline`` (refused now).
LEGACY_KEYS: tuple[str, ...] = ("clone_baseline", "clone_rounds", "clone_epochs",
                                "clone_internal_force", "distill_internal_force",
                                "distill_rounds", "distill_weight", "mean_bound",
                                "reward_schedule")
_CLONE = {"clone_baseline": "steps", "clone_rounds": "rounds", "clone_epochs": "epochs",
          "clone_internal_force": "internal_force"}
_DISTILL = {"distill_internal_force": "steps", "distill_rounds": "rounds",
            "distill_weight": "internal_force"}
#: The teachers the flat keys could spell, with those keys.
_LEGACY_TEACHER_KEYS = {"baseline": _CLONE, "self_without_internal_force": _DISTILL}


def from_legacy(block: Mapping[str, Any]) -> tuple[list[dict[str, Any]] | None, Any]:
    """The ``pipeline`` list (``None``: plain RL) and ``mean_bound`` (for ``policy_kwargs``;
    ``None`` when unset) that a block's flat keys spelled."""
    stages: list[dict[str, Any]] = []
    clone = {new: block[old] for old, new in _CLONE.items() if block.get(old) is not None}
    if clone:
        stages.append({"stage": "imitate", "teacher": "baseline", **clone})
    rl: dict[str, Any] = {"stage": "rl"}
    if block.get("reward_schedule") is not None:
        rl["reward_schedule"] = block["reward_schedule"]
    stages.append(rl)
    distill = {new: block[old] for old, new in _DISTILL.items() if block.get(old) is not None}
    if distill:
        stages.append({"stage": "imitate", "teacher": "self_without_internal_force", **distill})
    plain = len(stages) == 1 and len(rl) == 1
    return (None if plain else stages), block.get("mean_bound")


def legacy_message(block: Mapping[str, Any], where: str) -> str:
    """The loader's refusal of the flat keys, with their new spelling."""
    import yaml

    old = [k for k in LEGACY_KEYS if k in block]
    stages, bound = from_legacy(block)
    parts = []
    if stages is not None:
        flow = yaml.safe_dump(stages, default_flow_style=True, sort_keys=False, width=10**6)
        parts.append(f"in the wheelgym block: pipeline: {flow.strip()}")
    if bound is not None:
        parts.append(f"in the RL Zoo block's policy_kwargs: mean_bound: {bound}")
    return (f"{where}: the keys {old} are no longer read; write them as a pipeline of stages "
            f"(docs/topics/configs.md): {'; '.join(parts)}")


def legacy_form(stages: Sequence[Stage]) -> dict[str, Any] | None:
    """The flat keys (``clone_*``, ``reward_schedule``, ``distill_*``) that spelled ``stages``
    before the pipeline, or ``None`` when no flat form says the same (more than one stage of a
    teacher, a baseline stage after ``rl``, a key the flat form lacked)."""
    out: dict[str, Any] = {}
    seen_rl = False
    taken: set[str] = set()
    for s in stages:
        if isinstance(s, RL):
            seen_rl = True
            if s.reward_schedule is not None:
                out["reward_schedule"] = copy.deepcopy(s.reward_schedule)
            continue
        names = _LEGACY_TEACHER_KEYS.get(s.teacher)
        if names is None:  # a teacher no flat key ever named
            return None
        if (s.teacher in taken or (s.teacher == "baseline") == seen_rl or s.lr is not None
                or s.teacher_kwargs is not None):
            return None
        if s.teacher != "baseline" and s.epochs is not None:
            return None
        taken.add(s.teacher)
        for old, new in names.items():
            if getattr(s, new) is not None:
                out[old] = getattr(s, new)
    return out


def migrate(data: Mapping[str, Any]) -> dict[str, Any]:
    """A config's file form (RL Zoo block + ``wheelgym`` block) with the flat keys of
    :data:`LEGACY_KEYS` rewritten as ``pipeline`` and ``policy_kwargs.mean_bound``; a form
    without them comes back unchanged (a copy). Run folders written before the pipeline are
    read through it (:func:`wheelgym.agents.config.load_run_config`)."""
    data = copy.deepcopy(dict(data))
    wg = data.get("wheelgym")
    if not isinstance(wg, dict) or not any(k in wg for k in LEGACY_KEYS):
        return data
    stages, bound = from_legacy(wg)
    for k in LEGACY_KEYS:
        wg.pop(k, None)
    if stages is not None:
        wg["pipeline"] = stages
    if bound is not None:
        env_id = next(k for k in data if k != "wheelgym")
        block = data[env_id]
        block["policy_kwargs"] = {**(block.get("policy_kwargs") or {}), "mean_bound": bound}
    return data
