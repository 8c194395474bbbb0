"""Package list of the wheel; the rest of the packaging is in ``pyproject.toml``.

Every ``wheelgym*`` package of the tree, found as it is built (a new subpackage needs no entry
here), plus the two folders that stay at the top level of the repository and ship inside the
package: ``configs/`` as ``wheelgym/configs`` and ``agents/pretrained/`` as
``wheelgym/pretrained`` (``package-dir`` and ``package-data`` in ``pyproject.toml``;
:mod:`wheelgym.resources` finds them in either layout).
"""

from setuptools import find_namespace_packages, setup

SHIPPED_DATA = ["wheelgym.configs", "wheelgym.pretrained"]

setup(packages=[*find_namespace_packages(include=["wheelgym", "wheelgym.*"],
                                         exclude=["*.__pycache__", *SHIPPED_DATA]),
                *SHIPPED_DATA])
