"""Keep numba's disk cache consistent with the files a cached kernel inlines.

numba keys a cached kernel on its own source file only. wheelgym's kernels inline compiled
pieces from other files (every model inlines ``integrators.rk4_inplace`` and
``friction.sgn_s``; the environment and controller kernels inline the models' derivatives), so
an edit there would otherwise leave a stale compiled kernel (seen in practice: a kernel cached
against a temporarily edited model kept the old physics). :func:`guard`, called at import by
each such module, records the sizes and modification times of its dependencies next to the
cache and drops the module's cache files when they change. A fresh checkout has no cache, so
this only matters to someone editing the package.
"""

from __future__ import annotations

import glob
import os


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
