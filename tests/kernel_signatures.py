"""What a numba dispatcher was compiled for, for the tests that check one signature serves
every caller (:func:`wheelgym.integrators.kernel_array`)."""

from __future__ import annotations

from typing import Any

import numba


def read_only_arrays(dispatcher: Any) -> list[Any]:
    """The read-only array types among ``dispatcher``'s compiled (or cache-loaded)
    signatures: each would be a compile of its own."""
    return [t for sig in dispatcher.signatures for t in sig
            if isinstance(t, numba.types.Array) and not t.mutable]
