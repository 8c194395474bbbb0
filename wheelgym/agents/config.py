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

Files are read with :func:`safe_load_config_yaml` (``yaml.safe_load`` semantics, but YAML
aliases ``*name`` are refused: a config never needs them, and nested aliases can expand
exponentially; merge keys ``<<: *x`` are aliases too) and nothing in them is evaluated:
``policy_kwargs`` holds plain values (``net_arch: [64, 64]``; ``activation_fn`` by a name from
:data:`ACTIVATIONS`). Every unknown key and every bad value raises ``ValueError`` (one line)
naming the file, the key and the valid choices.

The ``wheelgym`` block and the RL Zoo's own keys (``policy``, ``n_envs``, ``n_timesteps``,
``normalize``, ``noise_type``, ``noise_std``) have a schema here. The algorithm's keys are read
from Stable-Baselines3's signatures (imported on first use, then cached per algorithm): the
keyword arguments of the algorithm class, and for ``policy_kwargs`` those of its ``MlpPolicy``
class, whose annotated type has a plain YAML form (numbers, booleans, strings, lists, mappings,
``"lin_<number>"`` for a schedule); arguments the run supplies (env, seed, device, ...) and
class-typed ones are left out, except ``activation_fn`` (by name). Values are checked against
the annotated type, then against the ranges of :data:`_LIMITS` where one is given.
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

__all__ = [
    "ALGOS",
    "ON_POLICY",
    "ACTIVATIONS",
    "TrainConfig",
    "load_config",
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

#: The ``wheelgym`` block's keys of the clone (:mod:`wheelgym.agents.clone`); the first starts
#: it, the others need it. Only for :data:`ON_POLICY` algorithms.
CLONE_KEYS: tuple[str, ...] = ("clone_baseline", "clone_rounds", "clone_epochs",
                               "clone_internal_force")

#: The ``wheelgym`` block's keys of the internal-force distillation after training
#: (:func:`wheelgym.agents.clone.distill_internal_force`); the first starts it, the others need
#: it. Only for :data:`ON_POLICY` algorithms.
DISTILL_KEYS: tuple[str, ...] = ("distill_internal_force", "distill_rounds", "distill_weight")

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


def _reward_schedule(v: Any) -> dict[str, list[list]] | None:
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
REPLAY_BUFFERS: tuple[str, ...] = ("ReplayBuffer", "DictReplayBuffer", "HerReplayBuffer")
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
    "seed": _int(0, hi=MAX_SEED),
    "eval_freq": _int(0),
    "eval_episodes": _int(1),
    "checkpoint_freq": _int(0),
    "vec_env": _choice(*VEC_ENVS),
    "device": _choice(*DEVICES),
    "torch_threads": _int(1),
    "reward_schedule": _reward_schedule,
    "mean_bound": _float(lo=1.0),
    "clone_baseline": _int(1),
    "clone_rounds": _int(1),
    "clone_epochs": _int(1),
    "clone_internal_force": _float(lo=0.0),
    "distill_internal_force": _int(1),
    "distill_rounds": _int(1),
    "distill_weight": _float(lo=0.0),
}

_WHEELGYM_DEFAULTS: dict[str, Any] = {
    "env_kwargs": {},
    "seed": 0,
    "eval_freq": 0,
    "eval_episodes": 10,
    "checkpoint_freq": 0,
    "vec_env": "dummy",
    "device": "cpu",
    "torch_threads": 1,
    "reward_schedule": None,
    "mean_bound": None,
    "clone_baseline": None,
    "clone_rounds": None,
    "clone_epochs": None,
    "clone_internal_force": None,
    "distill_internal_force": None,
    "distill_rounds": None,
    "distill_weight": None,
}


