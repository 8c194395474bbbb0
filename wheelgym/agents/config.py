"""Training configurations: one YAML file per env id x task x action mode.

The file layout is the RL Zoo's ``hyperparams/<algo>.yml`` (a block keyed by the env id, plain
values), plus a ``wheelgym`` block that the RL Zoo ignores and that holds what its command line
would otherwise carry (algorithm, env keyword arguments, seed, evaluation settings)::

    wheelgym/ThreeWheel-v0:          # RL Zoo block: n_envs, n_timesteps, normalize, policy,
      policy: MlpPolicy              # policy_kwargs and the algorithm's keyword arguments
      n_envs: 8
      n_timesteps: 200000
      normalize: true
      learning_rate: 0.0003          # or "lin_0.0003" (linear decay, the RL Zoo's schedule)
      policy_kwargs:
        net_arch: [64, 64]
    wheelgym:
      algo: ppo
      env_kwargs: {task: goal, action_mode: velocity}
      seed: 0
      eval_freq: 20000               # environment steps between evaluations (0: none)
      eval_episodes: 10
      checkpoint_freq: 50000         # environment steps between checkpoints (0: none)
      pipeline:                      # optional: the training's stages (wheelgym.agents.pipeline)
        - {stage: imitate, teacher: baseline, steps: 200000}
        - {stage: rl}

Files are read with :func:`safe_load_config_yaml` (``yaml.safe_load`` semantics, but YAML
aliases ``*name`` are refused: a config never needs them, and nested aliases can expand
exponentially; merge keys ``<<: *x`` are aliases too) and nothing in them is evaluated:
``policy_kwargs`` holds plain values (``net_arch: [64, 64]``; ``activation_fn`` by a name from
:data:`ACTIVATIONS`). Every unknown key and every bad value raises ``ValueError`` (one line)
naming the file, the key and the valid choices.

Every key, with its type, default and valid values: docs/topics/configs.md. The ``wheelgym``
block's recipe keys of old (``clone_baseline``, ``mean_bound``, ...) are refused with their
new spelling (:func:`wheelgym.agents.pipeline.legacy_message`); ``mean_bound`` is a key of
``policy_kwargs`` (PPO/A2C). The ``wheelgym`` block and the RL Zoo's own keys (``policy``,
``n_envs``, ``n_timesteps``, ``normalize``, ``noise_type``, ``noise_std``) have a schema here.
The algorithm's keys are read from Stable-Baselines3's signatures (imported on first use, then
cached per algorithm): the keyword arguments of the algorithm class, and for ``policy_kwargs``
those of its ``MlpPolicy`` class, whose annotated type has a plain YAML form (numbers, booleans,
strings, lists, mappings, ``"lin_<number>"`` for a schedule); arguments the run supplies (env,
seed, device, ...) and class-typed ones are left out, except ``activation_fn`` (by name). Values
are checked against the annotated type, then against the ranges of :data:`_LIMITS` where one is
given.
"""

from __future__ import annotations

import collections.abc
import copy
import dataclasses
import functools
import inspect
import math
import types
import typing
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import yaml

from wheelgym import resources, safe_yaml
from wheelgym.agents import pipeline as pipeline_mod

__all__ = [
    "ALGOS",
    "ON_POLICY",
    "ACTIVATIONS",
    "TrainConfig",
    "load_config",
    "load_run_config",
    "parse_config",
    "default_config_path",
    "configs_dir",
    "safe_load_config_yaml",
]

#: Supported algorithms (Stable-Baselines3 class names in lower case).
ALGOS: tuple[str, ...] = ("ppo", "sac", "td3", "a2c")

#: Activation names accepted in ``policy_kwargs.activation_fn`` (torch.nn class names).
ACTIVATIONS: dict[str, str] = {
    "tanh": "Tanh",
    "relu": "ReLU",
    "elu": "ELU",
    "leaky_relu": "LeakyReLU",
    "gelu": "GELU",
    "silu": "SiLU",
}

WHEELGYM_BLOCK = "wheelgym"
VEC_ENVS: tuple[str, ...] = ("dummy", "subproc", "native")
DEVICES: tuple[str, ...] = ("cpu", "cuda", "auto")

#: The on-policy algorithms (rollouts of ``n_steps``; a Gaussian policy with a free mean).
ON_POLICY: tuple[str, ...] = ("ppo", "a2c")

#: Largest accepted seed (NumPy's legacy seeding and SB3's ``set_random_seed`` need < 2**32).
MAX_SEED = 2**32 - 1


