"""Validation report of the physics models: ``python -m wheelgym.validate``.

Runs each check on the default parameters of every model exported by :mod:`wheelgym.models`
that supports it and prints one Markdown table, ``check | model | measured | bound | pass``.
The check functions are public so that the tests call the same code with the same bounds.

A model opts into a check by providing what the check needs:

| check                | needs                                                        |
|----------------------|--------------------------------------------------------------|
| stiffness margin     | ``stiffness()`` (largest friction eigenvalue magnitude, 1/s) |
| energy balance       | ``kinetic_energy(x)``, ``motor_power(x, u)``, ``friction_power(x)`` |
| energy conservation  | the above and ``friction_params`` (see ``Model.frictionless``) |
| RK4 order, step refinement, batch equality | nothing beyond the ``Model`` API      |
| skid-steer answers   | a :class:`~wheelgym.models.SkidSteer`                        |

Input scale: ``model.input_high`` if the model has it, else ``params.tau_max``, else 1.
Optional hooks: ``validation_state()`` (the start state of the runs) and
``validation_manoeuvre(t)`` (the input at time ``t``) replace the generic ones.
"""

from __future__ import annotations

import argparse
import dataclasses
import math
import sys
from collections.abc import Callable, Sequence

import numpy as np

from wheelgym.integrators import rk4
from wheelgym.models import Model

__all__ = [
    "RK4_REAL_STABILITY_LIMIT",
    "BOUNDS",
    "CheckResult",
    "model_classes",
    "input_scale",
    "start_state",
    "manoeuvre",
    "simulate",
    "stiffness_margin",
    "rk4_order_ratio",
    "step_refinement_error",
    "energy_balance_error",
    "energy_conservation_error",
    "batch_mismatches",
    "skid_steer_straight",
    "skid_steer_turn",
    "run_checks",
    "format_table",
    "main",
]

#: RK4 is stable for a real eigenvalue ``-lambda`` when ``lambda dt`` is below this number
#: (the negative real root of ``|1 + z + z^2/2 + z^3/6 + z^4/24| = 1``).
RK4_REAL_STABILITY_LIMIT = 2.785293563405282

#: Pass bounds of the checks. Order ratio: 16 +- 25 %.
BOUNDS = {
    "stiffness": RK4_REAL_STABILITY_LIMIT,
    "order_lo": 12.0,
    "order_hi": 20.0,
    "refinement": 1e-6,
    "energy": 1e-9,
    "conservation": 1e-9,
    "batch": 0,
    "ss_steady": 1e-9,
    "ss_icr": 1e-12,
}


@dataclasses.dataclass(frozen=True)
class CheckResult:
    """One row of the report."""

    check: str
    model: str
    figure: float
    bound: str
    passed: bool


# ---------------------------------------------------------------------------- helpers
def model_classes() -> list[type[Model]]:
    """Every concrete :class:`Model` subclass exported by :mod:`wheelgym.models`, in order."""
    import wheelgym.models as models

    out: list[type[Model]] = []
    for name in getattr(models, "__all__", dir(models)):
        obj = getattr(models, name, None)
        if isinstance(obj, type) and issubclass(obj, Model) and obj is not Model:
            if obj.state_names and obj not in out:
                out.append(obj)
    return out


def input_scale(model: Model) -> np.ndarray:
    """Per-input magnitude used for the manoeuvres: the model's input limit where known."""
    high = getattr(model, "input_high", None)
    if high is None:
        high = getattr(model.params, "tau_max", 1.0)
    return np.broadcast_to(np.asarray(high, dtype=np.float64), (model.input_dim,)).copy()


def start_state(model: Model, seed: int = 0) -> np.ndarray:
    """A moving start: ``model.validation_state()`` if defined, else a seeded N(0, 0.3^2) state."""
    fn = getattr(model, "validation_state", None)
    if callable(fn):
        return np.asarray(fn(), dtype=np.float64)
    return np.random.default_rng(seed).normal(0.0, 0.3, model.state_dim)


def manoeuvre(model: Model, n_ctrl: int, ctrl_dt: float, amplitude: float = 0.5) -> np.ndarray:
    """Inputs ``(n_ctrl, m)`` held over each control step.

    ``model.validation_manoeuvre(t)`` (input at time ``t``) where the model defines one (for
    example a robot whose reversing motion is unstable); otherwise ``amplitude`` of the input
    scale times sinusoids of periods 1.3 s, 1.7 s, ... and phases 0, 1.1, ... rad (one per
    input), so the run accelerates, turns and reverses.
    """
    fn = getattr(model, "validation_manoeuvre", None)
    if callable(fn):
        return np.stack([np.asarray(fn(k * ctrl_dt), dtype=np.float64) for k in range(n_ctrl)])
    t = np.arange(n_ctrl)[:, None] * ctrl_dt
    k = np.arange(model.input_dim)[None, :]
    return amplitude * input_scale(model) * np.sin(2.0 * np.pi * t / (1.3 + 0.4 * k) + 1.1 * k)