@dataclasses.dataclass(frozen=True)
class TrainConfig:
    """A validated training configuration.

    ============== ============================================================================
    field          meaning
    ============== ============================================================================
    env_id         registered Gymnasium id, e.g. ``"wheelgym/ThreeWheel-v0"``
    algo           one of :data:`ALGOS`
    env_kwargs     keyword arguments of ``gym.make`` (task, action_mode, ...)
    hyperparams    algorithm keyword arguments incl. ``policy`` and ``policy_kwargs`` (plain
                   values as in the file)
    n_envs         parallel environments in training
    n_timesteps    total environment steps of training
    normalize      ``None`` (no ``VecNormalize``) or its keyword arguments
    noise          ``None`` or ``(noise_type, noise_std)`` for SAC/TD3 action noise
    seed           seed of the algorithm and of the training environments
    eval_freq      environment steps between evaluations during training (0: none)
    eval_episodes  episodes per evaluation
    checkpoint_freq environment steps between checkpoints (0: none)
    vec_env        ``"dummy"``, ``"subproc"`` or ``"native"`` (wheelgym's batched env)
    device         torch device
    torch_threads  ``torch.set_num_threads`` value (1 is fastest for small MLPs)
    reward_schedule ``None`` or ``{term: [[step, weight], ...]}``: reward weights changed during
                   training (a curriculum; piecewise constant in training steps)
    mean_bound     ``None`` or ``b >= 1``: PPO/A2C's Gaussian mean squashed to ``b tanh(x / b)``
                   (:class:`wheelgym.agents.bounded_policy.BoundedMeanPolicy`), so it cannot
                   drift far past the action box where clipped samples give no gradient
    clone_baseline ``None`` or ``N >= 1``: before PPO/A2C trains, the analytic baseline drives
                   the training envs for ``N`` steps; the policy's Gaussian mean is fitted to
                   its actions and the value network to the returns that followed
                   (:mod:`wheelgym.agents.clone`; not counted in ``n_timesteps``)
    clone_rounds   ``None`` (one round) or ``K >= 1``: the ``N`` steps in ``K`` rounds; after
                   the first, the clone drives and the baseline labels the states it visits
                   (DAgger), and each round refits on all rows so far
    clone_epochs   ``None`` (:data:`wheelgym.agents.clone.EPOCHS`, 10) or ``E >= 1``: passes of
                   each round's fit over the rows so far (the fit is most of a DAgger run's
                   time; later rounds start from the last fit)
    clone_internal_force ``None`` or ``w >= 0``: the fit weighs the internal force of the
                   action error (its null-space part, TW-6) ``w`` more than the plain squared
                   error (torque mode on a robot with an internal force; ThreeWheel)
    distill_internal_force ``None`` or ``N >= 1``: after PPO/A2C trains, ``N`` steps in which
                   the policy drives and its mean is refitted to its own actions less their
                   internal force (the same motion; torque mode on a robot with an internal
                   force; :func:`wheelgym.agents.clone.distill_internal_force`; not counted in
                   ``n_timesteps``)
    distill_rounds ``None`` (:data:`wheelgym.agents.clone.DISTILL_ROUNDS`, 6) or ``K >= 1``:
                   the ``N`` steps in ``K`` rounds, each refitting on all rows so far
    distill_weight ``None`` (:data:`wheelgym.agents.clone.DISTILL_WEIGHT`, 1000) or
                   ``w >= 0``: the weight of the internal force of the fit's error
    source         the file it came from (for messages), or ``"<dict>"``
    ============== ============================================================================
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
    reward_schedule: dict | None = None
    mean_bound: float | None = None
    clone_baseline: int | None = None
    clone_rounds: int | None = None
    clone_epochs: int | None = None
    clone_internal_force: float | None = None
    distill_internal_force: int | None = None
    distill_rounds: int | None = None
    distill_weight: float | None = None
    source: str = "<dict>"

    @property
    def task(self) -> str | None:
        return self.env_kwargs.get("task")

    @property
    def action_mode(self) -> str | None:
        return self.env_kwargs.get("action_mode")

    @property
    def name(self) -> str:
        """Short name ``<Robot>-<task>-<action_mode>-<algo>`` used for run folders."""
        robot = self.env_id.split("/")[-1].rsplit("-v", 1)[0]
        parts = [robot, self.task, self.action_mode, self.algo]
        return "-".join(str(p) for p in parts if p)

    def replace(self, **changes: Any) -> TrainConfig:
        """A copy with fields changed; the result is validated again."""
        data = self.to_dict()
        block = data[self.env_id]
        wg = data[WHEELGYM_BLOCK]
        for key, value in changes.items():
            if key == "n_timesteps" or key == "n_envs":
                block[key] = value
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
        if self.reward_schedule is not None:  # absent by default (old files stay the same)
            wg["reward_schedule"] = copy.deepcopy(self.reward_schedule)
        if self.mean_bound is not None:  # absent by default, like reward_schedule
            wg["mean_bound"] = self.mean_bound
        for key in (*CLONE_KEYS, *DISTILL_KEYS):  # absent by default, like reward_schedule
            if getattr(self, key) is not None:
                wg[key] = getattr(self, key)
        return {self.env_id: block, WHEELGYM_BLOCK: wg}

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

    wg = _check_block(wg, _WHEELGYM_KEYS, f"{source}: {WHEELGYM_BLOCK}")
    if "algo" not in wg:
        raise ValueError(f"{source}: {WHEELGYM_BLOCK}: missing key 'algo'; choose from {ALGOS}")
    algo = wg["algo"]
    env_kwargs = wg.get("env_kwargs", {})
    if env_kwargs is None:
        env_kwargs = {}
    if not isinstance(env_kwargs, Mapping):
        raise ValueError(f"{source}: {WHEELGYM_BLOCK}: env_kwargs must be a mapping")
    wg = {**_WHEELGYM_DEFAULTS, **wg, "env_kwargs": dict(env_kwargs)}

    table = {**_ZOO_KEYS, **_algo_table(algo)}
    block = _check_block(block, table, f"{source}: {env_id} ({algo})")
    if "n_timesteps" not in block:
        raise ValueError(f"{source}: {env_id}: missing key 'n_timesteps'")
    if ("noise_type" in block) != ("noise_std" in block):
        raise ValueError(f"{source}: {env_id}: noise_type and noise_std go together")
    if "noise_type" in block and algo in ON_POLICY:
        raise ValueError(f"{source}: {env_id}: noise_type is for sac/td3, not {algo}")
    if wg["mean_bound"] is not None and algo not in ON_POLICY:
        raise ValueError(f"{source}: {WHEELGYM_BLOCK}: mean_bound is for {list(ON_POLICY)} "
                         f"(a Gaussian policy with a free mean), not {algo!r}")
    if wg["mean_bound"] is not None and (block.get("policy", "MlpPolicy") != "MlpPolicy"
                                         or block.get("use_sde")):
        raise ValueError(f"{source}: {WHEELGYM_BLOCK}: mean_bound needs policy MlpPolicy "
                         f"without use_sde")

    for keys in (CLONE_KEYS, DISTILL_KEYS):  # the first starts the fit, the others need it
        first = keys[0]
        if wg[first] is not None and algo not in ON_POLICY:
            raise ValueError(f"{source}: {WHEELGYM_BLOCK}: {first} is for {list(ON_POLICY)} "
                             f"(a Gaussian policy whose mean is fitted), not {algo!r}")
        for key in keys[1:]:
            if wg[key] is not None and wg[first] is None:
                raise ValueError(f"{source}: {WHEELGYM_BLOCK}: {key} needs {first} "
                                 f"(the steps it works on)")

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
        reward_schedule=wg["reward_schedule"],
        mean_bound=wg["mean_bound"],
        clone_baseline=wg["clone_baseline"],
        clone_rounds=wg["clone_rounds"],
        clone_epochs=wg["clone_epochs"],
        clone_internal_force=wg["clone_internal_force"],
        distill_internal_force=wg["distill_internal_force"],
        distill_rounds=wg["distill_rounds"],
        distill_weight=wg["distill_weight"],
        source=source,
    )


def load_config(path: str | Path, argument: str = "config") -> TrainConfig:
    """Read a YAML config with :func:`safe_load_config_yaml` and validate it (see
    :func:`parse_config`). ``path``: a config file, or the name of a shipped config
    (:func:`wheelgym.resources.config_path`; ``argument`` names it in the error)."""
    path = resources.config_path(path, argument)
    return parse_config(safe_load_config_yaml(path), source=str(path))


def configs_dir() -> Path:
    """The shipped configs' folder (:func:`wheelgym.resources.configs_dir`)."""
    return resources.configs_dir()


def default_config_path() -> Path:
    """The main job's config: the three-wheel robot on the goal task."""
    return resources.default_config()