def safe_load_config_yaml(path: str | Path) -> Any:
    """Read a config YAML file like ``yaml.safe_load``, refusing aliases
    (:func:`wheelgym.safe_yaml.load`).

    Raises ``ValueError`` (one line, naming the file) for unreadable files, invalid YAML and
    aliases.
    """
    return safe_yaml.load(path, "config")


# --------------------------------------------------------------------------------------------
# value checkers: each returns the cleaned value or raises ValueError(message without context)
# --------------------------------------------------------------------------------------------


def _is_int(v: Any) -> bool:
    return isinstance(v, int) and not isinstance(v, bool)


def _is_num(v: Any) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)


def _int(lo: int | None = None, allow: tuple[int, ...] = (), hi: int | None = None):
    def check(v: Any) -> int:
        if isinstance(v, float) and math.isfinite(v) and v.is_integer():
            v = int(v)  # YAML writes 2.0e5 as a float
        if not _is_int(v):
            raise ValueError(f"must be an integer, got {v!r}")
        if v in allow:
            return v
        if lo is not None and v < lo:
            extra = f" (or one of {list(allow)})" if allow else ""
            raise ValueError(f"must be >= {lo}{extra}, got {v!r}")
        if hi is not None and v > hi:
            raise ValueError(f"must be <= {hi}, got {v!r}")
        return v

    return check


def _float(lo: float | None = None, hi: float | None = None, lo_open: bool = False):
    def check(v: Any) -> float:
        if not _is_num(v):
            raise ValueError(f"must be a finite number, got {v!r}")
        v = float(v)
        if lo is not None and (v <= lo if lo_open else v < lo):
            raise ValueError(f"must be {'>' if lo_open else '>='} {lo}, got {v!r}")
        if hi is not None and v > hi:
            raise ValueError(f"must be <= {hi}, got {v!r}")
        return v

    return check


def _bool(v: Any) -> bool:
    if not isinstance(v, bool):
        raise ValueError(f"must be true or false, got {v!r}")
    return v


def _choice(*choices: str):
    def check(v: Any) -> str:
        if v not in choices:
            raise ValueError(f"must be one of {list(choices)}, got {v!r}")
        return v

    return check


def _schedule(lo_open: bool = True):
    """A positive float, or the RL Zoo's ``"lin_<float>"`` linear schedule (parsed, not eval'd)."""
    num = _float(0.0, lo_open=lo_open)

    def check(v: Any) -> float | str:
        if isinstance(v, str):
            head, _, tail = v.partition("_")
            if head != "lin" or not tail:
                raise ValueError(f"must be a number or 'lin_<number>', got {v!r}")
            try:
                num(float(tail))
            except ValueError as e:
                raise ValueError(f"must be a number or 'lin_<number>', got {v!r} ({e})") from None
            return v
        return num(v)

    return check


def _ent_coef(v: Any) -> float | str:
    if isinstance(v, str):
        if v == "auto" or (v.startswith("auto_") and _is_float_str(v[5:])):
            return v
        raise ValueError(f"must be a number >= 0, 'auto' or 'auto_<number>', got {v!r}")
    return _float(0.0)(v)


def _is_float_str(s: str) -> bool:
    try:
        return math.isfinite(float(s)) and float(s) > 0
    except ValueError:
        return False


def _target_entropy(v: Any) -> float | str:
    return v if v == "auto" else _float()(v)


def _train_freq(v: Any) -> int | list:
    if isinstance(v, list):
        if len(v) != 2 or not _is_int(v[0]) or v[0] < 1 or v[1] not in ("step", "episode"):
            raise ValueError(f"must be an integer >= 1 or [n, 'step'|'episode'], got {v!r}")
        return v
    return _int(1)(v)


def _net_arch(v: Any) -> list | dict:
    def layers(x: Any) -> list[int]:
        if not isinstance(x, list) or not all(_is_int(n) and n >= 1 for n in x):
            raise ValueError(f"net_arch must be a list of positive integers, got {x!r}")
        return list(x)

    if isinstance(v, dict):
        bad = sorted(set(v) - {"pi", "vf", "qf"})
        if bad:
            raise ValueError(f"net_arch keys {bad} unknown; valid keys: ['pi', 'vf', 'qf']")
        return {k: layers(x) for k, x in v.items()}
    return layers(v)


def weights_at(schedule: Mapping[str, Sequence[Sequence[float]]] | None,
               step: int) -> dict[str, float]:
    """The weights a :attr:`TrainConfig.reward_schedule` sets at training step ``step`` (terms
    whose first point lies ahead are left out: the env's own weight holds)."""
    out: dict[str, float] = {}
    for term, points in (schedule or {}).items():
        for at, w in points:
            if at <= step:
                out[term] = float(w)
    return out


