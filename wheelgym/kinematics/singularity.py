"""Singularity analysis of caster robots for a choice of input joints (docs/physics/three-wheel.md
TW-2, docs/physics/caster-robots.md).

Both caster robots have a joint Jacobian ``qdot = J(config) u`` from their model (one
implementation: :meth:`ThreeWheel.jacobian` of TW-1, :meth:`CasterAGV.jacobian`). Choosing a set
``S`` of joints as the measured or driven inputs keeps the rows ``J_S``; the forward kinematics
``u = J_S^-1 qdot_S`` exists where ``det J_S != 0`` (three-wheel paper (7)-(11), whose choice
is ``S = (drive_1, drive_2, steer_3)``; the caster-singularity paper identifies the singular
configurations by this determinant).

| robot      | config                  | twist ``u``      | joints                                |
|------------|-------------------------|------------------|---------------------------------------|
| ThreeWheel | ``(psi_1, psi_2, psi_3)`` | ``(vx, vy, wz)`` | ``drive_1..3``, ``steer_1..3``      |
| CasterAGV  | ``(sigma,)``            | ``(v, w)``       | ``drive_L``, ``drive_R``,             |
|            |                         |                  | ``caster_drive``, ``caster_steer``    |

With more joints than degrees of freedom (redundant sensing/actuation, e.g. all six ThreeWheel
joints) ``J_S`` is tall: the measure of singularity is then its smallest singular value (rank
loss), and the "determinant" is ``sqrt(det(J_S^T J_S))``, the product of the singular values.

The rows of ``J_S`` carry units (rad/s per m/s and per rad/s) and so do the condition number
and the determinant; singularity tests use the scale-free ratio ``s_min / s_max``.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from typing import Any

import numpy as np

from wheelgym.models.elementwise import wrap_angle

__all__ = ["SingularConfigurationError", "SingularityAnalysis", "SingularScan"]


class SingularConfigurationError(ValueError):
    """The forward kinematics was asked for at a singular configuration of ``J_S``."""


def _model_info(model: Any) -> tuple[tuple[str, ...], tuple[str, ...]]:
    """(joint names, configuration names) of a supported model."""
    from wheelgym.models.caster_agv import CasterAGV
    from wheelgym.models.three_wheel import ThreeWheel

    if isinstance(model, ThreeWheel):
        return tuple(model.input_names), ("psi_1", "psi_2", "psi_3")
    if isinstance(model, CasterAGV):
        return tuple(model.joint_names), ("sigma",)
    raise TypeError(
        f"model must be a ThreeWheel or a CasterAGV instance, got {type(model).__name__}"
    )


@dataclasses.dataclass(frozen=True)
class SingularScan:
    """Result of :meth:`SingularityAnalysis.scan`.

    Attributes:
        joints: the input-joint choice S.
        config_names: names of the configuration coordinates.
        configs: singular configurations found, shape ``(K, n_config)`` (rad).
        ratio: ``s_min / s_max`` of ``J_S`` at each of them, shape ``(K,)``.
        min_ratio: smallest ``s_min / s_max`` over the whole grid (how close S comes to a
            singularity; 0 for an always-singular choice).
        active: configuration coordinates ``J_S`` depends on (the scanned ones).
        always_singular: ``J_S`` is singular everywhere (then ``configs`` is empty).
    """

    joints: tuple[str, ...]
    config_names: tuple[str, ...]
    configs: np.ndarray
    ratio: np.ndarray
    min_ratio: float
    active: tuple[str, ...]
    always_singular: bool

    def __len__(self) -> int:
        return int(self.configs.shape[0])


class SingularityAnalysis:
    """``J_S``, its determinant and conditioning, forward kinematics and a singularity scan.

    Args:
        model: a :class:`~wheelgym.models.ThreeWheel` or :class:`~wheelgym.models.CasterAGV`.
        joints: the input joints S by name (at least as many as the robot's degrees of
            freedom), e.g. ``("drive_1", "drive_2", "steer_3")``.

    Raises:
        ValueError: on an unknown or repeated joint name (the message lists the valid ones),
            or too few joints.
        TypeError: on an unsupported model.

    Configurations are arrays ``(..., n_config)`` (for CasterAGV ``n_config = 1``).
    """

    def __init__(self, model: Any, joints: Sequence[str]):
        names, cfg = _model_info(model)
        if isinstance(joints, str):
            raise TypeError("joints must be a sequence of joint names, not a single string")
        joints = tuple(joints)
        unknown = [j for j in joints if j not in names]
        if unknown:
            raise ValueError(
                f"unknown joint(s) {unknown} for {type(model).__name__}; valid joints: "
                f"{list(names)}"
            )
        if len(set(joints)) != len(joints):
            raise ValueError(f"joints must not repeat, got {list(joints)}")
        self.model = model
        self.joints = joints
        self.joint_names = names
        self.config_names = cfg
        self.rows = np.array([names.index(j) for j in joints])
        self.n_config = len(cfg)
        self.n_dof = 2 if len(cfg) == 1 else 3
        if len(joints) < self.n_dof:
            raise ValueError(
                f"choose at least {self.n_dof} joints (the robot's degrees of freedom) for a "
                f"forward kinematics, got {len(joints)}: {list(joints)}"
            )
        self.square = len(joints) == self.n_dof

    # ------------------------------------------------------------------ pieces
    def _config(self, config: Any) -> np.ndarray:
        c = np.asarray(config, dtype=np.float64)
        if self.n_config == 1 and (c.ndim == 0 or c.shape[-1] != 1):
            c = c[..., None]
        if c.shape[-1] != self.n_config:
            raise ValueError(
                f"config must have shape (..., {self.n_config}) ({', '.join(self.config_names)})"
                f", got {c.shape}"
            )
        if not np.all(np.isfinite(c)):
            raise ValueError("config must be finite")
        return c

    def full_jacobian(self, config: Any) -> np.ndarray:
        """The model's joint Jacobian, shape ``(..., n_joints, n_dof)``."""
        c = self._config(config)
        arg = c[..., 0] if self.n_config == 1 else c
        return self.model.jacobian(arg)

    def jacobian(self, config: Any) -> np.ndarray:
        """``J_S``: the rows of the chosen joints, shape ``(..., len(S), n_dof)``."""
        return self.full_jacobian(config)[..., self.rows, :]

    def singular_values(self, config: Any) -> np.ndarray:
        """Singular values of ``J_S``, descending, shape ``(..., n_dof)``."""
        return np.linalg.svd(self.jacobian(config), compute_uv=False)

    def det(self, config: Any) -> np.ndarray:
        """``det J_S`` (square S), or ``sqrt(det(J_S^T J_S))`` (redundant S); shape ``(...)``."""
        j = self.jacobian(config)
        if self.square:
            return np.linalg.det(j)
        return np.sqrt(np.maximum(np.linalg.det(np.swapaxes(j, -1, -2) @ j), 0.0))

    def condition_number(self, config: Any) -> np.ndarray:
        """2-norm condition number ``s_max / s_min`` of ``J_S`` (``inf`` at rank loss)."""
        s = self.singular_values(config)
        with np.errstate(divide="ignore"):
            return np.where(s[..., -1] > 0, s[..., 0] / np.where(s[..., -1] > 0, s[..., -1], 1),
                            np.inf)

    def ratio(self, config: Any) -> np.ndarray:
        """Scale-free distance to singularity ``s_min / s_max`` of ``J_S`` (0 = singular)."""
        s = self.singular_values(config)
        return s[..., -1] / s[..., 0]

    def is_singular(self, config: Any, tol: float = 1e-9) -> np.ndarray:
        """``s_min / s_max < tol``, shape ``(...)``."""
        return self.ratio(config) < tol

    # ------------------------------------------------------------------ kinematics
    def inverse(self, config: Any, u: Any) -> np.ndarray:
        """Inverse kinematics ``qdot_S = J_S u`` (rad/s), shape ``(..., len(S))``."""
        return np.einsum("...ij,...j->...i", self.jacobian(config), np.asarray(u, float))

    def forward(self, config: Any, qdot_s: Any, tol: float = 1e-9) -> np.ndarray:
        """Forward kinematics ``u = J_S^-1 qdot_S`` (least squares for a redundant S).

        Args:
            config: configuration(s) ``(..., n_config)``.
            qdot_s: rates of the chosen joints ``(..., len(S))`` (rad/s).
            tol: a configuration with ``s_min / s_max < tol`` counts as singular.

        Raises:
            SingularConfigurationError: at a singular configuration (the body twist is not
                determined by the chosen joints' rates there).
        """
        j = self.jacobian(config)
        q = np.asarray(qdot_s, dtype=np.float64)
        if q.shape[-1:] != (len(self.joints),):
            raise ValueError(f"qdot_s must have shape (..., {len(self.joints)}), got {q.shape}")
        lead = np.broadcast_shapes(j.shape[:-2], q.shape[:-1])
        j = np.broadcast_to(j, lead + j.shape[-2:])
        q = np.broadcast_to(q, lead + q.shape[-1:])
        s = np.linalg.svd(j, compute_uv=False)
        bad = s[..., -1] < tol * s[..., 0]
        if np.any(bad):
            cfg = np.broadcast_to(self._config(config), lead + (self.n_config,))[bad][0]
            raise SingularConfigurationError(
                f"J_S is singular for joints {list(self.joints)} at "
                f"{dict(zip(self.config_names, np.round(cfg, 12).tolist(), strict=True))} "
                f"(s_min / s_max = {float(np.min(s[bad][..., -1] / s[bad][..., 0])):.3g} < "
                f"{tol}); these joint rates do not determine the body twist there"
            )
        if self.square:
            return np.linalg.solve(j, q[..., None])[..., 0]
        jt = np.swapaxes(j, -1, -2)
        return np.linalg.solve(jt @ j, (jt @ q[..., None]))[..., 0]

    # ------------------------------------------------------------------ scans
    def active(self) -> tuple[int, ...]:
        """Indices of the configuration coordinates ``J_S`` depends on."""
        if self.n_config == 1:
            uses = any(j.startswith("caster") for j in self.joints)
            return (0,) if uses else ()
        return tuple(i for i in range(3)
                     if f"drive_{i + 1}" in self.joints or f"steer_{i + 1}" in self.joints)

    def det_grid(
        self, axes: tuple[int, int] = (0, 1), n: int = 181, fixed: Any = None
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``det J_S`` on an ``n x n`` grid of two configuration coordinates over [-pi, pi].

        Args:
            axes: the two coordinates (indices into :attr:`config_names`); ThreeWheel only.
            n: points per axis.
            fixed: values of the other coordinates (default zeros).

        Returns:
            ``(a, b, det)`` with ``a``, ``b`` the grid vectors and ``det`` of shape ``(n, n)``
            (``det[i, j]`` at ``a[i]``, ``b[j]``).
        """
        if self.n_config < 2:
            raise ValueError("det_grid needs two configuration coordinates (ThreeWheel)")
        i, k = axes
        if i == k or not (0 <= i < self.n_config and 0 <= k < self.n_config):
            raise ValueError(f"axes must be two different indices in 0..{self.n_config - 1}")
        g = np.linspace(-np.pi, np.pi, int(n))
        base = np.zeros(self.n_config) if fixed is None else self._config(fixed).reshape(-1)
        cfg = np.broadcast_to(base, (len(g), len(g), self.n_config)).copy()
        cfg[..., i] = g[:, None]
        cfg[..., k] = g[None, :]
        return g, g, self.det(cfg)

    def scan(self, n: int = 73, fixed: Any = None, tol: float = 1e-9) -> SingularScan:
        """Singular configurations of S on a grid, refined to round-off.

        The coordinates ``J_S`` depends on are sampled on a periodic grid of ``n`` points per
        axis over [-pi, pi) (the others held at ``fixed``, default 0). For a square ``J_S``,
        every sign change of ``det J_S`` along the last active coordinate is refined by
        bisection to the zero (so ``det`` vanishes there to round-off); a double root that
        touches zero without a sign change is reported at the grid point if its ratio
        ``s_min / s_max`` is below ``tol``. For a redundant S, grid points with
        ``s_min / s_max < tol`` are reported.

        Returns:
            A :class:`SingularScan`.
        """
        n = int(n)
        if n < 4:
            raise ValueError(f"n must be >= 4, got {n}")
        act = self.active()
        base = np.zeros(self.n_config) if fixed is None else self._config(fixed).reshape(-1)
        g = -np.pi + 2.0 * np.pi * np.arange(n) / n
        if act:
            mesh = np.meshgrid(*([g] * len(act)), indexing="ij")
        else:
            mesh = []
        shape = tuple(len(g) for _ in act)
        cfg = np.broadcast_to(base, shape + (self.n_config,)).copy()
        for ax, m in zip(act, mesh, strict=True):
            cfg[..., ax] = m
        ratio = self.ratio(cfg)
        min_ratio = float(np.min(ratio))
        names = tuple(self.config_names[a] for a in act)
        empty = np.zeros((0, self.n_config))
        if np.max(ratio) < tol:
            return SingularScan(self.joints, self.config_names, empty, np.zeros(0), min_ratio,
                                names, True)
        found = [cfg[ratio < tol]]
        if self.square and act:
            last = act[-1]
            det = self.det(cfg)
            nxt = np.roll(det, -1, axis=-1)
            bracket = (det * nxt < 0) & (ratio >= tol) & (np.roll(ratio, -1, axis=-1) >= tol)
            lo = cfg[bracket]
            if len(lo):
                hi = lo.copy()
                hi[:, last] += 2.0 * np.pi / n
                found.append(self._bisect(lo, hi, last))
        configs = np.concatenate(found, axis=0) if found else empty
        configs = configs[np.lexsort(configs.T[::-1])] if len(configs) else empty
        return SingularScan(self.joints, self.config_names, configs, self.ratio(configs)
                            if len(configs) else np.zeros(0), min_ratio, names, False)

    def _bisect(self, lo: np.ndarray, hi: np.ndarray, axis: int) -> np.ndarray:
        """Refine sign changes of det along ``axis`` (vectorized bisection to round-off)."""
        f_lo = self.det(lo)
        for _ in range(200):
            mid = lo.copy()
            mid[:, axis] = 0.5 * (lo[:, axis] + hi[:, axis])
            f_mid = self.det(mid)
            left = f_lo * f_mid <= 0.0
            hi[left] = mid[left]
            lo[~left] = mid[~left]
            f_lo[~left] = f_mid[~left]
            if np.all(np.abs(hi[:, axis] - lo[:, axis]) <= 4 * np.spacing(np.abs(hi[:, axis]))):
                break
        # of the two ends of each final bracket, keep the one with the smaller |det|
        f_hi = self.det(hi)
        out = np.where((np.abs(f_lo) <= np.abs(f_hi))[:, None], lo, hi)
        out[:, axis] = wrap_angle(out[:, axis])
        return out