def simulate(model: Model, x0: np.ndarray, inputs: np.ndarray, ctrl_dt: float,
             n_sub: int) -> np.ndarray:
    """States ``(len(inputs) + 1, ..., n)`` at the control instants (RK4 via ``model.step``)."""
    xs = [np.asarray(x0, dtype=np.float64)]
    for u in inputs:
        xs.append(model.step(xs[-1], u, ctrl_dt, n_sub))
    return np.stack(xs)


# ---------------------------------------------------------------------------- the checks
def stiffness_margin(model: Model, sim_dt: float | None = None) -> float:
    """``model.stiffness() * sim_dt``; must stay below :data:`RK4_REAL_STABILITY_LIMIT`."""
    return float(model.stiffness()) * (model.default_sim_dt if sim_dt is None else sim_dt)


def _final_error(model: Model, x0, inputs, ctrl_dt: float, n_sub: int, ref: np.ndarray) -> float:
    return float(np.max(np.abs(simulate(model, x0, inputs, ctrl_dt, n_sub)[-1] - ref)))


def rk4_order_ratio(model: Model, sim_dt: float | None = None, duration: float = 1.0,
                    amplitude: float = 0.5) -> float:
    """Global error at ``sim_dt`` over global error at ``sim_dt / 2`` (RK4: 16).

    The run is :func:`manoeuvre` from :func:`start_state` over ``duration`` s; the error is the
    largest entry of the final state's difference to a run at ``sim_dt / 64``. By default
    ``sim_dt`` is the model's default step, halved while ``stiffness() * sim_dt > 0.3``: the
    h^4 law holds once the stiff friction mode is resolved (at ``lambda h = 0.8``, RK4's
    amplification factor still differs from ``exp(-lambda h)`` beyond its leading term and the
    error falls faster than 16x per halving).
    """
    if sim_dt is None:
        sim_dt = model.default_sim_dt
        if _has(model, "stiffness"):
            while model.stiffness() * sim_dt > 0.3:
                sim_dt /= 2.0
    hold = model.default_ctrl_dt
    n = model.n_substeps(hold, sim_dt)
    x0 = start_state(model)
    for _ in range(12):
        inputs = manoeuvre(model, max(1, int(round(duration / hold))), hold, amplitude)
        ref = simulate(model, x0, inputs, hold, 64 * n)[-1]
        e1 = _final_error(model, x0, inputs, hold, n, ref)
        e2 = _final_error(model, x0, inputs, hold, 2 * n, ref)
        if e2 > 1e-11 * max(1.0, float(np.max(np.abs(ref)))):
            break
        # Errors at round-off (a nearly exact model, e.g. kinematic arcs): hold the input
        # twice as long with the same number of substeps, so the substep doubles.
        hold *= 2.0
    return e1 / e2


def step_refinement_error(model: Model, duration: float = 5.0, factor: int = 8,
                          sim_dt: float | None = None) -> float:
    """Error of the default step over a ``duration`` s :func:`manoeuvre` against ``sim_dt/factor``.

    Measured at every control instant, per state entry, relative to that entry's scale
    ``max(1, max_t |x_ref|)`` (SI units: an entry that stays below 1 m, rad, m/s or rad/s is
    compared in absolute terms); the figure is the largest such ratio.
    """
    sim_dt = model.default_sim_dt if sim_dt is None else sim_dt
    ctrl_dt = model.default_ctrl_dt
    n = model.n_substeps(ctrl_dt, sim_dt)
    inputs = manoeuvre(model, int(round(duration / ctrl_dt)), ctrl_dt)
    x0 = start_state(model)
    run = simulate(model, x0, inputs, ctrl_dt, n)
    ref = simulate(model, x0, inputs, ctrl_dt, factor * n)
    scale = np.maximum(1.0, np.max(np.abs(ref), axis=0))
    return float(np.max(np.abs(run - ref) / scale))


