"""Perturbations of the plant and of its signals: the ``perturbation=`` keyword of every env.

A :class:`Perturbation` states, in physical units, how the robot an environment simulates
differs from the robot the policy (or the analytic controller) was designed for, modelled on
the challenge specs of DeepMind's Real-World RL suite (delays, Gaussian noise, dropped and
stuck signals, per-episode parameter perturbations, combined easy / medium / hard levels):

============== =============================================================================
field          meaning
============== =============================================================================
scales         group -> ``(low, high)``: drawn uniformly at each reset, per parameter field
               of the group (the robot's ``randomize`` groups: mass, inertia, friction,
               wheel_radius, caster_trail, torque_limit, motor (DC motors), x_icr); a factor
               of the base value for the relative groups, an offset (m) from it for
               ``x_icr``
action_delay   ``(low, high)`` control steps between an action and its effect, drawn per
               episode (``low == high``: fixed)
actuator_lag   time constant (s) of a first-order lag on the applied inputs
obs_noise      relative Gaussian error of each observation entry: std ``obs_noise * |o_j|``
               (then clipped to the observation bounds)
action_noise   Gaussian noise on each normalised action entry (std, in action units)
action_dropped ``(prob, steps)``: each action entry is replaced by 0 for ``steps`` control
               steps, starting with probability ``prob`` at each step
action_stuck   ``(prob, steps)``: each action entry is held at its last delivered value
obs_dropped    ``(prob, steps)``: each observation entry reads 0
obs_stuck      ``(prob, steps)``: each observation entry is held at its last delivered value
============== =============================================================================

The env keyword ``perturbation`` takes a :class:`Perturbation`, a dict of its fields, or a
level name of :data:`LEVELS` (``"easy"``, ``"medium"``, ``"hard"``; the table in
``docs/topics/robustness.md``), or ``None`` (none). A dict with the key ``level`` is that
level with the dict's other fields replaced (``{"level": "medium", "action_delay": [0, 2]}``:
``medium`` with the delay drawn from 0-2 steps). The parameter draws join the env's
``randomize`` draws (a group set in both raises), the delay and lag replace ``action_delay``
and ``actuator_lag`` (set in both raises). Every draw comes from the env's ``np_random``
(row i of a vector env from its own generator), in a fixed order: at a reset the parameters,
then the delay; at each step, before the dynamics, one uniform draw per dropped/stuck entry
and one normal draw per noisy entry (:meth:`SignalFaults.draw`). So a seed gives the same
episode in the single and the vector env.

Which signals the policies see: observation noise, dropped and stuck observations act on the
observation vector; the analytic baseline reads the state (``wheelgym.envs.baseline``), so
they do not reach it. Action noise, drops, stuck entries, delay and lag act on every
policy's action.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping
from typing import Any

import numpy as np

from wheelgym.envs.actuator import MAX_ACTION_DELAY

__all__ = ["Perturbation", "LEVELS", "level", "parse_perturbation", "resolve_scales",
           "SignalFaults", "FAULT_FIELDS"]

#: The signal faults, each ``(prob, steps)``.
FAULT_FIELDS = ("action_dropped", "action_stuck", "obs_dropped", "obs_stuck")


def _pair(name: str, v: Any, kind: type) -> tuple[Any, Any]:
    if np.ndim(v) != 1 or len(v) != 2:
        raise TypeError(f"perturbation {name} must be a pair, got {v!r}")
    a, b = v
    for x in (a, b):
        if isinstance(x, bool) or not isinstance(x, (int, float, np.integer, np.floating)):
            raise TypeError(f"perturbation {name} must hold numbers, got {v!r}")
        if kind is int and not float(x).is_integer():
            raise TypeError(f"perturbation {name} must hold ints, got {v!r}")
    return kind(a), kind(b)


@dataclasses.dataclass(frozen=True)
class Perturbation:
    """A perturbation of the plant and its signals (module docstring: the fields' meaning).

    Attributes:
        scales: group -> ``(low, high)`` per-episode factor (``x_icr``: offset in m).
        action_delay: ``(low, high)`` control steps (an int: fixed).
        actuator_lag: s (0: off).
        obs_noise: relative std (0: off).
        action_noise: std in normalised action units (0: off).
        action_dropped, action_stuck, obs_dropped, obs_stuck: ``(prob, steps)``.
    """

    scales: Mapping[str, tuple[float, float]] = dataclasses.field(default_factory=dict)
    action_delay: tuple[int, int] | int = (0, 0)
    actuator_lag: float = 0.0
    obs_noise: float = 0.0
    action_noise: float = 0.0
    action_dropped: tuple[float, int] = (0.0, 0)
    action_stuck: tuple[float, int] = (0.0, 0)
    obs_dropped: tuple[float, int] = (0.0, 0)
    obs_stuck: tuple[float, int] = (0.0, 0)

    def __post_init__(self) -> None:
        put = self._put
        if not isinstance(self.scales, Mapping):
            raise TypeError(f"perturbation scales must be a dict group -> (low, high), got "
                            f"{self.scales!r}")
        scales = {}
        for g, v in self.scales.items():
            lo, hi = _pair(f"scales[{g!r}]", v, float)
            if not (math.isfinite(lo) and math.isfinite(hi) and lo <= hi):
                raise ValueError(f"perturbation scales[{g!r}] must be a finite (low, high) "
                                 f"with low <= high, got {v!r}")
            if g != "x_icr" and lo <= 0:
                raise ValueError(f"perturbation scales[{g!r}] factors must be > 0, got {v!r}")
            scales[str(g)] = (lo, hi)
        put("scales", scales)
        d = self.action_delay
        d = (d, d) if np.ndim(d) == 0 else d
        lo, hi = _pair("action_delay", d, int)
        if not 0 <= lo <= hi <= MAX_ACTION_DELAY:
            raise ValueError(f"perturbation action_delay must be 0 <= low <= high <= "
                             f"{MAX_ACTION_DELAY} control steps, got {self.action_delay!r}")
        put("action_delay", (lo, hi))
        for name in ("actuator_lag", "obs_noise", "action_noise"):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, (int, float, np.integer, np.floating)):
                raise TypeError(f"perturbation {name} must be a number, got {v!r}")
            if not (math.isfinite(v) and v >= 0):
                raise ValueError(f"perturbation {name} must be finite and >= 0, got {v!r}")
            put(name, float(v))
        for name in FAULT_FIELDS:
            v = getattr(self, name)
            p, _ = _pair(name, v, float)
            _, k = _pair(name, (0, v[1]), int)
            if not (0.0 <= p <= 1.0) or k < 0 or (p > 0) != (k > 0):
                raise ValueError(f"perturbation {name} must be (prob in [0, 1], steps >= 0), "
                                 f"both zero or both positive, got {v!r}")
            put(name, (p, k))

    def _put(self, name: str, value: Any) -> None:
        object.__setattr__(self, name, value)

    @property
    def faults(self) -> bool:
        """Whether any per-step draw is made (noise, drops, stuck entries)."""
        return (self.obs_noise > 0 or self.action_noise > 0
                or any(getattr(self, f)[0] > 0 for f in FAULT_FIELDS))

    @property
    def is_null(self) -> bool:
        """Whether it changes nothing (every scale exactly 1 and nothing else set)."""
        return (all(v == ((0.0, 0.0) if g == "x_icr" else (1.0, 1.0))
                    for g, v in self.scales.items())
                and self.action_delay == (0, 0) and self.actuator_lag == 0 and not self.faults)

    def to_dict(self) -> dict[str, Any]:
        """The fields as plain values (YAML/JSON)."""
        out = dataclasses.asdict(self)
        out["scales"] = {g: list(v) for g, v in self.scales.items()}
        for k, v in out.items():
            if isinstance(v, tuple):
                out[k] = list(v)
        return out

    def replace(self, **changes: Any) -> Perturbation:
        """A new perturbation with ``changes`` (validated)."""
        return dataclasses.replace(self, **changes)


#: The combined levels (``docs/topics/robustness.md`` states them as a table). Parameter
#: groups a robot does not have are left out when the level is applied (:func:`level`).
LEVELS: dict[str, Perturbation] = {
    "easy": Perturbation(
        scales={"mass": (0.9, 1.1), "inertia": (0.9, 1.1), "friction": (0.8, 1.2),
                "wheel_radius": (0.98, 1.02), "caster_trail": (0.9, 1.1),
                "torque_limit": (0.9, 1.0), "motor": (0.95, 1.05), "x_icr": (-0.01, 0.01)},
        action_delay=1, actuator_lag=0.02, obs_noise=0.02, action_noise=0.02,
        action_dropped=(0.01, 1), action_stuck=(0.01, 1), obs_dropped=(0.01, 1),
        obs_stuck=(0.01, 1)),
    "medium": Perturbation(
        scales={"mass": (0.75, 1.4), "inertia": (0.75, 1.4), "friction": (0.6, 1.4),
                "wheel_radius": (0.95, 1.05), "caster_trail": (0.8, 1.2),
                "torque_limit": (0.75, 1.0), "motor": (0.9, 1.1), "x_icr": (-0.03, 0.03)},
        action_delay=2, actuator_lag=0.05, obs_noise=0.05, action_noise=0.05,
        action_dropped=(0.02, 2), action_stuck=(0.02, 2), obs_dropped=(0.02, 2),
        obs_stuck=(0.02, 2)),
    "hard": Perturbation(
        scales={"mass": (0.5, 2.0), "inertia": (0.5, 2.0), "friction": (0.3, 1.5),
                "wheel_radius": (0.9, 1.1), "caster_trail": (0.6, 1.4),
                "torque_limit": (0.5, 1.0), "motor": (0.8, 1.2), "x_icr": (-0.05, 0.05)},
        action_delay=4, actuator_lag=0.1, obs_noise=0.1, action_noise=0.1,
        action_dropped=(0.05, 5), action_stuck=(0.05, 5), obs_dropped=(0.05, 5),
        obs_stuck=(0.05, 5)),
}


def level(name: str) -> Perturbation:
    """The combined level ``name`` (one of :data:`LEVELS`; ``ValueError`` listing them)."""
    if name not in LEVELS:
        raise ValueError(f"unknown perturbation level {name!r}; valid levels: {list(LEVELS)}")
    return LEVELS[name]


def parse_perturbation(value: Any) -> Perturbation | None:
    """The ``perturbation`` keyword as a :class:`Perturbation` (``None``: none)."""
    if value is None:
        return None
    if isinstance(value, Perturbation):
        return value
    if isinstance(value, str):
        return level(value)
    if isinstance(value, Mapping):
        valid = [f.name for f in dataclasses.fields(Perturbation)]
        unknown = [k for k in value if k not in valid and k != "level"]
        if unknown:
            raise ValueError(f"unknown perturbation field(s) {unknown}; valid fields: "
                             f"{valid} and 'level' (a level's fields replaced)")
        fields = {k: v for k, v in value.items() if k != "level"}
        if "level" in value:
            if not isinstance(value["level"], str):
                raise TypeError(f"perturbation level must be a level name of {list(LEVELS)}, "
                                f"got {value['level']!r}")
            return level(value["level"]).replace(**fields)
        return Perturbation(**fields)
    raise TypeError(f"perturbation must be None, a Perturbation, a dict of its fields or a "
                    f"level name of {list(LEVELS)}, got {value!r}")


def resolve_scales(pert: Perturbation, groups: Mapping[str, tuple[tuple[str, str], ...]],
                   base: Any, dc: bool) -> dict[str, tuple[float, float]]:
    """The perturbation's parameter scales as ``randomize`` ranges of a robot with the
    randomisation ``groups`` (its spec's) and base parameters ``base``: groups the robot
    lacks, and ``motor`` without DC motors, are left out; ``x_icr`` offsets become absolute
    values around the base value."""
    out: dict[str, tuple[float, float]] = {}
    for g, (lo, hi) in pert.scales.items():
        if g not in groups or (g == "motor" and not dc):
            continue
        if g == "x_icr":
            x0 = float(getattr(base, groups[g][0][0]))
            out[g] = (x0 + lo, x0 + hi)
        else:
            out[g] = (lo, hi)
    return out


class SignalFaults:
    """Per-row state and application of a perturbation's per-step signal faults.

    Each active row draws, at each step and in this order, ``rng.random(k)`` for the
    dropped/stuck entries (action entries of each enabled action fault, then observation
    entries of each enabled observation fault) and ``rng.standard_normal(g)`` for the noisy
    entries (actions, then observations), whatever its faults' state, so the draws per step
    are fixed. A fault starts on an entry where the draw is below ``prob`` and no fault of
    that kind is running, and lasts ``steps`` steps (the current one included).

    Args:
        pert: the perturbation.
        num: rows N.
        action_dim, obs_dim: entries of an action and an observation.
    """

    def __init__(self, pert: Perturbation, num: int, action_dim: int, obs_dim: int) -> None:
        self.pert = pert
        N, da, do = num, action_dim, obs_dim
        self._fa = [(f, pert_f) for f in ("action_dropped", "action_stuck")
                    if (pert_f := getattr(pert, f))[0] > 0]
        self._fo = [(f, pert_f) for f in ("obs_dropped", "obs_stuck")
                    if (pert_f := getattr(pert, f))[0] > 0]
        self.n_uniform = da * len(self._fa) + do * len(self._fo)
        self.n_normal = (da if pert.action_noise > 0 else 0) + (do if pert.obs_noise > 0 else 0)
        self.da, self.do = da, do
        self.U = np.zeros((N, self.n_uniform))
        self.G = np.zeros((N, self.n_normal))
        #: remaining steps of each fault per entry, by field name
        self.count = {f: np.zeros((N, da if f.startswith("action") else do), dtype=np.int64)
                      for f, _ in self._fa + self._fo}
        self.held = {f: np.zeros((N, da if f.startswith("action") else do))
                     for f, _ in self._fa + self._fo if f.endswith("stuck")}
        self.last_action = np.zeros((N, da))
        self.last_obs = np.zeros((N, do), dtype=np.float32)
        self._out = np.zeros((N, da))

    def reset_rows(self, idx: np.ndarray, obs: np.ndarray) -> None:
        """Rows ``idx`` start an episode: no fault running, no action yet, their
        observation ``obs`` the last delivered one."""
        for c in self.count.values():
            c[idx] = 0
        self.last_action[idx] = 0.0
        self.last_obs[idx] = obs[idx]

    def draw(self, rows: np.ndarray, rngs: Any) -> None:
        """This step's draws of rows ``rows`` (class docstring)."""
        for i in rows:
            rng = rngs[i]
            if self.n_uniform:
                self.U[i] = rng.random(self.n_uniform)
            if self.n_normal:
                self.G[i] = rng.standard_normal(self.n_normal)

    def _apply(self, fields: list, values: np.ndarray, last: np.ndarray, rows: np.ndarray,
               offset: int) -> int:
        width = values.shape[1]
        for f, (p, k) in fields:
            u = self.U[rows, offset:offset + width]
            offset += width
            c = self.count[f]
            cr = c[rows]
            start = (cr == 0) & (u < p)
            if f.endswith("stuck"):
                h = self.held[f]
                hr = h[rows]
                hr[start] = last[rows][start]
                h[rows] = hr
            cr[start] = k
            on = cr > 0
            vr = values[rows]
            if f.endswith("stuck"):
                vr[on] = self.held[f][rows][on]
            else:
                vr[on] = 0.0
            values[rows] = vr
            cr[on] -= 1
            c[rows] = cr
        return offset

    def actions(self, a: np.ndarray, rows: np.ndarray) -> np.ndarray:
        """The actions ``a (N, d)`` as delivered (a new array): noise, then drops, then stuck
        entries, on rows ``rows`` (the others unchanged)."""
        out = self._out
        np.copyto(out, a)
        if self.pert.action_noise > 0:
            out[rows] += self.pert.action_noise * self.G[rows, :self.da]
            np.clip(out, -1.0, 1.0, out=out)
        self._apply(self._fa, out, self.last_action, rows, 0)
        self.last_action[rows] = out[rows]
        return out

    def observations(self, obs: np.ndarray, rows: np.ndarray, low: np.ndarray,
                     high: np.ndarray) -> None:
        """The observations ``obs (N, D)`` as delivered, in place: relative noise (clipped to
        ``low``, ``high``), then drops, then stuck entries, on rows ``rows``."""
        if self.pert.obs_noise > 0:
            g0 = self.da if self.pert.action_noise > 0 else 0
            o = obs[rows].astype(np.float64)
            o += self.pert.obs_noise * np.abs(o) * self.G[rows, g0:g0 + self.do]
            obs[rows] = np.clip(o, low, high)
        self._apply(self._fo, obs, self.last_obs, rows, self.da * len(self._fa))
        self.last_obs[rows] = obs[rows]