def _check_table(v: dict, table: dict[str, Any]) -> dict:
    """Validate each entry of ``v`` with ``table[key]``; an unknown key lists the valid ones."""
    out = {}
    for k, x in v.items():
        if k not in table:
            raise ValueError(f"unknown key {k!r}; valid keys: {sorted(table)}")
        try:
            out[k] = table[k](x)
        except ValueError as e:
            raise ValueError(f"{k} {e}") from None
    return out


_NORMALIZE_KWARGS: dict[str, Any] = {
    "norm_obs": _bool,
    "norm_reward": _bool,
    "clip_obs": _float(0.0, lo_open=True),
    "clip_reward": _float(0.0, lo_open=True),
    "epsilon": _float(0.0, lo_open=True),
    "gamma": _float(0.0, 1.0, lo_open=True),
}


def _normalize(v: Any) -> bool | dict:
    if isinstance(v, bool):
        return v
    if not isinstance(v, dict):
        raise ValueError(f"must be true, false or a mapping of VecNormalize options, got {v!r}")
    return _check_table(v, _NORMALIZE_KWARGS)


# Keys of the RL Zoo block that are not algorithm keyword arguments (``policy_kwargs`` is added
# per algorithm, from its policy class).
_ZOO_KEYS: dict[str, Any] = {
    "policy": _choice("MlpPolicy", "MultiInputPolicy"),  # Dict observations: goal_conditioned
    "n_envs": _int(1),
    "n_timesteps": _int(1),
    "normalize": _normalize,
    "noise_type": _choice("normal", "ornstein-uhlenbeck"),
    "noise_std": _float(0.0),
}

# --------------------------------------------------------------------------------------------
# algorithm keys from Stable-Baselines3's signatures
# --------------------------------------------------------------------------------------------

# Keyword arguments of the algorithm that a config does not set: the run supplies them, or the
# config has its own key for them (``policy_kwargs``; ``action_noise``: noise_type, noise_std).
_SUPPLIED = frozenset({"self", "policy", "env", "seed", "device", "tensorboard_log", "verbose",
                       "_init_setup_model", "policy_kwargs", "action_noise"})
# ... and per algorithm, those the layout keeps out: ``n_steps`` is the on-policy rollout
# length here, not the n-step returns of SB3's off-policy algorithms.
_NOT_EXPOSED: dict[str, frozenset[str]] = {"sac": frozenset({"n_steps"}),
                                           "td3": frozenset({"n_steps"})}
# Keyword arguments of the policy class that the algorithm passes itself.
_POLICY_SUPPLIED = frozenset({"self", "observation_space", "action_space", "lr_schedule",
                              "use_sde"})

# Ranges and string forms beyond the annotated types, checked after them (``None`` passes).
_LIMITS: dict[str, Any] = {
    "learning_rate": _schedule(),
    "clip_range": _schedule(),
    "clip_range_vf": _schedule(),
    "gamma": _float(0.0, 1.0, lo_open=True),
    "gae_lambda": _float(0.0, 1.0),
    "tau": _float(0.0, 1.0, lo_open=True),
    "n_steps": _int(1),
    "batch_size": _int(1),
    "n_epochs": _int(1),
    "buffer_size": _int(1),
    "learning_starts": _int(0),
    "gradient_steps": _int(1, allow=(-1,)),
    "target_update_interval": _int(1),
    "policy_delay": _int(1),
    "sde_sample_freq": _int(-1),
    "stats_window_size": _int(1),
    "train_freq": _train_freq,
    "ent_coef": _ent_coef,
    "target_entropy": _target_entropy,
    "vf_coef": _float(0.0),
    "max_grad_norm": _float(0.0, lo_open=True),
    "target_kl": _float(0.0, lo_open=True),
    "rms_prop_eps": _float(0.0, lo_open=True),
    "target_policy_noise": _float(0.0),
    "target_noise_clip": _float(0.0),
    "n_critics": _int(1),
}
_ALGO_LIMITS: dict[str, dict[str, Any]] = {"ppo": {"n_steps": _int(2), "batch_size": _int(2)}}
# Policy arguments written in a plain form of our own instead of their annotated type.
#: Replay buffer classes a config may name (``replay_buffer_class``; off-policy algorithms).
REPLAY_BUFFERS: tuple[str, ...] = ("ReplayBuffer", "DictReplayBuffer", "HerReplayBuffer",
                                   "TerminatingHerReplayBuffer")  # the last: agents.her
