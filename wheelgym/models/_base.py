"""Shared machinery of every wheelgym model: frozen parameters and the batched model API.

Every model is a thin Python object around compiled per-state functions. The Python layer
only reshapes ``(..., n)`` inputs to 2-D ``(N, n)`` batches, checks them once per call, and
dispatches to a serial kernel (small N) or a ``prange`` kernel (large N). Both kernels inline
the same per-state derivative, so a single state and a batch of 16384 run the same code and
give the same bits.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping
from typing import Any, ClassVar

import numpy as np

from wheelgym.integrators import check_substeps

__all__ = ["Params", "Model", "PARALLEL_MIN_BATCH"]

#: Batches at least this large use the multi-threaded kernel.
PARALLEL_MIN_BATCH = 512


@dataclasses.dataclass(frozen=True)
class Params:
    """Base of the frozen parameter dataclasses.

    Subclasses list field names in ``_positive`` (must be > 0) and ``_nonnegative`` (>= 0);
    every numeric field must be finite. Subclasses add their own checks in ``_check``.
    Construction with an unknown keyword raises ``TypeError`` (a dataclass does that itself;
    :meth:`from_dict` and :meth:`replace` also list the valid names).
    """

    _positive: ClassVar[tuple[str, ...]] = ()
    _nonnegative: ClassVar[tuple[str, ...]] = ()

    def __post_init__(self) -> None:
        for f in dataclasses.fields(self):
            value = getattr(self, f.name)
            arr = np.asarray(value)
            if arr.dtype == object or not np.issubdtype(arr.dtype, np.number):
                raise TypeError(
                    f"{type(self).__name__}.{f.name} must be numeric, got {value!r}"
                )
            if not np.all(np.isfinite(arr)):
                raise ValueError(f"{type(self).__name__}.{f.name} must be finite, got {value!r}")
        for name in self._positive:
            if not getattr(self, name) > 0:
                raise ValueError(
                    f"{type(self).__name__}.{name} must be > 0, got {getattr(self, name)!r}"
                )
        for name in self._nonnegative:
            if not getattr(self, name) >= 0:
                raise ValueError(
                    f"{type(self).__name__}.{name} must be >= 0, got {getattr(self, name)!r}"
                )
        self._check()

    def _check(self) -> None:
        """Model-specific checks; raise ``ValueError`` naming the field."""

    @classmethod
    def field_names(cls) -> tuple[str, ...]:
        return tuple(f.name for f in dataclasses.fields(cls))

    @classmethod
    def _check_names(cls, names) -> None:
        valid = cls.field_names()
        unknown = sorted(set(names) - set(valid))
        if unknown:
            raise TypeError(
                f"unknown {cls.__name__} parameter(s) {unknown}; valid names: {list(valid)}"
            )

    @classmethod
    def from_dict(cls, values: Mapping[str, Any] | None = None, **overrides: Any):
        """Build from a mapping (e.g. a YAML section) plus keyword overrides."""
        merged = {**dict(values or {}), **overrides}
        cls._check_names(merged)
        return cls(**{k: _freeze(v) for k, v in merged.items()})

    def replace(self, **changes: Any):
        """A copy with some fields changed (validated like a new instance)."""
        self._check_names(changes)
        return dataclasses.replace(self, **{k: _freeze(v) for k, v in changes.items()})

    def to_dict(self) -> dict[str, Any]:
        return {f.name: getattr(self, f.name) for f in dataclasses.fields(self)}

    def pack(self) -> np.ndarray:
        """Flat float64 array in the layout the compiled kernels read."""
        raise NotImplementedError


def _freeze(value: Any) -> Any:
    """Lists (from YAML) become tuples so frozen dataclasses stay hashable."""
    if isinstance(value, (list, np.ndarray)):
        return tuple(_freeze(v) for v in value)
    return value


class Model:
    """Batched model API shared by all robots.

    Subclasses set the class attributes below and the compiled kernels
    ``_k_deriv(X, U, p, out)``, ``_k_step(X, U, p, h, n, out) -> bool`` and
    ``_k_step_par(...)`` (the same with ``prange``); the step kernels return ``False`` when an
    input is not finite, before integrating anything.

    Attributes:
        state_names: names of the state entries, in order.
        input_names: names of the input entries (motor order of physics.md).
        params_type: the frozen parameter dataclass.
        default_sim_dt: physics substep (s) inside RK4's stability region at the defaults.
        default_ctrl_dt: control period (s).
    """

    state_names: ClassVar[tuple[str, ...]] = ()
    input_names: ClassVar[tuple[str, ...]] = ()
    params_type: ClassVar[type[Params]] = Params
    default_sim_dt: ClassVar[float] = 0.002
    default_ctrl_dt: ClassVar[float] = 0.05

    _k_deriv: ClassVar[Any]
    _k_step: ClassVar[Any]
    _k_step_par: ClassVar[Any]

    def __init__(self, params: Params | Mapping[str, Any] | None = None, **overrides: Any):
        if params is None:
            params = self.params_type.from_dict(overrides)
        elif isinstance(params, Mapping):
            params = self.params_type.from_dict(params, **overrides)
        elif isinstance(params, self.params_type):
            if overrides:
                params = params.replace(**overrides)
        else:
            raise TypeError(
                f"params must be a {self.params_type.__name__}, a mapping or None, "
                f"got {type(params).__name__}"
            )
        self.params = params
        self._p = params.pack()

    # ------------------------------------------------------------------ sizes and names
    @property
    def state_dim(self) -> int:
        return len(self.state_names)

    @property
    def input_dim(self) -> int:
        return len(self.input_names)

    def __repr__(self) -> str:
        return f"{type(self).__name__}({self.params!r})"

    # ------------------------------------------------------------------ batching helpers
    def _as_batch(self, a: Any, width: int, name: str) -> np.ndarray:
        arr = np.asarray(a, dtype=np.float64)
        if arr.ndim == 0 or arr.shape[-1] != width:
            raise ValueError(
                f"{name} must have shape (..., {width}) for {type(self).__name__}, "
                f"got {arr.shape}"
            )
        return arr

    def _prepare(self, x: Any, u: Any) -> tuple[np.ndarray, np.ndarray, tuple[int, ...]]:
        """Return C-contiguous 2-D ``X``, ``U`` with a common leading shape."""
        X = self._as_batch(x, self.state_dim, "x")
        U = self._as_batch(u, self.input_dim, "u")
        if X.shape[:-1] != U.shape[:-1]:
            lead = np.broadcast_shapes(X.shape[:-1], U.shape[:-1])
            X = np.broadcast_to(X, lead + X.shape[-1:])
            U = np.broadcast_to(U, lead + U.shape[-1:])
        lead = X.shape[:-1]
        X2 = np.ascontiguousarray(X.reshape(-1, self.state_dim))
        U2 = np.ascontiguousarray(U.reshape(-1, self.input_dim))
        return X2, U2, lead

    # ------------------------------------------------------------------ public API
    def derivative(self, x: Any, u: Any) -> np.ndarray:
        """State derivative ``xdot = f(x, u)``; ``(..., n)`` in, ``(..., n)`` out."""
        X, U, lead = self._prepare(x, u)
        out = np.empty_like(X)
        type(self)._k_deriv(X, U, self._p, out)
        return out.reshape(lead + (self.state_dim,))

    def step(self, x: Any, u: Any, dt: float, n_substeps: int = 1) -> np.ndarray:
        """Advance by ``dt`` with RK4 over ``n_substeps`` substeps, ``u`` held constant.

        Args:
            x: state ``(..., n)``.
            u: input ``(..., m)`` (broadcast against ``x``'s leading shape).
            dt: time to advance (s), positive and finite.
            n_substeps: RK4 substeps of ``dt / n_substeps`` each.

        Returns:
            The new state, same leading shape as the inputs.

        Raises:
            ValueError: on a non-finite state or input, a bad ``dt``, or wrong shapes.
        """
        n = check_substeps(n_substeps)
        if not (isinstance(dt, (int, float, np.floating)) and math.isfinite(dt) and dt > 0):
            raise ValueError(f"dt must be a positive finite number of seconds, got {dt!r}")
        X, U, lead = self._prepare(x, u)
        out = np.empty_like(X)
        kernel = type(self)._k_step_par if X.shape[0] >= PARALLEL_MIN_BATCH else type(self)._k_step
        if not kernel(X, U, self._p, float(dt) / n, n, out):
            bad = "x" if not np.all(np.isfinite(X)) else "u"
            raise ValueError(f"{bad} passed to {type(self).__name__}.step is not finite")
        return out.reshape(lead + (self.state_dim,))

    def n_substeps(self, ctrl_dt: float | None = None, sim_dt: float | None = None) -> int:
        """Substeps per control step for this model's (or the given) time steps."""
        from wheelgym.integrators import n_substeps

        return n_substeps(
            self.default_ctrl_dt if ctrl_dt is None else ctrl_dt,
            self.default_sim_dt if sim_dt is None else sim_dt,
        )
