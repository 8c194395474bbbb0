"""Keep numba's disk cache consistent with the files a cached kernel inlines.

numba keys a cached kernel on its own source file only. wheelgym's kernels inline compiled
pieces from other files (every model inlines ``integrators.rk4_inplace`` and
``friction.sgn_s``; the environment and controller kernels inline the models' derivatives), so
an edit there would otherwise leave a stale compiled kernel (seen in practice: a kernel cached
against a temporarily edited model kept the old physics). :func:`guard`, called at import by
each such module, records the sizes and modification times of its dependencies next to the
cache and drops the module's cache files when they change. A fresh checkout has no cache, so
this only matters to someone editing the package.

:func:`announce` prints one line when a long compile starts (``wheelgym: compiling the
ThreeWheel kernels (first use only, ~10 s)``), and nothing when the kernels load from the cache.
"""

from __future__ import annotations

import glob
import logging
import os

from numba.core import event


def guard(module_file: str, *dep_modules: str) -> None:
    """Drop ``module_file``'s numba cache if it or a dependency changed since it was written.

    Args:
        module_file: the ``__file__`` of the module whose kernels are cached.
        dep_modules: ``__file__`` paths of the modules its kernels call into.
    """
    here = os.path.dirname(os.path.abspath(module_file))
    stem = os.path.splitext(os.path.basename(module_file))[0]
    cache_dir = os.path.join(here, "__pycache__")
    files = [os.path.abspath(module_file), *(os.path.abspath(d) for d in dep_modules)]
    try:
        stamp = ";".join(f"{f}:{os.stat(f).st_size}:{os.stat(f).st_mtime_ns}" for f in files)
    except OSError:
        return
    marker = os.path.join(cache_dir, f"{stem}.deps")
    try:
        with open(marker) as fh:
            if fh.read() == stamp:
                return
    except OSError:
        pass
    try:
        for f in glob.glob(os.path.join(cache_dir, f"{stem}.*.nb[ic]")):
            os.remove(f)
        os.makedirs(cache_dir, exist_ok=True)
        with open(marker, "w") as fh:
            fh.write(stamp)
    except OSError:  # read-only install: numba then compiles in memory
        pass


# ---------------------------------------------------------------------------- compile notice
#: Kernels whose first compile takes long: ``id(dispatcher) -> (what, seconds)``.
_NOTICES: dict[int, tuple[str, float]] = {}
_SAID: set[str] = set()
_LISTENING = False

#: The logger of the notice (``logging.getLogger("wheelgym")``): a WARNING-level record,
#: which Python prints on stderr when the application configured no logging; silence it
#: with ``logging.getLogger("wheelgym").setLevel(logging.ERROR)``.
LOGGER_NAME = "wheelgym"


def announce(what: str, seconds: float, *kernels: object) -> None:
    """Say on screen (one ``logging`` record of the ``"wheelgym"`` logger) that ``what`` is
    compiling, once per process, when numba starts to compile any of ``kernels`` (numba
    dispatchers; None entries are skipped): ``wheelgym: compiling the ThreeWheel kernels (first
    use only, ~10 s)``. A load from the disk cache is no compile and says nothing.

    Args:
        what: what compiles (``"the ThreeWheel kernels"``), one notice per ``what``.
        seconds: the compile time to announce (measured: ``benchmarks/coldstart.py``).
        kernels: the kernels whose compile starts it.
    """
    global _LISTENING
    for k in kernels:
        if k is not None:
            _NOTICES[id(k)] = (what, seconds)
    if not _LISTENING:
        event.register("numba:compile", _Notice())
        _LISTENING = True


def _say(dispatcher: object) -> None:
    hit = _NOTICES.get(id(dispatcher))
    if hit is None or hit[0] in _SAID:
        return
    what, seconds = hit
    _SAID.add(what)
    logging.getLogger(LOGGER_NAME).warning(
        "wheelgym: compiling %s (first use only, ~%.0f s)", what, seconds)


class _Notice(event.Listener):
    """numba's compile events: the notice of :func:`announce` when a kernel's compile starts
    (numba fires them after a cache miss only)."""

    def on_start(self, ev: event.Event) -> None:
        _say(ev.data.get("dispatcher"))

    def on_end(self, ev: event.Event) -> None:
        pass