#: Algorithm arguments written in a plain form of our own (class-typed ones, by name).
_ALGO_PLAIN_FORMS: dict[str, Any] = {"replay_buffer_class": _choice(*REPLAY_BUFFERS)}
_PLAIN_FORMS: dict[str, Any] = {
    "net_arch": _net_arch,
    "activation_fn": _choice(*ACTIVATIONS),  # torch.nn class by name
}


def _str(v: Any) -> str:
    if not isinstance(v, str):
        raise ValueError(f"must be a string, got {v!r}")
    return v


def _lin(v: Any) -> str:
    """A schedule (``Callable[[float], float]``) in its plain form ``"lin_<number>"``."""
    if isinstance(v, str):
        head, _, tail = v.partition("_")
        if head == "lin" and tail:
            try:
                float(tail)
                return v
            except ValueError:
                pass
    raise ValueError(f"must be 'lin_<number>', got {v!r}")


def _list_of(item) -> Any:
    def check(v: Any) -> list:
        if not isinstance(v, list):
            raise ValueError(f"must be a list, got {v!r}")
        return [item(x) for x in v]

    return check


def _tuple_of(items: tuple) -> Any:
    def check(v: Any) -> list:  # YAML has lists; algo_kwargs makes the tuple
        if not isinstance(v, list) or len(v) != len(items):
            raise ValueError(f"must be a list of {len(items)} values, got {v!r}")
        return [c(x) for c, x in zip(items, v, strict=True)]

    return check


def _mapping_of(value) -> Any:
    def check(v: Any) -> dict:
        if not isinstance(v, dict):
            raise ValueError(f"must be a mapping, got {v!r}")
        return {k: value(x) for k, x in v.items()}

    return check


def _any(v: Any) -> Any:
    return v  # plain already (_plain)


def _union(options: list, optional: bool) -> Any:
    def check(v: Any) -> Any:
        if v is None and optional:
            return None
        errors = []
        for c in options:
            try:
                return c(v)
            except ValueError as e:
                errors.append(str(e).removeprefix("must be ").rsplit(", got ", 1)[0])
        if optional:
            errors.append("null")
        raise ValueError(f"must be {' or '.join(errors)}, got {v!r}")

    return check


def _from_annotation(ann: Any) -> Any | None:
    """A checker of a YAML value for an SB3 type annotation; ``None`` when no plain value
    has that type (classes, spaces, environments, devices)."""
    if ann is Any:
        return _any
    simple = {bool: _bool, int: _int(), float: _float(), str: _str}
    if isinstance(ann, type) and ann in simple:
        return simple[ann]
    origin, args = typing.get_origin(ann), typing.get_args(ann)
    if origin in (typing.Union, types.UnionType):
        optional = type(None) in args
        options = [_from_annotation(a) for a in args if a is not type(None)]
        options = [c for c in options if c is not None]
        return _union(options, optional) if options else None
    if origin is list and len(args) == 1:
        item = _from_annotation(args[0])
        return None if item is None else _list_of(item)
    if origin is tuple and args and Ellipsis not in args:
        items = tuple(_from_annotation(a) for a in args)
        return None if None in items else _tuple_of(items)
    if origin is dict and len(args) == 2 and args[0] is str:
        value = _from_annotation(args[1])
        return None if value is None else _mapping_of(value)
    if origin is collections.abc.Callable and args == ([float], float):
        return _lin
    return None


def _limited(check, limit) -> Any:
    def wrapped(v: Any) -> Any:
        v = check(v)
        return v if v is None else limit(v)

    return wrapped


def _signature_table(fn: Any, skip: frozenset[str], limits: Mapping[str, Any],
                     plain_forms: Mapping[str, Any] | None = None) -> dict[str, Any]:
    """``keyword -> checker`` for the keyword arguments of ``fn`` that a config can set."""
    try:
        params = inspect.signature(fn, eval_str=True).parameters
    except Exception:  # an annotation that does not evaluate: read them as written
        params = inspect.signature(fn).parameters
    table: dict[str, Any] = {}
    for name, p in params.items():
        if name in skip or p.kind in (p.VAR_POSITIONAL, p.VAR_KEYWORD):
            continue
        if plain_forms and name in plain_forms:
            table[name] = plain_forms[name]
            continue
        check = _from_annotation(p.annotation)
        if check is None:
            continue
        table[name] = _limited(check, limits[name]) if name in limits else check
    return table


