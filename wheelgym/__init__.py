"""wheelgym: Gymnasium environments for wheeled mobile robots with real physics.

``import wheelgym`` registers the ``wheelgym/<Robot>-v0`` ids and loads nothing heavy: the
subpackages (``wheelgym.models``, ``wheelgym.control``, ``wheelgym.envs``, ...) are imported on
first attribute access, so ``wheelgym.baseline(env)`` (the analytic baseline policy,
:mod:`wheelgym.envs.baseline`) works after a bare ``import wheelgym`` without loading numba or
the models at start-up.

Gymnasium 1.x reads no plugin entry points, so a process that has not imported wheelgym makes
its envs through the module prefix, which imports it first::

    gym.make("wheelgym:wheelgym/ThreeWheel-v0")            # no `import wheelgym` needed
    gym.make_vec("wheelgym:wheelgym/ThreeWheel-v0", num_envs=8)

The same prefix lets subprocess workers that start fresh (``spawn``/``forkserver``: SB3's
``SubprocVecEnv``, Gymnasium's ``AsyncVectorEnv``) register the ids themselves.
"""

from __future__ import annotations

import importlib
from types import ModuleType
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:  # pragma: no cover
    from wheelgym.envs.baseline import BaselinePolicy

__version__ = "0.1.0"

#: Subpackages and modules reachable as attributes of ``wheelgym`` (imported on first access).
SUBMODULES = (
    "agents",
    "cli",
    "control",
    "envs",
    "integrators",
    "kinematics",
    "models",
    "registration",
    "render",
    "resources",
    "tasks",
    "validate",
    "vector",
    "world",
)

__all__ = ["__version__", "baseline", "register_envs", *SUBMODULES]


def register_envs() -> None:
    """Register the ``wheelgym/<Robot>-v0`` ids (done on ``import wheelgym``; idempotent)."""
    from wheelgym.registration import register_envs as _register

    _register()


def baseline(env: Any, **kwargs: Any) -> BaselinePolicy:
    """The analytic baseline policy of a wheelgym environment (single, wrapped or vector):
    :func:`wheelgym.envs.baseline.baseline`, imported on first call."""
    from wheelgym.envs.baseline import baseline as _baseline

    return _baseline(env, **kwargs)


def __getattr__(name: str) -> ModuleType:
    """Import ``wheelgym.<name>`` on first access (PEP 562)."""
    if name in SUBMODULES:
        module = importlib.import_module(f"{__name__}.{name}")
        globals()[name] = module
        return module
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted({*globals(), *SUBMODULES})


register_envs()
