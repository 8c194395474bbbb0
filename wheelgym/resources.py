"""Where wheelgym's shipped files are, and where its outputs go by default.

This module is the one place that answers "where is config X, agent Y, the default output
folder". The configs and the pretrained agents live at the top level of the repository
(``configs/``, ``agents/pretrained/``); the wheel carries them inside the package
(``pyproject.toml`` maps them there), and :mod:`importlib.resources` finds them in either
layout:

=================== ====================================== ===================================
what                installed from a wheel                 source checkout, editable install
=================== ====================================== ===================================
configs             ``wheelgym/configs/*.yml``             the repository's ``configs/``
pretrained agents   ``wheelgym/pretrained/<NAME>/``        the repository's ``agents/pretrained/``
run folders         ``runs/`` in the current folder        the same
results CSV         ``runs/benchmark/training.csv``        the repository's
                                                           ``benchmarks/results/training.csv``
=================== ====================================== ===================================

Rules (``docs/topics/install-details.md``):

- An explicit path given by the user wins: a ``CONFIG`` argument naming an existing file is that
  file. Otherwise it must be the name of a shipped config (``ThreeWheel-goal-velocity``, the
  ``.yml`` optional); an unknown name is a ``ValueError`` naming the argument and listing the
  shipped names.
- The current folder never stands in for the shipped files: a ``./configs`` folder of the
  user's own is not read unless its files are given as paths.
- ``$WHEELGYM_PRETRAINED`` (:data:`PRETRAINED_ENV`) names another folder of agents.

This module imports nothing of wheelgym (bottom layer, ``ARCHITECTURE.md``).
"""

from __future__ import annotations

import difflib
import os
from importlib import resources as _ilr
from pathlib import Path

__all__ = [
    "PRETRAINED_ENV",
    "RUNS",
    "DEFAULT_CONFIG",
    "package_root",
    "repository_root",
    "configs_dir",
    "config_names",
    "config_path",
    "default_config",
    "pretrained_dir",
    "runs_dir",
    "results_csv",
    "results_dir",
]

#: Environment variable naming another folder of pretrained agents (tests, private agents).
PRETRAINED_ENV = "WHEELGYM_PRETRAINED"

#: Default root of every output folder (run folders, evaluations, studies, benchmark runs),
#: relative to the current folder.
RUNS = Path("runs")

#: Name of the main job's config (``wheelgym main``): the three-wheel robot on the goal task.
DEFAULT_CONFIG = "ThreeWheel-goal-velocity"

#: Shipped folders: name inside the package (wheel) -> path in the repository (checkout).
_SHIPPED = {"configs": Path("configs"), "pretrained": Path("agents") / "pretrained"}

#: What each shipped folder holds, for the messages.
_WHAT = {"configs": "configs", "pretrained": "pretrained agents"}

_CONFIG_SUFFIXES = (".yml", ".yaml")


def package_root() -> Path:
    """The installed ``wheelgym`` package folder, through :func:`importlib.resources.files`."""
    root = _ilr.files(__package__ or "wheelgym")
    if not isinstance(root, Path):  # e.g. a zip import: the shipped files need a real folder
        raise ValueError(f"wheelgym is installed as {root!r}, not as a folder; install the "
                         "wheel with pip (unzipped) to use its configs and agents")
    return root


def repository_root() -> Path | None:
    """The source checkout the package is imported from (its ``pyproject.toml`` names
    wheelgym), or ``None`` for an installed wheel."""
    parent = package_root().parent
    project = parent / "pyproject.toml"
    try:
        text = project.read_text(encoding="utf-8")
    except OSError:
        return None
    return parent if 'name = "wheelgym"' in text else None


def _shipped(kind: str) -> Path:
    """The folder of shipped ``kind`` files (``"configs"`` or ``"pretrained"``)."""
    inside = package_root() / kind
    if inside.is_dir():
        return inside
    repo = repository_root()
    if repo is not None and (repo / _SHIPPED[kind]).is_dir():
        return repo / _SHIPPED[kind]
    where = [str(inside)] + ([str(repo / _SHIPPED[kind])] if repo is not None else [])
    raise ValueError(f"wheelgym's shipped {_WHAT[kind]} are missing (looked in {where}): a wheel "
                     "built without its package data? Reinstall wheelgym")