@functools.cache
def _algo_table(algo: str) -> dict[str, Any]:
    """``key -> checker`` of an algorithm's keys in the RL Zoo block, from the signatures of
    its SB3 class and of its ``MlpPolicy`` (for ``policy_kwargs``); imports SB3."""
    try:
        import stable_baselines3 as sb3
    except ImportError as e:
        raise ValueError(f"checking the hyperparameters needs stable-baselines3 "
                         f"(pip install -e '.[train]'): {e}") from None
    cls = getattr(sb3, algo.upper())
    limits = {**_LIMITS, **_ALGO_LIMITS.get(algo, {})}
    table = _signature_table(cls.__init__, _SUPPLIED | _NOT_EXPOSED.get(algo, frozenset()),
                             limits, _ALGO_PLAIN_FORMS)
    policy_table = _signature_table(cls.policy_aliases["MlpPolicy"].__init__, _POLICY_SUPPLIED,
                                    limits, _PLAIN_FORMS)

    if algo in ON_POLICY:  # the squashed Gaussian mean (wheelgym.agents.bounded_policy)
        policy_table["mean_bound"] = _float(lo=1.0)

    def policy_kwargs(v: Any) -> dict:
        if not isinstance(v, dict):
            raise ValueError(
                f"must be a mapping of plain values (e.g. {{net_arch: [64, 64]}}), got {v!r}"
            )
        return _check_table(v, policy_table)

    return {**table, "policy_kwargs": policy_kwargs}


_WHEELGYM_KEYS: dict[str, Any] = {
    "algo": _choice(*ALGOS),
    "env_kwargs": None,  # checked separately (a mapping; the environment validates values)
    "train_env_kwargs": None,  # checked separately (a mapping)
    "seed": _int(0, hi=MAX_SEED),
    "eval_freq": _int(0),
    "eval_episodes": _int(1),
    "checkpoint_freq": _int(0),
    "vec_env": _choice(*VEC_ENVS),
    "device": _choice(*DEVICES),
    "torch_threads": _int(1),
    "pipeline": None,  # checked separately (wheelgym.agents.pipeline.parse_pipeline)
}

_WHEELGYM_DEFAULTS: dict[str, Any] = {
    "env_kwargs": {},
    "train_env_kwargs": {},
    "seed": 0,
    "eval_freq": 0,
    "eval_episodes": 10,
    "checkpoint_freq": 0,
    "vec_env": "dummy",
    "device": "cpu",
    "torch_threads": 1,
    "pipeline": None,
}


