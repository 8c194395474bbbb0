"""Shared machinery of every wheelgym model: frozen parameters and the batched model API.

Every model is a thin Python object around compiled per-state functions. The Python layer
only reshapes ``(..., n)`` inputs to 2-D ``(N, n)`` batches, checks them once per call, and
dispatches to a serial kernel (small N) or a ``prange`` kernel (large N). Both kernels inline
the same per-state derivative, so a single state and a batch of 16384 run the same code and
give the same bits.

A single 1-D float64 state takes a fast path: a kernel of one fixed signature, compiled on its
first call (``_k_step1`` / ``_k_deriv1``, see :data:`wheelgym.integrators.STEP1_SIG`), checks
shapes and finiteness inside the compiled code and reports a status code; numba's own type dispatch
rejects anything else (lists, other dtypes, strided or read-only arrays) with ``TypeError``,
and such calls take the general path.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping
from typing import Any, ClassVar

import numpy as np

from wheelgym import integrators as _itg
from wheelgym.integrators import check_substeps

__all__ = ["Params", "Model", "PARALLEL_MIN_BATCH", "LENGTH", "SIGNED_LENGTH", "MASS",
           "INERTIA", "TORQUE", "GRAVITY", "SMOOTHING", "COEFFICIENT", "DAMPING", "SPEED",
           "RATE"]

# Physical bounds of the parameters (closed intervals; ``Params._bounds`` maps a field to one,
# applied to every entry of a tuple field). Wide enough for any wheeled robot from a toy to a
# truck, narrow enough that no accepted value overflows or underflows the dynamics (a radius
# of 1e30 m or a wheelbase of 1e-30 m gave infinite observations).
#: Lengths (m): 1 mm to 100 m.
LENGTH = (1e-3, 1e2, "m")
#: Signed positions in the body frame (m).
SIGNED_LENGTH = (-1e2, 1e2, "m")
#: Masses (kg): 1 g to 100 t.
MASS = (1e-3, 1e5, "kg")
#: Moments of inertia (kg m²): a 1 g, 1 mm wheel to a 100 t, 10 m body.
INERTIA = (1e-9, 1e7, "kg m²")
#: Motor torque limits (N·m).
TORQUE = (1e-3, 1e4, "N·m")
#: Gravity (m/s²): a small moon to 10 g.
GRAVITY = (0.1, 1e2, "m/s²")
#: Arctan smoothing gain of the friction sign (s/m).
SMOOTHING = (1e-2, 1e5, "s/m")
#: Dimensionless friction coefficients.
COEFFICIENT = (0.0, 10.0, "-")
#: Viscous joint friction (N·m·s/rad).
DAMPING = (0.0, 1e3, "N·m·s/rad")
#: Speed limits (m/s).
SPEED = (-1e2, 1e2, "m/s")
#: Angular-rate limits (rad/s).
RATE = (-1e4, 1e4, "rad/s")

#: Batches at least this large use the multi-threaded kernel.
PARALLEL_MIN_BATCH = 512


@dataclasses.dataclass(frozen=True)
class Params:
    """Base of the frozen parameter dataclasses.

    Subclasses list field names in ``_positive`` (must be > 0) and ``_nonnegative`` (>= 0);
    every numeric field must be finite and, where ``_bounds`` names it, within its physical
    bounds (``(low, high, unit)``, e.g. :data:`LENGTH`; every entry of a tuple field).
    String fields list their valid values in ``_choices``.
    Subclasses add their own checks in ``_check``.
    Construction with an unknown keyword raises ``TypeError`` (a dataclass does that itself;
    :meth:`from_dict` and :meth:`replace` also list the valid names).
    """

    _positive: ClassVar[tuple[str, ...]] = ()
    _nonnegative: ClassVar[tuple[str, ...]] = ()
    _bounds: ClassVar[Mapping[str, tuple[float, float, str]]] = {}
    #: String fields and their valid values (e.g. ``motor``: ``("ideal", "dc", ...)``).
    _choices: ClassVar[Mapping[str, tuple[str, ...]]] = {}

    def __post_init__(self) -> None:
        for f in dataclasses.fields(self):
            value = getattr(self, f.name)
            if f.name in self._choices:
                if value not in self._choices[f.name]:
                    raise ValueError(
                        f"{type(self).__name__}.{f.name} must be one of "
                        f"{list(self._choices[f.name])}, got {value!r}"
                    )
                continue
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
        for name, (lo, hi, unit) in self._bounds.items():
            value = getattr(self, name)
            if isinstance(value, (float, int)):  # (the common case, without NumPy: resets
                ok = lo <= value <= hi           # with randomize build a set per draw)
            else:
                arr = np.asarray(value, dtype=np.float64)
                ok = bool(np.all(arr >= lo) and np.all(arr <= hi))
            if not ok:
                raise ValueError(
                    f"{type(self).__name__}.{name} must be within the physical bounds "
                    f"[{lo:g}, {hi:g}] {unit}, got {value!r}"
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


_ndarray = np.ndarray
_F64 = np.dtype(np.float64)


class Model:
    """Batched model API shared by all robots.

    Subclasses set the class attributes below and the compiled kernels
    ``_k_deriv(X, U, p, out)``, ``_k_step(X, U, p, h, n, out) -> bool`` and
    ``_k_step_par(...)`` (the same with ``prange``), usually from the
    :class:`~wheelgym.integrators.ModelKernels` of their kernel module; the step kernels return
    ``False`` when an input is not finite, before integrating anything. Optionally (for speed on
    one state) ``_k_step1`` and ``_k_deriv1``, of the one signature
    :data:`~wheelgym.integrators.STEP1_SIG` / :data:`~wheelgym.integrators.DERIV1_SIG` each
    (compiled on first use, :func:`~wheelgym.integrators.first_call`), that return a
    ``STATUS_*`` code of :mod:`wheelgym.integrators`.

    Models opt into the checks of :mod:`wheelgym.validate` by providing ``stiffness()``
    (stability margin), ``kinetic_energy``/``motor_power``/``friction_power`` (energy balance)
    and ``friction_params`` (the parameters that :meth:`frictionless` sets to zero); optional
    ``input_high`` (input limits), ``validation_state()`` and ``validation_manoeuvre(t)``
    replace the validation's generic start state and inputs.

    Attributes:
        state_names: names of the state entries, in order.
        input_names: names of the input entries (motor order of docs/physics/index.md).
        params_type: the frozen parameter dataclass.
        default_sim_dt: physics substep (s) inside RK4's stability region at the defaults.
        default_ctrl_dt: control period (s).
        friction_params: parameter names whose zero switches all friction off.
    """

    state_names: ClassVar[tuple[str, ...]] = ()
    input_names: ClassVar[tuple[str, ...]] = ()
    params_type: ClassVar[type[Params]] = Params
    default_sim_dt: ClassVar[float] = 0.002
    #: The one default control period of wheelgym (controllers and envs read it from here).
    default_ctrl_dt: ClassVar[float] = 0.05
    friction_params: ClassVar[tuple[str, ...]] = ()

    _k_deriv: ClassVar[Any]
    _k_step: ClassVar[Any]
    _k_step_par: ClassVar[Any]
    _k_step1: ClassVar[Any] = None
    _k_deriv1: ClassVar[Any] = None

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
        # Instance attributes (not class lookups: a numba dispatcher found on the class would
        # bind as a method) for the single-state fast path.
        cls = type(self)
        self._step1 = cls._k_step1
        self._deriv1 = cls._k_deriv1
        self._kd = getattr(cls, "_k_deriv", None)
        self._ks = getattr(cls, "_k_step", None)
        self._ksp = getattr(cls, "_k_step_par", None)
        self._bind_kernels()
        self._nx = len(cls.state_names)

    def _bind_kernels(self) -> None:
        """Hook: replace the instance's kernels (``_kd``, ``_ks``, ``_ksp``, ``_step1``,
        ``_deriv1``) by another compiled set for these parameters (the DC-motor models)."""

    # ------------------------------------------------------------------ sizes and names
    @property
    def state_dim(self) -> int:
        return len(self.state_names)

    @property
    def input_dim(self) -> int:
        return len(self.input_names)

    @property
    def packed(self) -> np.ndarray:
        """The packed parameter array the compiled kernels read (``params.pack()``, with the
        input mode for the kinematic models), indexed by the ``P_*`` names of the model's
        :mod:`wheelgym.models.kernels` module. The model's own array: do not modify it."""
        return self._p

    def __repr__(self) -> str:
        return f"{type(self).__name__}({self.params!r})"

    def frictionless(self) -> Model:
        """The same model with every parameter in :attr:`friction_params` set to zero."""
        if not self.friction_params:
            raise NotImplementedError(f"{type(self).__name__} lists no friction_params")
        return type(self)(self.params.replace(**{k: 0.0 for k in self.friction_params}))

    # ------------------------------------------------------------------ batching helpers
    def _as_batch(self, a: Any, width: int, name: str) -> np.ndarray:
        try:
            arr = np.asarray(a, dtype=np.float64)
        except (TypeError, ValueError) as exc:
            raise TypeError(
                f"{name} must be an array of numbers of shape (..., {width}) for "
                f"{type(self).__name__}, got {type(a).__name__}"
            ) from exc
        if arr.ndim == 0 or arr.shape[-1] != width:
            raise ValueError(
                f"{name} must have shape (..., {width}) for {type(self).__name__}, "
                f"got {arr.shape}"
            )
        return arr

    def _prepare(self, x: Any, u: Any) -> tuple[np.ndarray, np.ndarray, tuple[int, ...]]:
        """Return C-contiguous 2-D ``X``, ``U`` with a common leading shape.

        Raises:
            ValueError: wrong trailing sizes, or leading shapes that do not broadcast.
        """
        X = self._as_batch(x, self.state_dim, "x")
        U = self._as_batch(u, self.input_dim, "u")
        if X.shape[:-1] != U.shape[:-1]:
            try:
                lead = np.broadcast_shapes(X.shape[:-1], U.shape[:-1])
            except ValueError:
                raise ValueError(
                    f"the leading shapes of x {X.shape} and u {U.shape} do not broadcast"
                ) from None
            X = np.broadcast_to(X, lead + X.shape[-1:])
            U = np.broadcast_to(U, lead + U.shape[-1:])
        lead = X.shape[:-1]
        X2 = _itg.kernel_array(X.reshape(-1, self.state_dim))
        U2 = _itg.kernel_array(U.reshape(-1, self.input_dim))
        return X2, U2, lead

    def _raise_status(self, status: int, method: str, x: Any, u: Any, dt: Any = None) -> None:
        name = f"{type(self).__name__}.{method}"
        if status == _itg.STATUS_X_SHAPE:
            raise ValueError(
                f"x must have shape (..., {self.state_dim}) for {name}, got {np.shape(x)}"
            )
        if status == _itg.STATUS_U_SHAPE:
            raise ValueError(
                f"u must have shape (..., {self.input_dim}) for {name}, got {np.shape(u)}"
            )
        if status == _itg.STATUS_X_NONFINITE:
            raise ValueError(f"x passed to {name} is not finite: {x!r}")
        if status == _itg.STATUS_U_NONFINITE:
            raise ValueError(f"u passed to {name} is not finite: {u!r}")
        if status == _itg.STATUS_BAD_DT:
            raise ValueError(f"dt must be a positive finite number of seconds, got {dt!r}")
        if status == _itg.STATUS_BAD_N:
            raise ValueError("n_substeps must be >= 1")
        if status == _itg.STATUS_DIVERGED:
            raise FloatingPointError(
                f"{name} produced a non-finite state from finite input (dt={dt!r}); "
                f"the substep is outside RK4's stability region or the state overflowed"
            )
        raise RuntimeError(f"{name}: unknown kernel status {status}")  # pragma: no cover

    # ------------------------------------------------------------------ public API
    def derivative(self, x: Any, u: Any) -> np.ndarray:
        """State derivative ``xdot = f(x, u)``; ``(..., n)`` in, ``(..., n)`` out.

        Raises:
            ValueError: on wrong shapes or a non-finite state or input.
        """
        if self._deriv1 is not None and type(x) is _ndarray and x.ndim == 1:
            out = np.empty(self._nx)
            try:
                status = self._deriv1(x, u, self._p, out)
            except TypeError:  # not compiled yet, or not 1-D float64 arrays (then None)
                status = _itg.first_call(self._deriv1, x, u, self._p, out)
            if status is not None:
                if status == 0:
                    return out
                self._raise_status(status, "derivative", x, u)
        X, U, lead = self._prepare(x, u)
        out = np.empty_like(X)
        self._kd(X, U, self._p, out)
        if not np.isfinite(out).all():
            for name, arr in (("x", X), ("u", U)):
                if not np.isfinite(arr).all():
                    raise ValueError(
                        f"{name} passed to {type(self).__name__}.derivative is not finite"
                    )
            raise FloatingPointError(  # pragma: no cover - finite input overflowed
                f"{type(self).__name__}.derivative produced a non-finite value"
            )
        return out.reshape(lead + (self.state_dim,))

    def step(self, x: Any, u: Any, dt: float, n_substeps: int = 1) -> np.ndarray:
        """Advance by ``dt`` with RK4 over ``n_substeps`` substeps, ``u`` held constant.

        Args:
            x: state ``(..., n)``.
            u: input ``(..., m)`` (broadcast against ``x``'s leading shape).
            dt: time to advance (s), positive and finite.
            n_substeps: RK4 substeps of ``dt / n_substeps`` each.

        Returns:
            The new state (a new array), same leading shape as the inputs.

        Raises:
            ValueError: on a non-finite state or input, a bad ``dt``, or wrong shapes.
            TypeError: if ``n_substeps`` is not an int, or ``x``/``u`` are not numeric.
            FloatingPointError: if finite input produced a non-finite state (a ``dt``
                far outside the stability region).
        """
        # Fast path: one float64 state (the single-env case). Everything else is checked in
        # the compiled kernel; numba's dispatch raises TypeError for other argument types.
        if type(x) is _ndarray and x.ndim == 1 and type(n_substeps) is int:
            if self._step1 is not None:
                out = x.copy()
                try:
                    status = self._step1(out, u, self._p, dt, n_substeps)
                except TypeError:  # not compiled yet, or other argument types (then None)
                    status = _itg.first_call(self._step1, out, u, self._p, dt, n_substeps)
                if status is not None:
                    if status == 0:
                        return out
                    self._raise_status(status, "step", x, u, dt)
            elif (
                type(u) is _ndarray
                and type(dt) is float
                and 0.0 < dt < math.inf
                and n_substeps >= 1
                and x.dtype is _F64
                and u.dtype is _F64
                and x.shape[0] == self._nx
                and u.ndim == 1
                and u.shape[0] == len(self.input_names)
                and x.flags.c_contiguous
                and u.flags.c_contiguous
                and x.flags.writeable  # read-only arrays: a kernel signature of their own
                and u.flags.writeable
            ):
                # A model without ``_k_step1``: its serial batch kernel on a (1, n) view.
                out = np.empty((1, self._nx))
                if self._ks(
                    x.reshape(1, -1), u.reshape(1, -1), self._p, dt / n_substeps, n_substeps, out
                ):
                    if _itg.all_finite(out):
                        return out[0]
                    self._raise_status(_itg.STATUS_DIVERGED, "step", x, u, dt)
                # non-finite input: the general path names it
        return self._step_general(x, u, dt, n_substeps)

    def _step_general(self, x: Any, u: Any, dt: float, n_substeps: int) -> np.ndarray:
        n = check_substeps(n_substeps)
        if isinstance(dt, bool) or not isinstance(dt, (int, float, np.integer, np.floating)):
            raise TypeError(f"dt must be a number of seconds, got {type(dt).__name__}")
        if not (math.isfinite(dt) and dt > 0):
            raise ValueError(f"dt must be a positive finite number of seconds, got {dt!r}")
        X, U, lead = self._prepare(x, u)
        out = np.empty_like(X)
        kernel = self._ksp if X.shape[0] >= PARALLEL_MIN_BATCH else self._ks
        if not kernel(X, U, self._p, float(dt) / n, n, out):
            bad = "x" if not np.isfinite(X).all() else "u"
            raise ValueError(f"{bad} passed to {type(self).__name__}.step is not finite")
        if not _itg.all_finite(out):
            self._raise_status(_itg.STATUS_DIVERGED, "step", x, u, dt)
        return out.reshape(lead + (self.state_dim,))

    def n_substeps(self, ctrl_dt: float | None = None, sim_dt: float | None = None) -> int:
        """Substeps per control step for this model's (or the given) time steps.

        Raises:
            ValueError: if ``ctrl_dt`` is not a whole multiple of ``sim_dt``, or either is not
                a positive finite number.
        """
        return _itg.n_substeps(
            self.default_ctrl_dt if ctrl_dt is None else ctrl_dt,
            self.default_sim_dt if sim_dt is None else sim_dt,
        )