def configs_dir() -> Path:
    """The folder of the shipped configs (``wheelgym/configs`` or the checkout's ``configs/``)."""
    return _shipped("configs")


def config_names() -> list[str]:
    """Sorted names of the shipped configs (file names without ``.yml``)."""
    return sorted(p.stem for p in configs_dir().iterdir()
                  if p.is_file() and p.suffix in _CONFIG_SUFFIXES)


def config_path(config: str | Path, argument: str = "CONFIG") -> Path:
    """The config file meant by a user's ``config``: an existing file, else a shipped name.

    ``config`` is a path to a YAML file (it wins when it exists) or the name of a shipped config
    (``"ThreeWheel-goal-velocity"``, ``.yml`` optional). ``argument`` names the option in the
    error: ``ValueError`` listing the shipped names when ``config`` is neither.
    """
    path = Path(config)
    if path.is_file():
        return path
    if path.is_dir():
        raise ValueError(f"{argument} {str(config)!r} is a folder; give a config file or the "
                         "name of a shipped config (`wheelgym configs` lists them)")
    names = config_names()
    name = path.stem if path.suffix in _CONFIG_SUFFIXES else path.name
    bare = path.parent == Path(".")
    if bare and name in names:
        found = configs_dir() / f"{name}.yml"
        return found if found.is_file() else configs_dir() / f"{name}.yaml"
    close = difflib.get_close_matches(name, names, n=3, cutoff=0.6)
    hint = f" (did you mean {' or '.join(repr(c) for c in close)}?)" if close else ""
    if not bare and name in names:
        hint = f" (the shipped config of that name is {name!r}, without a folder)"
    kind = "file not found" if not bare else "file not found and no shipped config of that name"
    raise ValueError(f"{argument} {str(config)!r}: {kind}{hint}; give a config file path or "
                     f"one of the shipped names: {', '.join(names)}")


def default_config(argument: str = "--config") -> Path:
    """The main job's config file (:data:`DEFAULT_CONFIG` among the shipped configs)."""
    try:
        return config_path(DEFAULT_CONFIG, argument)
    except ValueError as e:
        raise ValueError(f"{e}; or give {argument} FILE") from None


def pretrained_dir(root: str | Path | None = None, *, for_writing: bool = False) -> Path:
    """The folder of pretrained agents: ``root``, else ``$WHEELGYM_PRETRAINED``, else the
    shipped agents (``wheelgym/pretrained`` or the checkout's ``agents/pretrained``).

    ``for_writing`` (an export): the shipped folder only in a source checkout (an installed
    package is not written to); ``ValueError`` asking for a folder otherwise. The folder is
    not checked to exist when ``root`` or the variable gives it.
    """
    if root is not None:
        return Path(root)
    override = os.environ.get(PRETRAINED_ENV)
    if override:
        return Path(override)
    if for_writing:
        repo = repository_root()
        if repo is None:
            raise ValueError("give the folder to export agents into (--root FOLDER or "
                             f"${PRETRAINED_ENV}): the installed package's agents are not "
                             "written to")
        return repo / _SHIPPED["pretrained"]
    return _shipped("pretrained")


def runs_dir(*parts: str) -> Path:
    """``runs/<parts...>``, relative to the current folder: the default output folders."""
    return RUNS.joinpath(*parts)


def results_dir(*parts: str) -> Path:
    """Default folder of committed results: the repository's ``benchmarks/results/<parts>`` in
    a source checkout, else ``runs/<parts>`` (``runs/benchmark`` for the benchmark's CSV)."""
    repo = repository_root()
    if repo is not None:
        return repo.joinpath("benchmarks", "results", *parts)
    return runs_dir(*(parts or ("benchmark",)))


def results_csv() -> Path:
    """Default results CSV of ``wheelgym benchmark``: the repository's committed
    ``benchmarks/results/training.csv`` in a source checkout, else
    ``runs/benchmark/training.csv``."""
    return results_dir() / "training.csv"