@dataclasses.dataclass(frozen=True)
class TrainConfig:
    """A validated training configuration.

    ================ ============================================================================
    field            meaning
    ================ ============================================================================
    env_id           registered Gymnasium id, e.g. ``"wheelgym/ThreeWheel-v0"``
    algo             one of :data:`ALGOS`
    env_kwargs       keyword arguments of ``gym.make`` (task, action_mode, ...): the task the
                     agent is evaluated, scored and shipped on
    train_env_kwargs keyword arguments replacing some of ``env_kwargs`` in the training envs
                     only (every stage; the periodic evaluations use ``env_kwargs``): a
                     training distribution wider than the task, e.g. a ``perturbation`` with
                     the delay drawn from 0-2 steps for an agent scored at ``medium``; ``{}``:
                     none. It may not change the observation or action space
    hyperparams      algorithm keyword arguments incl. ``policy`` and ``policy_kwargs`` (plain
                     values as in the file; ``policy_kwargs.mean_bound`` selects
                     :class:`wheelgym.agents.bounded_policy.BoundedMeanPolicy`)
    n_envs           parallel environments in training
    n_timesteps      total environment steps of the ``rl`` stage
    normalize        ``None`` (no ``VecNormalize``) or its keyword arguments
    noise            ``None`` or ``(noise_type, noise_std)`` for SAC/TD3 action noise
    seed             seed of the algorithm and of the training environments
    eval_freq        environment steps between evaluations during training (0: none)
    eval_episodes    episodes per evaluation
    checkpoint_freq  environment steps between checkpoints (0: none)
    vec_env          ``"dummy"``, ``"subproc"`` or ``"native"`` (wheelgym's batched env)
    device           torch device
    torch_threads    ``torch.set_num_threads`` value (1 is fastest for small MLPs)
    pipeline         the stages as written (:mod:`wheelgym.agents.pipeline`); ``()``: none
                     written, plain RL (:attr:`stages` is then one ``rl`` stage)
    source           the file it came from (for messages), or ``"<dict>"``
    ================ ============================================================================
    """

    env_id: str
    algo: str
    env_kwargs: dict
    hyperparams: dict
    n_envs: int = 1
    n_timesteps: int = 100_000
    normalize: dict | None = None
    noise: tuple[str, float] | None = None
    seed: int = 0
    eval_freq: int = 0
    eval_episodes: int = 10
    checkpoint_freq: int = 0
    vec_env: str = "dummy"
    device: str = "cpu"
    torch_threads: int = 1
    pipeline: tuple = ()
    source: str = "<dict>"
    train_env_kwargs: dict = dataclasses.field(default_factory=dict)

    @property
    def training_env_kwargs(self) -> dict:
        """The training envs' keyword arguments: ``env_kwargs`` with ``train_env_kwargs``."""
        return {**self.env_kwargs, **self.train_env_kwargs}

    @property
    def task(self) -> str | None:
        return self.env_kwargs.get("task")

    @property
    def action_mode(self) -> str | None:
        return self.env_kwargs.get("action_mode")

    @property
    def name(self) -> str:
        """Short name used for run folders and study names: the config file's stem and the
        algorithm (``ThreeWheel-navigate-warehouse-velocity-ppo``), so that the map, robust and
        HER variants of a config get folders of their own; ``<Robot>-<task>-<action_mode>-<algo>``
        for a config not read from a file (or from a run folder's ``config.yml``)."""
        src = Path(self.source)
        if src.suffix in (".yml", ".yaml") and src.stem != "config":
            return f"{src.stem}-{self.algo}"
        robot = self.env_id.split("/")[-1].rsplit("-v", 1)[0]
        parts = [robot, self.task, self.action_mode, self.algo]
        return "-".join(str(p) for p in parts if p)

    @property
    def stages(self) -> tuple:
        """The stages training runs: :attr:`pipeline`, or one ``rl`` stage without it."""
        return self.pipeline or (pipeline_mod.RL(),)

    @property
    def rl_stage(self) -> pipeline_mod.RL:
        """The one ``rl`` stage."""
        return next(s for s in self.stages if isinstance(s, pipeline_mod.RL))

    @property
    def reward_schedule(self) -> dict | None:
        """The ``rl`` stage's reward curriculum (``None``: the env's weights throughout)."""
        return self.rl_stage.reward_schedule

    @property
    def mean_bound(self) -> float | None:
        """``policy_kwargs.mean_bound`` (``None``: SB3's plain ``MlpPolicy``)."""
        return self.hyperparams.get("policy_kwargs", {}).get("mean_bound")

    @property
    def recipe(self) -> str:
        """The recipe's short name for the results table: ``scratch`` (RL alone, with or without a
        reward schedule), or the stages
        joined by ``+`` (``clone`` for imitating the baseline, ``clone-true`` the baseline with
        the true parameters, ``plan-clone`` the planning
        baseline, ``distill`` for the policy
        itself without its internal force, ``rl``), e.g. ``clone+rl``."""
        if not any(isinstance(s, pipeline_mod.Imitate) for s in self.pipeline):
            return "scratch"
        names = {"baseline": "clone", "baseline_true": "clone-true", "planner": "plan-clone",
                 "self_without_internal_force": "distill"}
        return "+".join(names[s.teacher] if isinstance(s, pipeline_mod.Imitate) else s.kind
                        for s in self.pipeline)

    def replace(self, **changes: Any) -> TrainConfig:
        """A copy with fields changed; the result is validated again."""
        data = self.to_dict()
        block = data[self.env_id]
        wg = data[WHEELGYM_BLOCK]
        for key, value in changes.items():
            if key == "n_timesteps" or key == "n_envs":
                block[key] = value
            elif key == "pipeline":
                if value:
                    wg[key] = (value if isinstance(value, list) and value
                               and isinstance(value[0], Mapping)
                               else pipeline_mod.pipeline_to_list(value))
                else:
                    wg.pop(key, None)
            elif key in _WHEELGYM_KEYS:
                wg[key] = value
            else:
                raise ValueError(
                    f"cannot replace {key!r}; valid fields: "
                    f"{sorted(['n_timesteps', 'n_envs', *_WHEELGYM_KEYS])}"
                )
        return parse_config(data, source=self.source)

    def to_dict(self) -> dict:
        """The file form (RL Zoo block + ``wheelgym`` block); ``parse_config`` reads it back."""
        block: dict[str, Any] = {}
        block.update(copy.deepcopy(self.hyperparams))
        block["n_envs"] = self.n_envs
        block["n_timesteps"] = self.n_timesteps
        if self.normalize is not None:
            block["normalize"] = copy.deepcopy(self.normalize) or True
        if self.noise is not None:
            block["noise_type"], block["noise_std"] = self.noise
        wg = {
            "algo": self.algo,
            "env_kwargs": copy.deepcopy(self.env_kwargs),
            "seed": self.seed,
            "eval_freq": self.eval_freq,
            "eval_episodes": self.eval_episodes,
            "checkpoint_freq": self.checkpoint_freq,
            "vec_env": self.vec_env,
            "device": self.device,
            "torch_threads": self.torch_threads,
        }
        if self.train_env_kwargs:  # absent unless set (config digests of the others unchanged)
            wg["train_env_kwargs"] = copy.deepcopy(self.train_env_kwargs)
        if self.pipeline:  # absent for plain RL
            wg["pipeline"] = pipeline_mod.pipeline_to_list(self.pipeline)
        return {self.env_id: block, WHEELGYM_BLOCK: wg}

    def recipe_form(self) -> dict:
        """:meth:`to_dict` with the pipeline and ``mean_bound`` in the flat keys that spelled
        them before the pipeline, where they have such a form
        (:func:`wheelgym.agents.pipeline.legacy_form`): the form the results CSV's
        ``config_sha`` digests, so that a recipe's digest does not depend on its spelling."""
        data = self.to_dict()
        flat = pipeline_mod.legacy_form(self.pipeline)
        if flat is None:
            return data
        wg = data[WHEELGYM_BLOCK]
        wg.pop("pipeline", None)
        block = data[self.env_id]
        pk = block.get("policy_kwargs")
        if pk and "mean_bound" in pk:
            wg["mean_bound"] = pk.pop("mean_bound")
            if not pk:
                del block["policy_kwargs"]
        wg.update(flat)
        return data

    def dump(self, path: str | Path) -> None:
        """Write the file form as YAML."""
        Path(path).write_text(yaml.safe_dump(self.to_dict(), sort_keys=False))


