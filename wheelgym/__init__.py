"""wheelgym: Gymnasium environments for wheeled mobile robots with real physics."""

__version__ = "0.1.0"


def register_envs() -> None:
    """Register the ``wheelgym/<Robot>-v0`` ids (also the ``gymnasium.envs`` entry point)."""
    from wheelgym.registration import register_envs as _register

    _register()


register_envs()
