"""Keep the numba disk cache of the control kernels consistent with the files they inline.

numba keys a cached kernel on its own source file only. The controller kernels inline the
models' compiled pieces (``wheelgym.models.three_wheel``, ``skid_steer``, ``friction``) and
the distribution functions, so an edit there would otherwise leave a stale compiled kernel
(seen in practice: a kernel cached against a temporarily edited model kept the old physics).
:func:`guard` records the sizes and modification times of the dependencies next to the cache
and drops the module's cache files when they change.
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