def _check_block(block: Mapping, table: Mapping[str, Any], where: str) -> dict:
    out: dict[str, Any] = {}
    for key, value in block.items():
        if key not in table:
            raise ValueError(f"{where}: unknown key {key!r}; valid keys: {sorted(table)}")
        check = table[key]
        if check is None:
            out[key] = value
            continue
        try:
            out[key] = check(value)
        except ValueError as e:
            raise ValueError(f"{where}: {key} {e}") from None
    return out


def _plain(value: Any, where: str) -> None:
    """Reject anything but YAML's plain scalars, lists and string-keyed mappings."""
    if value is None or isinstance(value, (bool, int, str)):
        return
    if isinstance(value, float):
        if not math.isfinite(value):
            raise ValueError(f"{where} must be finite, got {value!r}")
        return
    if isinstance(value, list):
        for i, x in enumerate(value):
            _plain(x, f"{where}[{i}]")
        return
    if isinstance(value, dict):
        for k, x in value.items():
            if not isinstance(k, str):
                raise ValueError(f"{where}: keys must be strings, got {k!r}")
            _plain(x, f"{where}.{k}")
        return
    raise ValueError(f"{where} must be a plain value, got {type(value).__name__}")


def _env_kwargs_of(wg: Mapping, source: str) -> dict[str, dict]:
    """``env_kwargs`` and ``train_env_kwargs`` of the ``wheelgym`` block as dicts (``None``:
    empty), checked: mappings, and the training envs keep the task and action mode."""
    out = {}
    for key in ("env_kwargs", "train_env_kwargs"):
        value = wg.get(key)
        value = {} if value is None else value
        if not isinstance(value, Mapping):
            raise ValueError(f"{source}: {WHEELGYM_BLOCK}: {key} must be a mapping of env "
                             f"keyword arguments, got {value!r}")
        out[key] = dict(value)
    fixed = [k for k in ("task", "action_mode") if k in out["train_env_kwargs"]]
    if fixed:
        raise ValueError(f"{source}: {WHEELGYM_BLOCK}: train_env_kwargs may not set {fixed} "
                         f"(the task the agent is scored on is env_kwargs')")
    return out


