"""wheelgym: Gymnasium environments for wheeled mobile robots with real physics."""

__version__ = "0.1.0"
