"""The client tests need the optional ``clients`` extra (``pip install -e .[clients]``; the
Makefile's venv has it). Without it they are skipped, except under CI (``CI`` set), where a
missing library is an install step gone missing and fails the run."""

from __future__ import annotations

import importlib
import os
from types import ModuleType

import pytest


def require(module: str, name: str) -> ModuleType:
    """``module`` imported; skipped with a reason when it is missing (failed under CI)."""
    if os.environ.get("CI"):
        return importlib.import_module(module)
    return pytest.importorskip(module, reason=f"{name} is in the optional 'clients' extra "
                                              "(pip install -e .[clients])")
