"""The client tests need the optional ``clients`` extra (``pip install -e .[clients]``; the
Makefile's venv has it). Without it they are skipped, except under CI (``CI`` set), where a
missing library is an install step gone missing and fails the run.

TorchRL and skrl switch torch's distribution argument checks off for the whole process when
they are imported; tests/conftest.py turns them back on before every test, and the client tests
run with them off, as those libraries set them."""

from __future__ import annotations

import importlib
import os
import sys
from collections.abc import Iterator
from types import ModuleType

import pytest


def require(module: str, name: str) -> ModuleType:
    """``module`` imported; skipped with a reason when it is missing (failed under CI)."""
    if os.environ.get("CI"):
        return importlib.import_module(module)
    return pytest.importorskip(module, reason=f"{name} is in the optional 'clients' extra "
                                              "(pip install -e .[clients])")


@pytest.fixture(autouse=True)
def _client_validate_args() -> Iterator[None]:
    """Each client test with torch's distribution checks off, as TorchRL and skrl set them
    (tests/conftest.py turns them on again before the next test)."""
    dist = sys.modules.get("torch.distributions")
    if dist is not None:
        dist.Distribution.set_default_validate_args(False)
    yield