def _energy_run(model: Model, x0: np.ndarray, inputs: np.ndarray, ctrl_dt: float,
                n_sub: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Integrate the augmented ODE ``(x, W_motor, W_friction)``; returns (dT, W_m, W_f)."""
    nx = model.state_dim

    def f(z: np.ndarray, u: np.ndarray) -> np.ndarray:
        x = z[..., :nx]
        return np.concatenate(
            [model.derivative(x, u), model.motor_power(x, u)[..., None],
             model.friction_power(x)[..., None]], axis=-1)

    z = np.concatenate([x0, np.zeros(x0.shape[:-1] + (2,))], axis=-1)
    for u in inputs:
        z = rk4(f, z, u, ctrl_dt, n_sub)
    d_t = model.kinetic_energy(z[..., :nx]) - model.kinetic_energy(x0)
    return d_t, z[..., nx], z[..., nx + 1]


def energy_balance_error(model: Model, duration: float = 1.0, sub_factor: int = 8,
                         n_runs: int = 4) -> float:
    """Relative residual of ``dT = W_motor + W_friction`` over a :func:`manoeuvre`.

    The work integrals ride along as extra ODE states, integrated by RK4 with the state at
    ``default_sim_dt / sub_factor``; ``n_runs`` starts (seeds 0..) run as one batch. The figure is
    ``max |dT - W_m - W_f| / max(|dT|, |W_m|, |W_f|)`` over the runs.
    """
    ctrl_dt = model.default_ctrl_dt
    n_sub = sub_factor * model.n_substeps()
    x0 = np.stack([start_state(model, seed) for seed in range(n_runs)])
    inputs = manoeuvre(model, int(round(duration / ctrl_dt)), ctrl_dt)
    phases = np.arange(n_runs)[:, None] * 0.5  # a different input mix per run
    inputs = inputs[:, None, :] * np.cos(phases + np.arange(model.input_dim)[None, :])
    d_t, w_m, w_f = _energy_run(model, x0, inputs, ctrl_dt, n_sub)
    scale = np.maximum.reduce([np.abs(d_t), np.abs(w_m), np.abs(w_f)])
    return float(np.max(np.abs(d_t - w_m - w_f) / scale))


def energy_conservation_error(model: Model, duration: float = 3.0, sub_factor: int = 1) -> float:
    """``|T(end) - T(0)| / T(0)`` with friction and torques off, from :func:`start_state`."""
    free = model.frictionless()
    ctrl_dt = model.default_ctrl_dt
    x0 = start_state(free)
    inputs = np.zeros((int(round(duration / ctrl_dt)), free.input_dim))
    run = simulate(free, x0, inputs, ctrl_dt, sub_factor * free.n_substeps())
    energy = free.kinetic_energy(run)
    return float(np.max(np.abs(energy - energy[0])) / energy[0])


def batch_mismatches(model: Model, n: int = 1000, seed: int = 0) -> int:
    """Entries (of ``derivative`` and of one control ``step``) where a batch of ``n`` random
    states and inputs differs from the same states one by one, compared bit for bit.

    Covers the 1-D fast path, the serial batch kernel (chunks of 100) and the parallel one.
    """
    rng = np.random.default_rng(seed)
    X = rng.normal(0.0, 1.0, (n, model.state_dim))
    U = rng.uniform(-1.0, 1.0, (n, model.input_dim)) * input_scale(model)
    dt, n_sub = model.default_ctrl_dt, model.n_substeps()

    def bits(a: np.ndarray) -> np.ndarray:
        return np.ascontiguousarray(a).view(np.uint64)

    bad = 0
    d_batch = model.derivative(X, U)
    d_one = np.stack([model.derivative(X[i], U[i]) for i in range(n)])
    bad += int(np.count_nonzero(bits(d_batch) != bits(d_one)))
    s_batch = model.step(X, U, dt, n_sub)
    s_chunks = np.concatenate([model.step(X[i:i + 100], U[i:i + 100], dt, n_sub)
                               for i in range(0, n, 100)])
    s_one = np.stack([model.step(X[i], U[i], dt, n_sub) for i in range(n)])
    bad += int(np.count_nonzero(bits(s_batch) != bits(s_one)))
    bad += int(np.count_nonzero(bits(s_chunks) != bits(s_one)))
    return bad


# ---------------------------------------------------------------------------- skid-steer answers
def _bisect(f: Callable[[float], float], lo: float, hi: float, tol: float = 0.0) -> float:
    """Root of a continuous ``f`` with a sign change on ``[lo, hi]`` (bisection to round-off)."""
    f_lo = f(lo)
    if f_lo == 0.0:
        return lo
    if (f_lo > 0) == (f(hi) > 0):
        raise ValueError(f"no sign change on [{lo}, {hi}]")
    for _ in range(200):
        mid = 0.5 * (lo + hi)
        if mid in (lo, hi) or hi - lo <= tol:
            break
        f_mid = f(mid)
        if f_mid == 0.0:
            return mid
        if (f_mid > 0) == (f_lo > 0):
            lo, f_lo = mid, f_mid
        else:
            hi = mid
    return 0.5 * (lo + hi)


def skid_steer_straight(model, tau: float = 0.5, duration: float = 10.0) -> dict[str, float]:
    """Equal torque ``tau`` on all four motors from rest (SS-3).

    With arctan friction and no back-EMF a steady speed exists only while the total torque
    ``4 tau`` is below ``r mu_s m g`` (2.75 N·m at the defaults); then
    ``(tau_L + tau_R) / r = sum F_si`` gives ``v* = tan(pi/2 * 4 tau / (r mu_s m g)) / k_s``.

    Returns:
        ``max_abs_wz`` (must be exactly 0), ``steady_residual`` (relative residual of
        ``(tau_L + tau_R)/r - sum F_si`` at the end, with the model's ``rbar``), ``speed_error``
        (relative error of the final speed against ``v*``) and ``max_abs_vy_world`` (largest
        lateral world velocity, exactly 0 on a straight run along x).
    """
    p = model.params
    drive = 4.0 * tau / p.r
    if not drive < p.mu_s * p.m * p.g:
        raise ValueError(f"tau = {tau} gives no steady speed: 4 tau must be < r mu_s m g")
    ctrl_dt = model.default_ctrl_dt
    n_ctrl = int(round(duration / ctrl_dt))
    run = simulate(model, np.zeros(5), np.full((n_ctrl, 4), tau), ctrl_dt, model.n_substeps())
    end = run[-1]
    v_star = math.tan(0.5 * math.pi * drive / (p.mu_s * p.m * p.g)) / p.k_s
    residual = abs(drive - model.rbar(end)[0]) / drive
    return {
        "max_abs_wz": float(np.max(np.abs(run[:, 4]))),
        "max_abs_y": float(np.max(np.abs(run[:, 1]))),
        "steady_residual": float(residual),
        "speed_error": abs(end[3] - v_star) / v_star,
    }


def skid_steer_turn(model, tau: float = 10.0, duration: float = 15.0) -> dict[str, float]:
    """Opposite side torques (``-tau`` left, ``+tau`` right) from rest: turning on the spot.

    The steady state of SS-3, ``Bbar tau = Cbar(eta) eta + Rbar(eta)``, is solved with the
    model's ``bbar``/``cbar``/``rbar`` by nested bisection (``vx`` from the first row for a
    given ``wz``, then ``wz`` from the second row). A steady rate exists while the yaw moment
    ``2 c tau / r`` stays below the largest friction moment (about 90 N·m at the defaults,
    ``tau`` < 13 N·m).

    Returns:
        ``wz_error`` and ``vx_error`` (simulated final values against the steady state,
        relative to the steady ``wz``), ``wz_steady``, ``vx_steady``, and ``icr_residual``:
        the largest ``|vy + x_icr wz|`` along the run, ``vy`` recovered from the derivative's
        world velocity as ``-sin(yaw) xdot + cos(yaw) ydot`` (SS-1).
    """
    u = np.array([-tau, -tau, tau, tau])
    drive = model.bbar() @ np.array([u[0] + u[1], u[2] + u[3]])

    def eta_rows(vx: float, wz: float) -> np.ndarray:
        x = np.array([0.0, 0.0, 0.0, vx, wz])
        return drive - model.cbar(x) @ np.array([vx, wz]) - model.rbar(x)

    p = model.params
    vmax = 10.0
    # Row 1 has a root in vx only while the centripetal term m |x_icr| wz^2 stays below the
    # largest rolling resistance mu_s m g: that bounds the bracket of wz.
    wz_hi = 0.9 * math.sqrt(p.mu_s * p.g / abs(p.x_icr)) if p.x_icr != 0 else 50.0

    def vx_of(wz: float) -> float:
        return _bisect(lambda vx: eta_rows(vx, wz)[0], -vmax, vmax)

    wz_s = _bisect(lambda wz: eta_rows(vx_of(wz), wz)[1], 1e-9, wz_hi)
    vx_s = vx_of(wz_s)
    ctrl_dt = model.default_ctrl_dt
    n_ctrl = int(round(duration / ctrl_dt))
    run = simulate(model, np.zeros(5), np.tile(u, (n_ctrl, 1)), ctrl_dt, model.n_substeps())
    xdot = model.derivative(run, np.tile(u, (n_ctrl + 1, 1)))
    yaw = run[:, 2]
    vy = -np.sin(yaw) * xdot[:, 0] + np.cos(yaw) * xdot[:, 1]
    icr = np.max(np.abs(vy + model.params.x_icr * run[:, 4]))
    return {
        "wz_steady": wz_s,
        "vx_steady": vx_s,
        "wz_error": abs(run[-1, 4] - wz_s) / abs(wz_s),
        "vx_error": abs(run[-1, 3] - vx_s) / abs(wz_s),
        "icr_residual": float(icr),
    }


# ---------------------------------------------------------------------------- the report
def _has(model: Model, *names: str) -> bool:
    return all(callable(getattr(model, n, None)) for n in names)


def run_checks(classes: Sequence[type[Model]] | None = None) -> list[CheckResult]:
    """All applicable checks on the default parameters of ``classes`` (default: all models)."""
    from wheelgym.models import SkidSteer

    rows: list[CheckResult] = []

    def add(check: str, model: Model, figure: float, bound: str, passed: bool) -> None:
        rows.append(CheckResult(check, type(model).__name__, float(figure), bound, bool(passed)))

    b = BOUNDS
    for cls in model_classes() if classes is None else classes:
        model = cls()
        if _has(model, "stiffness"):
            f = stiffness_margin(model)
            add("stiffness x sim_dt", model, f, f"< {b['stiffness']:.4g}", f < b["stiffness"])
        f = rk4_order_ratio(model)
        add("RK4 order: error(h)/error(h/2)", model, f, "16 +- 25%",
            b["order_lo"] <= f <= b["order_hi"])
        f = step_refinement_error(model)
        add("5 s manoeuvre: sim_dt vs sim_dt/8", model, f, f"< {b['refinement']:.0e}",
            f < b["refinement"])
        if _has(model, "kinetic_energy", "motor_power", "friction_power"):
            f = energy_balance_error(model)
            add("energy balance (relative)", model, f, f"< {b['energy']:.0e}", f < b["energy"])
            if getattr(model, "friction_params", ()):
                f = energy_conservation_error(model)
                add("energy conserved, no friction/torque", model, f,
                    f"< {b['conservation']:.0e}", f < b["conservation"])
        f = batch_mismatches(model)
        add("batch of 1000 == one by one (entries differing)", model, f, "== 0", f == 0)
        if isinstance(model, SkidSteer):
            s = skid_steer_straight(model)
            add("SS straight: max abs(wz), abs(y)", model, max(s["max_abs_wz"], s["max_abs_y"]),
                "== 0", s["max_abs_wz"] == 0 and s["max_abs_y"] == 0)
            add("SS straight: (tau_L+tau_R)/r = sum F_si", model, s["steady_residual"],
                f"< {b['ss_steady']:.0e}", s["steady_residual"] < b["ss_steady"])
            add("SS straight: speed vs tan() closed form", model, s["speed_error"],
                f"< {b['ss_steady']:.0e}", s["speed_error"] < b["ss_steady"])
            t = skid_steer_turn(model)
            f = max(t["wz_error"], t["vx_error"])
            add(f"SS turn: rate vs SS-3 steady {t['wz_steady']:.4f} rad/s", model, f,
                f"< {b['ss_steady']:.0e}", f < b["ss_steady"])
            add("SS turn: ICR residual max abs(vy + x_icr wz)", model, t["icr_residual"],
                f"< {b['ss_icr']:.0e}", t["icr_residual"] < b["ss_icr"])
    return rows


def format_table(rows: Sequence[CheckResult]) -> str:
    """Markdown table of the rows."""
    lines = ["| check | model | measured | bound | pass |", "| --- | --- | --- | --- | --- |"]
    for r in rows:
        lines.append(f"| {r.check} | {r.model} | {r.figure:.3g} | {r.bound} | "
                     f"{'yes' if r.passed else 'NO'} |")
    return "\n".join(lines)


def main(argv: Sequence[str] | None = None) -> int:
    """Print the validation table; exit code 1 if any check fails."""
    parser = argparse.ArgumentParser(prog="python -m wheelgym.validate", description=__doc__
                                     .splitlines()[0])
    names = [c.__name__ for c in model_classes()]
    parser.add_argument("--model", action="append", choices=names,
                        help="validate only this model (repeatable); default: all")
    args = parser.parse_args(argv)
    classes = [c for c in model_classes() if args.model is None or c.__name__ in args.model]
    rows = run_checks(classes)
    sys.stdout.write(format_table(rows) + "\n")
    failed = [r for r in rows if not r.passed]
    sys.stdout.write(f"\n{len(rows) - len(failed)}/{len(rows)} checks passed\n")
    return 1 if failed else 0


if __name__ == "__main__":
    raise SystemExit(main())
