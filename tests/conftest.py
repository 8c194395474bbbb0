"""Fixtures of the whole suite."""

from __future__ import annotations

import sys
from collections.abc import Iterator

import pytest


@pytest.fixture(autouse=True)
def _torch_distribution_checks() -> Iterator[None]:
    """Every test starts with torch's default distribution argument checks. TorchRL and skrl
    switch them off for the whole process when imported (tests/clients imports them at
    collection), and a worker that collected those modules would run every later test without
    them (a diverged policy then reaches the env as NaN instead of raising inside torch)."""
    dist = sys.modules.get("torch.distributions")
    if dist is not None:
        dist.Distribution.set_default_validate_args(__debug__)
    yield