def parse_config(data: Any, source: str = "<dict>") -> TrainConfig:
    """Validate the file form (a mapping) and return a :class:`TrainConfig`.

    Raises ``ValueError`` naming ``source``, the block and the key for an unknown key, a
    missing required key or a bad value.
    """
    if not isinstance(data, Mapping):
        raise ValueError(f"{source}: a config must be a mapping, got {type(data).__name__}")
    _plain(dict(data), source)
    if WHEELGYM_BLOCK not in data:
        raise ValueError(f"{source}: missing the {WHEELGYM_BLOCK!r} block (with 'algo')")
    env_ids = [k for k in data if k != WHEELGYM_BLOCK]
    if len(env_ids) != 1:
        raise ValueError(
            f"{source}: expected exactly one env-id block besides {WHEELGYM_BLOCK!r} "
            f"(e.g. 'wheelgym/ThreeWheel-v0'), got {env_ids}"
        )
    env_id = env_ids[0]
    block = data[env_id]
    wg = data[WHEELGYM_BLOCK]
    if not isinstance(block, Mapping):
        raise ValueError(f"{source}: block {env_id!r} must be a mapping")
    if not isinstance(wg, Mapping):
        raise ValueError(f"{source}: block {WHEELGYM_BLOCK!r} must be a mapping")

    if any(k in wg for k in pipeline_mod.LEGACY_KEYS):
        raise ValueError(pipeline_mod.legacy_message(wg, f"{source}: {WHEELGYM_BLOCK}"))
    wg = _check_block(wg, _WHEELGYM_KEYS, f"{source}: {WHEELGYM_BLOCK}")
    if "algo" not in wg:
        raise ValueError(f"{source}: {WHEELGYM_BLOCK}: missing key 'algo'; choose from {ALGOS}")
    algo = wg["algo"]
    wg = {**_WHEELGYM_DEFAULTS, **wg, **_env_kwargs_of(wg, source)}

    table = {**_ZOO_KEYS, **_algo_table(algo)}
    block = _check_block(block, table, f"{source}: {env_id} ({algo})")
    if "n_timesteps" not in block:
        raise ValueError(f"{source}: {env_id}: missing key 'n_timesteps'")
    if ("noise_type" in block) != ("noise_std" in block):
        raise ValueError(f"{source}: {env_id}: noise_type and noise_std go together")
    if "noise_type" in block and algo in ON_POLICY:
        raise ValueError(f"{source}: {env_id}: noise_type is for sac/td3, not {algo}")
    stages = () if wg["pipeline"] is None else pipeline_mod.parse_pipeline(
        wg["pipeline"], f"{source}: {WHEELGYM_BLOCK}", algo, ON_POLICY)
    if "mean_bound" in block.get("policy_kwargs", {}) and (
            block.get("policy", "MlpPolicy") != "MlpPolicy" or block.get("use_sde")):
        raise ValueError(f"{source}: {env_id}: policy_kwargs.mean_bound needs policy MlpPolicy "
                         f"without use_sde")

    normalize = block.pop("normalize", False)
    noise = None
    if "noise_type" in block:
        noise = (block.pop("noise_type"), block.pop("noise_std"))
    hyper = dict(block)
    n_envs = hyper.pop("n_envs", 1)
    n_timesteps = hyper.pop("n_timesteps")
    hyper.setdefault("policy", "MlpPolicy")
    return TrainConfig(
        env_id=env_id,
        algo=algo,
        env_kwargs=wg["env_kwargs"],
        hyperparams=hyper,
        n_envs=n_envs,
        n_timesteps=n_timesteps,
        normalize=(dict(normalize) if isinstance(normalize, dict) else ({} if normalize else None)),
        noise=noise,
        seed=wg["seed"],
        eval_freq=wg["eval_freq"],
        eval_episodes=wg["eval_episodes"],
        checkpoint_freq=wg["checkpoint_freq"],
        vec_env=wg["vec_env"],
        device=wg["device"],
        torch_threads=wg["torch_threads"],
        pipeline=stages,
        source=source,
        train_env_kwargs=wg["train_env_kwargs"],
    )


def load_config(path: str | Path, argument: str = "config") -> TrainConfig:
    """Read a YAML config with :func:`safe_load_config_yaml` and validate it (see
    :func:`parse_config`). ``path``: a config file, or the name of a shipped config
    (:func:`wheelgym.resources.config_path`; ``argument`` names it in the error)."""
    path = resources.config_path(path, argument)
    return parse_config(safe_load_config_yaml(path), source=str(path))


def load_run_config(path: str | Path) -> TrainConfig:
    """The ``config.yml`` of a run folder (or of a shipped agent): :func:`load_config`, but a
    file written before the pipeline (the flat keys of
    :data:`wheelgym.agents.pipeline.LEGACY_KEYS`) is read in the new spelling
    (:func:`wheelgym.agents.pipeline.migrate`) instead of refused."""
    path = Path(path)
    if not path.is_file():
        raise ValueError(f"config file {str(path)!r} not found"
                         + (" (it is a folder)" if path.is_dir() else ""))
    data = safe_load_config_yaml(path)
    if isinstance(data, Mapping):
        data = pipeline_mod.migrate(data)
    return parse_config(data, source=str(path))


def configs_dir() -> Path:
    """The shipped configs' folder (:func:`wheelgym.resources.configs_dir`)."""
    return resources.configs_dir()


def default_config_path() -> Path:
    """The main job's config: the three-wheel robot on the goal task."""
    return resources.default_config()
