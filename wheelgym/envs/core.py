"""Batch-first engine of every wheelgym environment.

:class:`WheelCore` holds N robots in arrays with a leading axis N. The single
:class:`~wheelgym.envs.wheel_env.WheelEnv` is the core at N = 1; the vector environments are the
same core at N > 1. Every per-step operation is per row (compiled loops over rows, no matrix
product across the batch), and every random draw of row i comes from ``rngs[i]``, so row i of a
batch reset with generator ``G`` is bit for bit the single environment reset with ``G``.

Core API::

    core = WheelCore("ThreeWheel", num=N, task="goal", action_mode="torque", ...)
    core = WheelCore(EnvConfig("ThreeWheel", task="goal"), num=N)  # the same
    obs = core.reset(rows, rngs, options)  # rows: index array; rngs: N generators
    obs, reward, terminated, info = core.step(actions)  # actions (N, action_dim)

``obs`` is the core's float32 buffer ``(N, obs_dim)`` (copy what you keep); ``info`` is a dict
of per-row arrays (see :meth:`WheelCore.step`). The core never truncates: time limits belong to
the wrappers (``max_episode_steps``). The track task's reference never runs out: it is evaluated
in windows that move on with the episode (``horizon`` only sizes the first one of small
batches), so an episode of any length sees it move on.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any, NamedTuple

import numba
import numpy as np

from wheelgym.envs._dispatch import FasterKernel
from wheelgym.envs.actuator import k_delay, k_lag
from wheelgym.envs.config import MAX_CTRL_DT, MAX_SUBSTEPS, EnvConfig
from wheelgym.envs.perturbation import SignalFaults, resolve_scales
from wheelgym.envs.robots import RobotSpec, get_spec
from wheelgym.envs.robots.body import (
    F_COLL,
    F_OK,
    F_SAT,
    F_SUCC,
    F_TERM,
    PAR_MIN_ROWS,
    k_or_flags,
    k_torque_ratio,
    k_twist_command,
    layout,
)
from wheelgym.integrators import entry_point
from wheelgym.registration import DEFAULT_HORIZON
from wheelgym.tasks.kernels import k_noise
from wheelgym.tasks.tasks import TASKS, NavigateTask, Task, TrackTask

__all__ = ["WheelCore", "EnvConfig", "InfoKey", "INFO_KEYS", "DEFAULT_HORIZON", "MAX_CTRL_DT",
           "MAX_SUBSTEPS"]


@numba.njit(cache=True)
def k_step_power(B, col, e0, inv_dt, out, steps):  # pragma: no cover - compiled
    """``out = (E - e0) * inv_dt`` (the step's mean motor power) with ``E = B[:, col]`` (the
    energy), then ``e0 = E`` and ``steps += 1``: one call (NumPy's operations cost ~10% of a
    single env's step, and each compiled call ~0.2 us)."""
    for i in range(B.shape[0]):
        e = B[i, col]
        out[i] = (e - e0[i]) * inv_dt
        e0[i] = e
        steps[i] += 1


class InfoKey(NamedTuple):
    """One key of every step's ``info`` and where the core keeps it.

    ``block``: ``"B"`` (the float block: ``column`` is its ``layout`` entry; ``motors``: only
    the first ``n_motor`` columns), ``"F"`` (the flag block: ``column`` its index; ``negate``:
    reported as ``not``), ``"core"`` (a number per row in the core's ``(N,)`` array attribute
    ``column``, :attr:`WheelCore.info_core`) or ``"terms"`` (the weighted reward terms, a dict
    by name)."""

    name: str
    block: str
    column: str | int
    motors: bool = False
    negate: bool = False


#: The step info of the single and the vector env, in order (``wheel_env.py``'s "Info" table);
#: both build theirs from it (:meth:`WheelCore.info_columns`).
INFO_KEYS: tuple[InfoKey, ...] = (
    InfoKey("pose", "B", "pose"),
    InfoKey("twist", "B", "twist"),
    InfoKey("motor_torque", "B", "U", motors=True),
    InfoKey("joint_velocity", "B", "jv", motors=True),
    InfoKey("tracking_error", "B", "err"),
    InfoKey("energy", "B", "energy"),
    InfoKey("electrical_power", "core", "pel"),
    InfoKey("internal_force", "B", "xf"),
    InfoKey("saturated", "F", F_SAT),
    InfoKey("is_success", "F", F_SUCC),
    InfoKey("numerical_failure", "F", F_OK, negate=True),
    InfoKey("reward_terms", "terms", "terms"),
)

#: RK4 is stable for a real eigenvalue ``-lambda`` while ``lambda sim_dt`` is below this.
RK4_REAL_STABILITY_LIMIT = 2.785


class WheelCore:
    """N robots of one kind on one task (see the module docstring for the API).

    Args:
        robot: robot name (``"ThreeWheel"``, ``"SkidSteer"``...), or an :class:`EnvConfig`
            (then no keywords).
        num: batch size N.
        **kwargs: the :class:`~wheelgym.envs.config.EnvConfig` keywords (task, action_mode,
            params, ctrl_dt, sim_dt, randomize, obs_noise, reward_weights, range_backend,
            horizon: as documented on :class:`~wheelgym.envs.wheel_env.WheelEnv`; ``horizon``
            is the control steps of the track reference that batches of up to
            ``TrackTask.whole_up_to`` robots evaluate at each reset, capped at
            ``TrackTask.max_table``; the reference moves on past it by windows).

    ``config`` holds the validated keywords; the checks that need the built model (the
    parameter values, RK4 stability, the ``randomize`` extremes) are made here.
    """

    def __init__(self, robot: str | EnvConfig, num: int = 1, **kwargs: Any) -> None:
        if isinstance(robot, EnvConfig):
            if kwargs:
                raise TypeError(f"WheelCore(config, num) takes no keywords, got {list(kwargs)}")
            cfg = robot
        else:
            get_spec(robot)  # an unknown robot first (ValueError listing the robots)
            cfg = None
        if isinstance(num, bool) or not isinstance(num, (int, np.integer)) or num < 1:
            raise ValueError(f"num must be a positive int, got {num!r}")
        if cfg is None:
            cfg = EnvConfig.from_kwargs("WheelCore", robot, kwargs)
        #: The validated keyword arguments (:class:`~wheelgym.envs.config.EnvConfig`).
        self.config = cfg
        spec: RobotSpec = cfg.spec
        self.spec = spec
        self.num = N = int(num)
        self.task_name = cfg.task
        self.action_mode = mode = cfg.action_mode
        #: DC motors (``motor="dc"``): the model's DC law and electrical power in the step.
        self.dc = cfg.motor != "ideal"
        #: ``action_mode="voltage"``: the inputs are the DC motors' terminal voltages (the
        #: model's ``motor="dc_voltage"``, stepped by the same DC kernels: the mode code in
        #: the packed parameters selects the voltage law).
        self.voltage = mode in spec.dc_action_modes
        self.model = spec.make_model(
            {**cfg.params, "motor": spec.model_motor(cfg.motor, mode)} if self.dc
            else cfg.params, mode)
        self.base_params = self.model.params
        self.dt = cfg.ctrl_dt
        self.n_sub = cfg.n_substeps
        self.h = self.dt / self.n_sub
        self._stiff_scale: float | None = None
        self._check_stable(self.base_params, "params")
        #: The perturbation (``perturbation=``, ``wheelgym.envs.perturbation``) or None.
        self.perturbation = pert = cfg.perturbation
        # its parameter scales are drawn with the randomize groups (config checks: no overlap)
        scales = {} if pert is None else resolve_scales(pert, spec.randomize, self.base_params,
                                                         self.dc)
        try:
            self.randomize = self._check_randomize(
                {**{g: r for g, r in cfg.randomize.items() if g != "action_delay"}, **scales})
        except ValueError as exc:
            if not scales:
                raise
            raise ValueError(f"{exc} (perturbation scales {scales} are drawn as randomize "
                             f"ranges)") from None
        self.obs_noise = cfg.obs_noise
        self.horizon = cfg.horizon
        self._init_blocks(N)
        self._init_observation(N)

    def _init_blocks(self, N: int) -> None:
        """The constructor's second part: the action sizes, the velocity mode's controller,
        the step kernel and the per-row state blocks."""
        cfg, spec, mode = self.config, self.spec, self.action_mode
        # action sizes and the velocity mode's controller
        self.action_dim = spec.action_dim(mode)
        self._velocity = spec.tracks_twist(mode)
        if self._velocity:
            self.twist_max = np.array(spec.twist_max)
            from wheelgym.control.controllers import TwistController

            # deadbeat twist loop at this control period (controllers.py module docstring)
            # (SkidSteer: PI, one integrator per row, zeroed at the row's reset); its model:
            # the built one ("nominal") or each row's drawn parameters ("true", bound below)
            self.controller = TwistController(self.model, ctrl_dt=self.dt, rows=N)
        #: ``controller_model``: ``"nominal"`` or ``"true"`` (``docs/topics/robustness.md``).
        self.controller_model = cfg.controller_model
        m = self.model.input_dim
        nx = self.model.state_dim
        nf = len(spec.feat_names)
        self.vclip = 2.0 * spec.v_max
        self.wclip = 2.0 * spec.w_max
        self.fclip = np.array(spec.feat_high, dtype=np.float64)

        # the step kernel: for large batches the faster (timed in use) of the serial kernel and
        # the one spreading rows over numba's threads (same bits per row, _dispatch.py); the
        # serial kernel below PAR_MIN_ROWS or with NUMBA_NUM_THREADS=1, so the single env never
        # starts numba's threads (read from the config: asking numba starts them)
        #: Whether this batch uses numba's threads (the step kernel, the goal task's kernel).
        self.threaded = N >= PAR_MIN_ROWS and numba.config.NUMBA_NUM_THREADS > 1
        self._bind_step()

        # per-row state
        self.X = np.zeros((N, nx))
        self.Xo = np.zeros((N, nx))
        p0 = self.model.packed
        self.P = np.tile(p0, (N, 1))
        lo, hi = spec.action_bounds(self.model, mode)
        # physical input bounds per row: low then high (LO, HI are views)
        self.m = m
        self.LH = np.tile(np.concatenate([lo, hi]), (N, 1))
        # the actions' shape; the single env writes its actions here (the direct calls of _step)
        self.A = np.zeros((N, self.action_dim))
        self._init_actuator()
        if self._velocity:
            #: the true controller model's per-row torque limits (contiguous copy of HI)
            self._ctl_T = np.ascontiguousarray(self.LH[:, m:])
            self._bind_controller()
        # one float block and one flag block per row (few arrays: each array argument of a
        # compiled call costs ~0.25 us); the named attributes are views into them
        lay = layout(m, nf)
        self._lay = lay
        self.B = np.zeros((N, lay["width"]))
        self.F = np.zeros((N, 5), dtype=np.bool_)
        self.terms = np.zeros((N, len(TASKS[self.task_name].columns)))
        #: Mean motor power of each row's last step (W; ``info["electrical_power"]``): the
        #: step's increment of ``energy`` over ``ctrl_dt`` (0 at a reset); ``_e0`` the energy
        #: at the end of the previous step (0 after a reset)
        #: before the step.
        self.pel = np.zeros(N)
        self._e0 = np.zeros(N)
        self._inv_dt = 1.0 / self.dt
        self._ecol = int(lay["energy"])
        self._bind_views()
        self.ok[:] = True
        self.steps = np.zeros(N, dtype=np.int64)  # control steps since each row's reset
        self.all_rows = np.arange(N, dtype=np.int64)  # every row index (kernels' row lists)
        self.drawn: list[dict[str, float]] = [{} for _ in range(N)]
        self.params_rows = [self.base_params] * N

    def _init_observation(self, N: int) -> None:
        """The constructor's last part: the task, the observation's layout (the task's
        entries, then the observation and action histories) and the signal faults."""
        cfg = self.config
        self.task: Task = TASKS[self.task_name](self, cfg.reward_weights, **cfg.task_kwargs())
        names, high = self.task.obs_layout()
        low = self.task.obs_low() if isinstance(self.task, NavigateTask) else -high
        #: Observation entries of the task (the first columns of ``obs``).
        self.task_obs_dim = D = len(names)
        #: ``action_history``: the last ``k`` actions the policy sent (clipped to [-1, 1]),
        #: newest first, appended to the task's entries; zeros at a reset. They are what the
        #: policy commanded, before the perturbation's action faults and delay, and the
        #: observation noise and faults do not touch them (they act on the task's entries).
        #: ``obs_history``: the task's entries of the last ``ko`` steps before this one, as
        #: observed (noise and faults included), newest first, after the task's entries;
        #: ``_ostack`` holds them behind the current ones (a reset fills it with the first).
        self.n_obs_history = ko = cfg.obs_history
        self._ostack = np.zeros((N, (ko + 1) * D), dtype=np.float32)
        if ko:
            names = [*names, *(f"prev_obs_{t}_{n}" for t in range(1, ko + 1)
                               for n in names[:D])]
            high = np.concatenate([high, np.tile(high[:D], ko)])
            low = np.concatenate([low, np.tile(low[:D], ko)])
        #: First column of the action history.
        self._hist0 = D * (ko + 1)
        self.n_history = k = cfg.action_history
        ad = self.action_dim
        self._hist = np.zeros((N, k * ad))
        if k:
            names = [*names, *(f"prev_action_{t}_{j}" for t in range(1, k + 1)
                               for j in range(ad))]
            high = np.concatenate([high, np.ones(k * ad)])
            low = np.concatenate([low, -np.ones(k * ad)])
        self.obs_names = names
        self.obs_high = high.astype(np.float32)
        self.obs_low = low.astype(np.float32)
        self.obs = np.zeros((N, len(names)), dtype=np.float32)
        #: The perturbation's per-step signal faults (noise, dropped and stuck entries) or None.
        self.faults: SignalFaults | None = None
        if self.perturbation is not None and self.perturbation.faults:
            self.faults = SignalFaults(self.perturbation, N, self.action_dim, D)
        #: Whether a step draws from the rows' generators (a vector env then passes the
        #: rows that step, :meth:`step`'s ``active``).
        self.step_draws = self.obs_noise > 0 or self.faults is not None
        self.rngs: Sequence[np.random.Generator] | None = None
        self._track = isinstance(self.task, TrackTask)
        #: No perturbation, delay, lag, history or noise: a step is the kernels alone (with
        #: the velocity mode's controller), skipping the other stages in one test.
        self._plain = not (self.faults is not None or self._delay or self._lag
                           or self.n_history or self.n_obs_history or self.obs_noise > 0)

    # ------------------------------------------------------------------ views and copies
    #: Attributes that are views into the blocks ``LH``, ``B`` and ``F`` (or hold such views,
    #: or compiled callables): a copy drops them and rebuilds them on its own blocks.
    _DERIVED = ("LO", "HI", "U", "jv", "energy", "eff", "pose", "twist", "xf", "reward", "err",
                "feat", "sat", "ok", "term", "succ", "coll", "info_buffers", "info_vectors",
                "info_numbers", "info_flags", "_k_step", "_ctl_kernel", "_ctl_args",
                "_k_serial", "info_core", "_direct")

    def _bind_views(self) -> None:
        """The named views into the blocks (one compiled call writes a whole row)."""
        m, lay = self.m, self._lay
        self.LO = self.LH[:, :m]
        self.HI = self.LH[:, m:]
        self.U = self.B[:, lay["U"]]
        self.jv = self.B[:, lay["jv"]]
        self.energy = self.B[:, lay["energy"]]
        self.eff = self.B[:, lay["eff"]]
        self.pose = self.B[:, lay["pose"]]
        self.twist = self.B[:, lay["twist"]]
        self.xf = self.B[:, lay["xf"]]
        self.reward = self.B[:, lay["reward"]]
        self.err = self.B[:, lay["err"]]
        self.feat = self.B[:, lay["feat"]]
        self.sat = self.F[:, F_SAT]
        self.ok = self.F[:, F_OK]
        self.term = self.F[:, F_TERM]
        self.succ = self.F[:, F_SUCC]
        self.coll = self.F[:, F_COLL]
        self.info_buffers = {
            "pose": self.pose, "twist": self.twist, "motor_torque": self.U,
            "joint_velocity": self.jv, "tracking_error": self.err, "energy": self.energy,
            "internal_force": self.xf, "saturated": self.sat, "is_success": self.succ,
            "ok": self.ok, "terms": self.terms,
        }
        # INFO_KEYS as views of the blocks: vectors (N, k), numbers (N,), flags (N,) + negate
        floats, flags = self.info_columns()
        self.info_vectors = tuple((n, self.B[:, col]) for n, col in floats
                                  if isinstance(col, slice))
        self.info_numbers = tuple((n, self.B[:, col]) for n, col in floats
                                  if not isinstance(col, slice))
        self.info_flags = tuple((n, self.F[:, col], neg) for n, col, neg in flags)
        #: INFO_KEYS' ``"core"`` entries: ``(name, (N,) array)`` in table order.
        self.info_core = tuple((k.name, getattr(self, str(k.column))) for k in INFO_KEYS
                               if k.block == "core")

    def _bind_step(self) -> None:
        """The step kernels of the motor model (``spec.step_kernels``): ``_k_serial`` and
        ``_k_step`` (for large batches the faster, timed in use, of the serial and the
        threaded kernel)."""
        ks, kp = self.spec.step_kernels(self.dc, self.num)
        self._k_serial = ks
        self._k_step = FasterKernel(ks, kp) if self.threaded else ks
        #: A plain step's compiled calls on the core's own buffers (:meth:`_resolve_direct`).
        self._direct: tuple[Any, ...] | None = None

    def info_columns(self) -> tuple[tuple[tuple[str, slice | int], ...],
                                    tuple[tuple[str, int, bool], ...]]:
        """:data:`INFO_KEYS` resolved on this core: the float keys as ``(name, column of B)``
        (a slice for a vector, an index for a number) and the flag keys as ``(name, column of
        F, negate)``, each in table order (the reward terms are ``terms``' columns
        ``task.term_index``)."""
        floats: list[tuple[str, slice | int]] = []
        flags: list[tuple[str, int, bool]] = []
        nm = self.spec.n_motor
        for key in INFO_KEYS:
            if key.block == "B":
                col = self._lay[key.column]
                if key.motors:
                    col = slice(col.start, col.start + nm)
                floats.append((key.name, col))
            elif key.block == "F":
                flags.append((key.name, int(key.column), key.negate))
        return tuple(floats), tuple(flags)

    def __getstate__(self) -> dict[str, Any]:
        """State for ``copy.deepcopy`` and ``pickle``: the blocks and buffers, without the
        views into them (a copy of a view would stop aliasing its block), the compiled
        callables, or the robot spec (stored by name)."""
        state = {k: v for k, v in self.__dict__.items() if k not in self._DERIVED}
        state["spec"] = self.spec.name
        return state

    def __setstate__(self, state: dict[str, Any]) -> None:
        self.__dict__.update(state)
        self.spec = get_spec(state["spec"])
        self._bind_views()
        self._bind_step()
        if self._velocity:
            self._bind_controller(buffers=False)

    def _bind_controller(self, buffers: bool = True) -> None:
        """The controller's compiled batch kernel and its arguments (its ``torques`` method
        without the per-call Python checks, which cost ~20x the kernel at N = 1), and (with
        ``buffers``) its scratch buffers."""
        if self.controller_model == "true":  # each row's packed parameters and limits
            self._ctl_kernel, self._ctl_args = self.controller.row_kernel(self.P, self._ctl_T)
        else:
            self._ctl_kernel, self._ctl_args = self.controller.batch_kernel()
        if not buffers:
            return
        N = self.num
        self._cmd = np.zeros((N, self.action_dim))
        self._tau = np.zeros((N, self.model.input_dim))
        self._anorm = np.zeros((N, self.model.input_dim))
        self._csat = np.zeros(N, dtype=np.bool_)
        self._clipped = np.zeros(N, dtype=np.bool_)

    # ------------------------------------------------------------------ delay and lag
    def _init_actuator(self) -> None:
        """State of ``action_delay`` (per-row ring buffers of the normalised actions,
        ``wheelgym.envs.actuator``) and ``actuator_lag`` (the filtered normalised inputs).
        ``randomize["action_delay"] = (lo, hi)`` replaces ``action_delay``: the buffers hold
        ``hi`` steps and each row reads its own delay, drawn at its reset."""
        cfg, N = self.config, self.num
        drawn = cfg.randomize.get("action_delay")
        fixed = cfg.action_delay
        pert = cfg.perturbation
        if pert is not None and pert.action_delay != (0, 0):  # (config: not with the above)
            lo, hi = pert.action_delay
            drawn, fixed = ((lo, hi), 0) if hi > lo else (None, lo)
        self._delay_range: tuple[int, int] | None = drawn
        K = fixed if drawn is None else drawn[1]
        #: Each row's action delay (control steps).
        self.delays = np.full(N, fixed if drawn is None else drawn[0], dtype=np.int64)
        self._delay = K > 0
        self._dbuf = np.zeros((N, K + 1, self.action_dim))
        self._dhead = np.zeros(1, dtype=np.int64)
        self._da = np.zeros((N, self.action_dim))
        T = cfg.actuator_lag or (0.0 if pert is None else pert.actuator_lag)
        self._lag = T > 0
        self._lag_alpha = float(-np.expm1(-self.dt / T)) if T > 0 else 1.0
        self._lag_u = np.zeros((N, self.m))
        self._lag_sat = np.zeros(N, dtype=np.bool_)
        self._act_fx = self._delay or self._lag or drawn is not None

    def _reset_actuator(self, idx: np.ndarray, rngs: Sequence[np.random.Generator]) -> None:
        """Rows ``idx``: draw the delay (``randomize``), zero the buffers and the lag."""
        if self._delay_range is not None:
            lo, hi = self._delay_range
            for i in idx:
                self.delays[i] = rngs[i].integers(lo, hi + 1)
        self._dbuf[idx] = 0.0
        self._lag_u[idx] = 0.0

    # ------------------------------------------------------------------ validation
    def _check_randomize(self, ranges: dict[str, tuple[float, float]]
                         ) -> dict[str, tuple[float, float]]:
        """The config's ``randomize`` ranges, checked on the model: a range that cannot change
        the motion (:meth:`RobotSpec.check_randomize`) or that can draw invalid or unstable
        parameters (:meth:`_check_randomize_extremes`) raises ``ValueError``."""
        self.spec.check_randomize(self.model, ranges)
        self._check_randomize_extremes(ranges)
        return dict(ranges)

    def _params_at(self, values: Mapping[str, float]) -> Any:
        """The base parameters with each group in ``values`` at that draw (a factor, or the
        value of an ``"abs"`` group), mapped onto fields as :meth:`_draw_params` does."""
        base = self.base_params
        changes: dict[str, Any] = {}
        for group, f in values.items():
            for field, kind in self.spec.randomize[group]:
                changes[field] = f * getattr(base, field) if kind == "rel" else f
        return base.replace(**changes)

    def _check_randomize_extremes(self, ranges: Mapping[str, tuple[float, float]]) -> None:
        """Build the parameters at the extremes of the ranges (each group alone at its low and
        its high, then every group at its low and every group at its high: 2 k + 2 sets for k
        groups, not all 2^k corners, as a set costs ~1 ms to validate) through the dataclass
        validation and the stability check, so that a seed cannot draw an invalid set;
        ``ValueError`` naming the ``randomize`` entry."""
        groups = [g for g in self.spec.randomize if g in ranges]  # the draws' fixed order
        if not groups:
            return
        # each group alone first (the error then names the one entry at fault)
        corners = [{g: v} for g in groups for v in ranges[g]]
        if len(groups) > 1:
            corners += [{g: ranges[g][end] for g in groups} for end in (0, 1)]
        for corner in corners:
            names = ", ".join(f"randomize[{g!r}] = {ranges[g]}" for g in corner)
            at = ", ".join(f"{g} at {v:g}" for g, v in corner.items())
            try:
                params = self._params_at(corner)
                self._check_stable(params, "params", coarse=True,
                                   model=self.spec.make_model(params, self.action_mode))
            except (ValueError, TypeError) as exc:
                raise ValueError(
                    f"{names}{' together' if len(corner) > 1 else ''} can draw invalid "
                    f"parameters ({at}): {exc}; narrow the range"
                ) from None

    def _check_stable(self, params: Any, what: str, coarse: bool = False,
                      model: Any = None) -> None:
        """``ValueError`` when the RK4 substep ``h`` is outside RK4's stability region for
        ``params``: ``lambda h >= 2.785`` (:data:`RK4_REAL_STABILITY_LIMIT`) for the stiffest
        mode, the friction at rest (the model's ``stiffness()``, README "Time steps") or, for
        a caster trail ``d``, the trailing-caster mode ``|v| / d`` (``ThreeWheel``'s
        docstring) at the speed limit ``v_max``. ``coarse``: at the spec's
        ``stiffness_probe`` configurations (for the randomisation corners). ``model``: the
        model of ``params`` if already built. Models without ``stiffness`` (kinematic) pass."""
        if not hasattr(self.spec.model_cls, "stiffness"):
            return
        if model is None:
            model = self.model if params is self.base_params else \
                self.spec.make_model(params, self.action_mode)
        probe = self.spec.stiffness_probe
        if coarse and probe is not None:  # fewer configurations, scaled by full/coarse at base
            psi = np.asarray(probe)
            if self._stiff_scale is None:
                self._stiff_scale = self.model.stiffness() / self.model.stiffness(psi)
            lam = model.stiffness(psi) * self._stiff_scale
        else:
            lam = model.stiffness()
        trail = getattr(params, "d", None)
        lam_c = self.spec.v_max / trail if trail else 0.0
        worst = max(lam, lam_c)
        if not worst * self.h < RK4_REAL_STABILITY_LIMIT:
            raise ValueError(
                f"{what}: sim_dt = {self.h:g} s is outside RK4's stability region for these "
                f"parameters: the stiffest mode (friction at rest {lam:.4g} 1/s"
                + (f", caster trail v_max / d = {lam_c:.4g} 1/s" if trail else "")
                + f") times sim_dt is {worst * self.h:.3g} >= {RK4_REAL_STABILITY_LIMIT}; "
                f"use sim_dt < {RK4_REAL_STABILITY_LIMIT / worst:.3g} s (a divisor of ctrl_dt)"
            )

    # ------------------------------------------------------------------ reset
    def _draw_params(self, i: int, rng: np.random.Generator) -> None:
        """Draw row i's randomised parameters (``randomize`` set) and write its rows of
        ``P``, ``LO``, ``HI``."""
        base = self.base_params
        changes: dict[str, Any] = {}
        drawn: dict[str, float] = {}
        for group in self.spec.randomize:  # fixed order: reproducible draws
            if group not in self.randomize:
                continue
            lo, hi = self.randomize[group]
            for field, kind in self.spec.randomize[group]:
                f = float(rng.uniform(lo, hi))
                val = f * getattr(base, field) if kind == "rel" else f
                changes[field] = val
                drawn[field] = val
        params = base.replace(**changes)
        self.params_rows[i] = params
        self.drawn[i] = drawn
        self.P[i], lo, hi = self.spec.row_params(self.model, params, self.action_mode)
        self.LO[i] = lo
        self.HI[i] = hi  # views into LH

    def reset(self, rows: Sequence[int] | np.ndarray | None,
              rngs: Sequence[np.random.Generator], options: dict | None = None) -> np.ndarray:
        """Start new episodes in ``rows`` (all when None) drawing row i from ``rngs[i]``.

        ``options``: the task's reset options (``Task.option_keys``; the env docstring's
        "Reset Options" table), each one value for every row or an array with a leading axis
        of N (row i reads entry i; rows not reset ignore theirs). Unknown keys raise
        ``ValueError`` listing the valid ones. The draws are made as without options (the
        options replace drawn values), so the generators advance the same either way.

        Returns the observation buffer ``(N, obs_dim)``; rows not reset keep their values.
        """
        N = self.num
        if len(rngs) != N:
            raise ValueError(f"rngs must hold {N} generators, got {len(rngs)}")
        opts = self.task.parse_options(options)  # before any draw: a bad option draws nothing
        self.rngs = rngs
        idx = self.all_rows if rows is None else np.asarray(rows, dtype=np.int64)
        if idx.size == 0:
            return self.obs
        if self.randomize:  # (without, every row keeps the base parameters it was built with)
            for i in idx:
                self._draw_params(int(i), rngs[i])
        if self._act_fx:  # action delay / actuator lag: after the parameter draws
            self._reset_actuator(idx, rngs)
        if self._velocity and self.controller_model == "true":
            self._ctl_T[idx] = self.HI[idx]  # (P holds the rows' drawn parameters)
        poses = self.task.reset_rows(idx, rngs, opts)
        if self.randomize:  # the start state may depend on each row's drawn parameters
            for n, i in enumerate(idx):
                self.X[i] = self.spec.initial_state(poses[n:n + 1], self.params_rows[i])[0]
        else:
            self.X[idx] = self.spec.initial_state(poses, self.base_params)
        self.steps[idx] = 0
        if self._velocity:
            self.controller.reset_rows(idx)  # the twist loop's integrators (SkidSteer)
        # features at the start state: a zero-substep pass of the step kernel on the reset
        # rows' copies of the blocks (a partial reset costs its rows only), which writes pose,
        # twist, features and joint rates; then no torque, effort, work or internal force yet,
        # and the blocks go back in one scatter each
        Xs = self.X[idx]
        Bs = self.B[idx]
        Fs = self.F[idx]
        lay = self._lay
        Bs[:, lay["energy"]] = 0.0  # the pass adds no work
        A0 = np.zeros((idx.size, self.m))
        self._k_serial(Xs, A0, self.LH[idx], self.P[idx], self.h, 0, Xs.copy(), Bs, Fs)
        Bs[:, lay["U"]] = 0.0
        Bs[:, lay["eff"]] = 0.0
        Bs[:, lay["xf"]] = 0.0
        Fs[:, F_SAT] = False
        Fs[:, F_OK] = True
        self.B[idx] = Bs
        self.F[idx] = Fs
        self.pel[idx] = 0.0
        self._e0[idx] = 0.0
        self.task.evaluate(idx)
        self._noise(idx)
        if self.faults is not None:
            self.faults.reset_rows(idx, self.obs[:, :self.task_obs_dim])
        if self.n_obs_history:  # the first observation stands for the steps before it
            D = self.task_obs_dim
            self._ostack[idx] = np.tile(self.obs[idx, :D], self.n_obs_history + 1)
            self.obs[idx, D:self._hist0] = self._ostack[idx, D:]
        if self.n_history:  # no action sent yet
            self._hist[idx] = 0.0
            self.obs[idx, self._hist0:] = 0.0
        return self.obs

    def _noise(self, idx: np.ndarray) -> None:
        if self.obs_noise <= 0:
            return
        D = self.task_obs_dim  # the task's entries (the action history stays exact)
        noise = np.zeros((idx.size, self.obs.shape[1]))
        for n, i in enumerate(idx):
            noise[n, :D] = self.rngs[i].normal(0.0, self.obs_noise, D)
        k_noise(idx, self.obs, noise, self.obs_low, self.obs_high)

    # ------------------------------------------------------------------ step
    def step(self, actions: np.ndarray, active: np.ndarray | None = None
             ) -> tuple[np.ndarray, np.ndarray, np.ndarray, dict]:
        """Advance every row one control period.

        Args:
            actions: ``(N, action_dim)`` real numbers in [-1, 1] (entries outside are
                clipped; a non-finite entry raises ``ValueError``, a non-real dtype such as
                strings, complex or bool ``TypeError``).
            active: optional ``(N,)`` bool mask; rows outside it are integrated all the same
                but draw no observation noise (nor the perturbation's per-step draws) from
                their generators. A vector env passes the
                rows it resets right after this step (next-step autoreset), so each row's
                generator is consumed exactly as the single environment's.

        Returns:
            ``obs (N, D) float32``, ``reward (N,)``, ``terminated (N,) bool`` and a dict of
            buffers: ``pose``, ``twist``, ``motor_torque`` (``U``), ``joint_velocity``,
            ``tracking_error``, ``energy``, ``internal_force``, ``saturated``, ``is_success``,
            ``terms`` (N, n_columns), ``ok`` (False: numerical failure). All are the core's
            buffers (the same dict every step).
        """
        a = actions
        if a.shape != self.A.shape or a.dtype != np.float64:  # (float64 of the shape: fast)
            a = np.asarray(actions)
            if a.dtype.kind not in "fiu":
                raise TypeError(f"action must be an array of real numbers (float or int), got "
                                f"dtype {a.dtype}")
            a = a.astype(np.float64, copy=False)
            if a.shape != self.A.shape:
                raise ValueError(f"action must have shape {self.A.shape}, got {np.shape(actions)}")
        return self._step(a, active)

    def _step(self, a: np.ndarray, active: np.ndarray | None
              ) -> tuple[np.ndarray, np.ndarray, np.ndarray, dict]:
        """:meth:`step` on actions ``a`` already float64 of shape ``(N, action_dim)`` (the
        single env passes its own buffer)."""
        plain = self._plain
        direct = plain and a is self.A  # the actions in A (the single env's)
        if direct and self._direct is not None:
            ks, kp, ev, ctl = self._direct
        else:
            ks, kp, ev, ctl = self._k_step, k_step_power, self.task.evaluate, None
        if plain:
            A = self._control(a, ctl) if self._velocity else a
        else:
            A = self._inputs(a, active)
        if not ks(self.X, A, self.LH, self.P, self.h, self.n_sub, self.Xo, self.B, self.F):
            raise ValueError("action must be finite (got NaN or inf)")
        kp(self.B, self._ecol, self._e0, self._inv_dt, self.pel, self.steps)
        if self._track:
            self.task.advance()
        if self._velocity:
            (k_or_flags if ctl is None else ctl[3])(self.F, self._csat, self._clipped)
        if self._lag:  # a clipped command saturates (the filtered input never exceeds 1)
            k_or_flags(self.F, self._lag_sat, self._lag_sat)
        self.X, self.Xo = self.Xo, self.X
        ev()
        if direct and self._direct is None:  # compiled now: resolve the entry points once
            self._direct = self._resolve_direct()
        if not plain:
            if self.obs_noise > 0:
                self._noise(self.all_rows if active is None else np.flatnonzero(active))
            if self.faults is not None:
                rows = self.all_rows if active is None else np.flatnonzero(active)
                D = self.task_obs_dim
                self.faults.observations(self.obs[:, :D], rows, self.obs_low[:D],
                                         self.obs_high[:D])
            if self.n_obs_history:
                self._push_obs_history()
            if self.n_history:
                self._push_history(a)
        return self.obs, self.reward, self.term, self.info_buffers

    def _resolve_direct(self) -> tuple[Any, ...]:
        """A plain step's compiled calls (physics, power, the task's evaluation; the velocity
        mode's four) as entry points for the core's own buffers, the actions in ``A`` (the
        single env's): a call then skips numba's resolution of its argument types (~0.2 us
        each at N = 1)."""
        ks = entry_point(self._k_step, self.X, self.A, self.LH, self.P, self.h, self.n_sub,
                         self.Xo, self.B, self.F)
        kp = entry_point(k_step_power, self.B, self._ecol, self._e0, self._inv_dt, self.pel,
                         self.steps)
        ctl = None
        if self._velocity:
            ctl = (entry_point(k_twist_command, self.A, self.twist_max, self._cmd,
                               self._clipped),
                   entry_point(self._ctl_kernel, self.X, self._cmd, *self._ctl_args, self._tau,
                               self._csat),
                   entry_point(k_torque_ratio, self._tau, self.LH, self._anorm),
                   entry_point(k_or_flags, self.F, self._csat, self._clipped))
        return ks, kp, self.task.evaluate_all(), ctl

    def _control(self, a: np.ndarray, ctl: tuple[Any, ...] | None) -> np.ndarray:
        """Velocity mode: the twist commands ``a`` through the controller, as normalised
        torques (``ctl``: the direct calls of :meth:`_resolve_direct`, or None)."""
        kt, kc, kr = (k_twist_command, self._ctl_kernel, k_torque_ratio) if ctl is None \
            else ctl[:3]
        if not kt(a, self.twist_max, self._cmd, self._clipped):
            raise ValueError("action must be finite (got NaN or inf)")
        kc(self.X, self._cmd, *self._ctl_args, self._tau, self._csat)
        kr(self._tau, self.LH, self._anorm)
        return self._anorm

    def _inputs(self, a: np.ndarray, active: np.ndarray | None) -> np.ndarray:
        """The kernel's normalised inputs from the sent actions ``a``: the perturbation's action
        faults, the delay, the twist controller (velocity mode) and the lag, in that order."""
        # the sent actions (action_history) are checked before anything moves: the
        # perturbation's dropped entries could hide a non-finite one from the kernels' check
        if self.n_history and not np.all(np.isfinite(a)):
            raise ValueError("action must be finite (got NaN or inf)")
        if self.faults is not None:  # the perturbation's action noise, drops, stuck entries
            rows = self.all_rows if active is None else np.flatnonzero(active)
            self.faults.draw(rows, self.rngs)
            a = self.faults.actions(a, rows)
        if self._delay:  # action_delay: the action of delays[i] steps ago (zeros at first)
            if not k_delay(a, self._dbuf, self._dhead, self.delays, self._da):
                raise ValueError("action must be finite (got NaN or inf)")
            a = self._da
        if self._velocity:
            a = self._control(a, None)
        if self._lag:  # actuator_lag: the filtered inputs
            if not k_lag(a, self._lag_u, self._lag_alpha, self._lag_sat):
                raise ValueError("action must be finite (got NaN or inf)")
            a = self._lag_u
        return a

    def _push_history(self, sent: np.ndarray) -> None:
        """``action_history``: the sent actions (clipped) become the newest entries."""
        h, ad = self._hist, self.action_dim
        h[:, ad:] = h[:, :-ad].copy()
        np.clip(sent, -1.0, 1.0, out=h[:, :ad])
        self.obs[:, self._hist0:] = h

    def _push_obs_history(self) -> None:
        """``obs_history``: the step's task entries join the stack; the ones before it are
        the appended entries."""
        st, D = self._ostack, self.task_obs_dim
        st[:, D:] = st[:, :-D].copy()
        st[:, :D] = self.obs[:, :D]
        self.obs[:, D:self._hist0] = st[:, D:]
