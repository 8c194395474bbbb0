"""What an environment needs to know about a robot, beyond its model (one object per robot)."""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Mapping
from typing import Any

import numpy as np

from wheelgym import _numba_cache
from wheelgym.integrators import LANES
from wheelgym.models import Model, Params

__all__ = ["RobotSpec", "RANDOMIZE_GROUPS", "VOLTAGE_MODE"]

#: A first compile of at least this many seconds (``RobotSpec.compile_s``) prints a notice.
NOTICE_MIN_S = 3.0

#: Randomisation groups accepted by ``randomize=``; each robot supports a subset.
RANDOMIZE_GROUPS = (
    "mass", "inertia", "friction", "x_icr", "wheel_radius", "caster_trail", "torque_limit",
    "motor",
)

#: The action mode of the DC motors' terminal voltages (:attr:`RobotSpec.dc_action_modes`):
#: action ``a_k`` in [-1, 1] applies ``a_k V_s`` (V) to motor k, the model's
#: ``motor="dc_voltage"`` input.
VOLTAGE_MODE = "voltage"


@dataclasses.dataclass(frozen=True)
class RobotSpec:
    """Static description of one robot for the environments.

    Attributes:
        name: robot name used in ids (``"SkidSteer"``...).
        model_cls: the :class:`~wheelgym.models.Model` subclass.
        k_env_step: compiled ``k_env_step(X, A, LH, P, h, n, Xo, B, F) -> bool`` (see
            ``body.env_step_body``), a row at a time, for any batch size.
        k_env_blocks, k_env_blocks_dc: the same step (ideal, DC motors) in the model's
            vectorised blocks of ``LANES`` robots (``body.env_step_blocks``, the same bits per
            row), used from ``LANES`` rows (:meth:`serial_kernel`); None where the model has
            no block kernel. A separate kernel, so that a single env never compiles it.
        k_env_step_par: the same kernel with the rows (or blocks) spread over numba's
            threads (``parallel=True``; same bits per row), used from ``body.PAR_MIN_ROWS``
            rows.
        input_bounds: ``input_bounds(params, mode) -> (lo, hi)`` physical bounds of the
            action in that action mode (torques N·m, or the kinematic inputs; the
            ``"voltage"`` mode's ``+-V_s`` come from :meth:`action_bounds` itself).
        action_modes: the ``action_mode`` values valid with either motor model, the default
            first (the robots with DC motors add :attr:`dc_action_modes`; every valid value:
            :attr:`all_action_modes`).
        twist_dim: 3 (vx, vy, wz) or 2 (vx, wz) for the velocity mode's command.
        twist_max: bounds of the velocity-mode command in its units (m/s, rad/s).
        v_max, w_max: sanity limits (m/s, rad/s): beyond them an episode ends (``overspeed``).
        feat_names, feat_high: names and bounds of the robot's extra observation features.
        radius: collision radius of the footprint (m).
        randomize: group -> tuple of (field, "rel" | "abs") entries.
        default_randomize: ranges used by ``randomize=True``.
        initial_state: ``initial_state(pose (N, 3), params) -> X (N, n_x)``.
        k_env_step_dc, k_env_step_par_dc: the same two kernels with DC motors (``motor="dc"``:
            the model's ``deriv_one_dc``, ``power_t_dc``, ``dc_kernels().block``; compiled on
            first use); None for the kinematic robots.
        n_motor: motors (0 for kinematic robots: no torque, no energy).
        has_internal_force: whether ``xf`` (the internal-force measure) is meaningful.
        geometry: ``geometry(params) -> dict`` for rendering (footprint, wheel size).
        wheels: ``wheels(x, params) -> (k, 3)`` wheel centres (m, in B) and angles (rad, in B).
        motor_names: names of the motors in input order (``n_motor`` of them; empty for
            kinematic robots), for plots and tables.
        twist_modes: action modes whose action is a body twist (``twist_dim`` entries scaled
            by ``twist_max``) tracked by :class:`wheelgym.control.TwistController`
            (``("velocity",)`` for the dynamic robots; none for the kinematic ones, whose
            modes are their model's input modes).
        holonomic: the robot can move sideways: the analytic baseline commands ``(vx, vy,
            wz)`` of the centre of mass directly (else it steers the ``x_icr`` point).
        turns_in_place: the robot can turn without moving (False for car-like robots: the
            baseline plans a Reeds-Shepp path on ``goal``).
        baseline_controllers: the analytic baseline drives the torque mode through
            ``wheelgym.control``'s TwistController and TrackingController (else through a
            proportional twist loop on the wheel torques, or the kinematic inputs).
        n_steer_motor: the last ``n_steer_motor`` motors steer wheels 0, 1, ...; the others
            drive wheels 0, 1, ... (the renderer's torque arrows).
        compile_s: measured seconds of the first compile (``benchmarks/coldstart.py``, on
            the 2-core development machine) of the single env's kernels (``"step"``: the
            slowest action mode and task), of its DC-motor kernels (``"dc"``) and of the
            block and threaded kernels of the vector env (``"blocks"``); those of 3 s or more
            print a notice when their compile starts (``_numba_cache.announce``).
        stiffness_probe: configurations (the model's ``stiffness`` argument, e.g. steering
            angles) at which the ``randomize`` extremes' RK4 stiffness is evaluated, scaled by
            full/probe at the nominal parameters (cheaper than the full grid); None: the
            model's ``stiffness()`` itself.
    """

    name: str
    model_cls: type[Model]
    k_env_step: Any
    k_env_step_par: Any
    input_bounds: Callable[[Params, str], tuple[np.ndarray, np.ndarray]]
    action_modes: tuple[str, ...]
    twist_dim: int
    twist_max: tuple[float, ...]
    v_max: float
    w_max: float
    feat_names: tuple[str, ...]
    feat_high: tuple[float, ...]
    radius: float
    randomize: Mapping[str, tuple[tuple[str, str], ...]]
    default_randomize: Mapping[str, tuple[float, float]]
    initial_state: Callable[[np.ndarray, Params], np.ndarray]
    n_motor: int
    has_internal_force: bool
    geometry: Callable[[Params], dict]
    wheels: Callable[[np.ndarray, Params], np.ndarray]
    motor_names: tuple[str, ...] = ()
    twist_modes: tuple[str, ...] = ("velocity",)
    holonomic: bool = False
    turns_in_place: bool = True
    baseline_controllers: bool = False
    n_steer_motor: int = 0
    stiffness_probe: tuple[tuple[float, ...], ...] | None = None
    k_env_step_dc: Any = None
    k_env_step_par_dc: Any = None
    k_env_blocks: Any = None
    k_env_blocks_dc: Any = None
    compile_s: Mapping[str, float] = dataclasses.field(default_factory=dict)

    def __post_init__(self) -> None:
        c = self.compile_s
        # the kinematic robots share one step kernel (its notice names them all)
        who = "the kinematic robots'" if self.kinematic else f"the {self.name}"
        for key, what, kernels in (
                ("step", f"{who} kernels", (self.k_env_step,)),
                ("dc", f"the {self.name} DC-motor kernels", (self.k_env_step_dc,)),
                ("blocks", f"the {self.name} vector-env kernels",
                 (self.k_env_blocks, self.k_env_blocks_dc, self.k_env_step_par,
                  self.k_env_step_par_dc))):
            if c.get(key, 0.0) >= NOTICE_MIN_S:
                _numba_cache.announce(what, c[key], *kernels)

    # ------------------------------------------------------------------ derived
    @property
    def kinematic(self) -> bool:
        """No motors: the action is the model's velocity input in the chosen input mode (no
        torque, no energy, no RK4 stiffness)."""
        return self.n_motor == 0

    def make_model(self, params: Mapping[str, Any] | Params | None, mode: str) -> Model:
        """The model with ``params`` (overrides or a Params instance) for action ``mode``
        (the kinematic models take the mode as their input mode)."""
        if self.kinematic:
            return self.model_cls(params, input_mode=mode)
        return self.model_cls(params)

    @property
    def has_dc_motors(self) -> bool:
        """Whether the robot offers the DC motor model (``motor="dc"``)."""
        return self.k_env_step_dc is not None

    @property
    def dc_action_modes(self) -> tuple[str, ...]:
        """Action modes that command the DC motors themselves: ``("voltage",)``
        (:data:`VOLTAGE_MODE`) on the robots with the DC motor model, else none. They are
        valid ``action_mode`` values besides :attr:`action_modes` and imply ``motor="dc"``
        (the model's ``motor="dc_voltage"``: the DC env kernels with the voltage mode code).
        Kept out of ``action_modes``, whose every mode runs with the default ideal motors
        (the per-mode loops of the tests and benchmarks)."""
        return (VOLTAGE_MODE,) if self.has_dc_motors else ()

    @property
    def all_action_modes(self) -> tuple[str, ...]:
        """Every valid ``action_mode``: :attr:`action_modes` then :attr:`dc_action_modes`."""
        return self.action_modes + self.dc_action_modes

    def model_motor(self, motor: str, mode: str) -> str:
        """The model's ``motor`` parameter for the env keyword ``motor`` in action ``mode``:
        ``"dc_voltage"`` in a :attr:`dc_action_modes` mode (the input is the terminal
        voltage), else ``motor`` itself."""
        return "dc_voltage" if mode in self.dc_action_modes else motor

    def serial_kernel(self, dc: bool, rows: int) -> Any:
        """The serial env step kernel for a batch of ``rows``: the block kernel
        (:attr:`k_env_blocks`, ``dc``: :attr:`k_env_blocks_dc`) from ``LANES`` rows where the
        robot has one, else the row kernel (:attr:`k_env_step`, :attr:`k_env_step_dc`)."""
        blocks = self.k_env_blocks_dc if dc else self.k_env_blocks
        if blocks is not None and rows >= LANES:
            return blocks
        return self.k_env_step_dc if dc else self.k_env_step

    def step_kernels(self, dc: bool, rows: int = 1) -> tuple[Any, Any]:
        """``(serial, parallel)`` env step kernels for a batch of ``rows``: ideal motors or
        (``dc``) DC motors; the serial one is :meth:`serial_kernel`'s."""
        return self.serial_kernel(dc, rows), (self.k_env_step_par_dc if dc
                                               else self.k_env_step_par)

    def action_dim(self, mode: str) -> int:
        """Size of the normalised action in ``mode``."""
        if self.kinematic:
            return len(self.model_cls.input_modes[mode])
        return self.twist_dim if self.tracks_twist(mode) else self.n_motor

    def tracks_twist(self, mode: str) -> bool:
        """Whether ``mode``'s action is a twist tracked by the TwistController."""
        return mode in self.twist_modes

    def action_bounds(self, model: Model, mode: str) -> tuple[np.ndarray, np.ndarray]:
        """Physical ``(lo, hi)`` of the model's input that the action in ``mode`` scales onto,
        at the nominal model ``model``."""
        if self.kinematic:
            return model.input_bounds()
        return self._input_bounds(model.params, mode)

    def _input_bounds(self, params: Params, mode: str) -> tuple[np.ndarray, np.ndarray]:
        """``input_bounds(params, mode)``; in a :attr:`dc_action_modes` mode the terminal
        voltages ``-V_s .. V_s`` of each motor (V, ``params.motor_table()``)."""
        if mode in self.dc_action_modes:
            v = np.array(params.motor_table()["V_s"], dtype=np.float64)
            return -v, v
        return self.input_bounds(params, mode)

    def row_params(self, nominal: Model, params: Params, mode: str
                   ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """A row drawn with ``params``: its packed parameter array and ``(lo, hi)`` action
        bounds (the kinematic models scale onto the nominal model's ``action_bounds`` of the
        drawn one)."""
        if self.kinematic:
            mdl = self.make_model(params, mode)
            lo, hi = nominal.action_bounds(mdl)  # the commanding side's scale
            return mdl.packed, lo, hi
        lo, hi = self._input_bounds(params, mode)
        return params.pack(), lo, hi

    def check_randomize(self, model: Model, ranges: Mapping[str, tuple[float, float]]) -> None:
        """``ValueError`` for ranges that cannot change the motion (the kinematic models'
        ``check_randomize``; nothing for the others)."""
        if ranges and self.kinematic:
            model.check_randomize(dict(ranges))


def guard_cache(module_file: str, *deps: str) -> None:
    """Drop a robot module's numba cache when a file its kernels inline has changed.

    The robot kernels inline the model's derivative and ``body.env_step_body`` from other
    files (and link the models' compiled block kernels, which inline ``integrators.py``);
    see :mod:`wheelgym._numba_cache`. ``body.py`` and ``integrators.py`` are always
    dependencies.
    """
    import os

    from wheelgym import _numba_cache
    from wheelgym import integrators as _integrators

    body = os.path.join(os.path.dirname(os.path.abspath(module_file)), "body.py")
    _numba_cache.guard(module_file, body, _integrators.__file__, *deps)

