"""The modules of ``wheelgym.agents`` import each other without cycles.

Every import is counted, module-level, function-local and under ``TYPE_CHECKING`` alike, read
with ``ast`` (nothing is imported), so a cycle cannot hide behind a lazy import.
"""

from __future__ import annotations

import ast
import subprocess
import sys
from pathlib import Path

import wheelgym

PACKAGE = "wheelgym.agents"
AGENTS_DIR = Path(wheelgym.__file__).resolve().parent / "agents"


def _module_name(path: Path) -> str:
    return PACKAGE if path.stem == "__init__" else f"{PACKAGE}.{path.stem}"


def _targets(node: ast.Import | ast.ImportFrom, module: str, modules: set[str]) -> set[str]:
    """The modules of the package that one import statement reaches."""
    if isinstance(node, ast.Import):
        names = [a.name for a in node.names]
    else:
        base = node.module or ""
        if node.level:  # relative: resolve against this module's package
            parts = module.split(".")
            pkg = parts if module == PACKAGE else parts[:-1]
            pkg = pkg[: len(pkg) - (node.level - 1)]
            base = ".".join([*pkg, *([base] if base else [])])
        # ``from pkg import sub`` reaches the submodule; ``from mod import name`` the module.
        names = [f"{base}.{a.name}" if f"{base}.{a.name}" in modules else base
                 for a in node.names]
    out = set()
    for name in names:
        while name and name not in modules:  # ``import wheelgym.agents.x.y`` -> x
            name = name.rpartition(".")[0]
        if name:
            out.add(name)
    return out


def import_graph() -> dict[str, set[str]]:
    """``module -> modules of wheelgym.agents it imports`` (self-imports left out)."""
    files = sorted(AGENTS_DIR.glob("*.py"))
    modules = {_module_name(p) for p in files}
    graph: dict[str, set[str]] = {}
    for path in files:
        module = _module_name(path)
        tree = ast.parse(path.read_text(), filename=str(path))
        edges: set[str] = set()
        for node in ast.walk(tree):
            if isinstance(node, (ast.Import, ast.ImportFrom)):
                edges |= _targets(node, module, modules)
        graph[module] = edges - {module}
    return graph


def find_cycle(graph: dict[str, set[str]]) -> list[str] | None:
    """One import cycle as ``[a, b, ..., a]``, or ``None``."""
    state: dict[str, int] = {}  # 1: on the current path, 2: done
    path: list[str] = []

    def visit(node: str) -> list[str] | None:
        state[node] = 1
        path.append(node)
        for nxt in sorted(graph.get(node, ())):
            if state.get(nxt) == 1:
                return [*path[path.index(nxt):], nxt]
            if nxt not in state:
                cycle = visit(nxt)
                if cycle:
                    return cycle
        path.pop()
        state[node] = 2
        return None

    for node in sorted(graph):
        if node not in state:
            cycle = visit(node)
            if cycle:
                return cycle
    return None


def test_graph_reads_every_kind_of_import():
    src = ("import wheelgym.agents.common as c\n"
           "from wheelgym.agents import config\n"
           "from wheelgym.agents.policies import AgentPolicy\n"
           "from typing import TYPE_CHECKING\n"
           "if TYPE_CHECKING:\n    from wheelgym.agents.train import TrainResult\n"
           "def f():\n    from . import evaluate\n    from .tune import tune\n")
    modules = {PACKAGE, *(f"{PACKAGE}.{m}" for m in
                          ("common", "config", "policies", "train", "evaluate", "tune"))}
    found: set[str] = set()
    for node in ast.walk(ast.parse(src)):
        if isinstance(node, (ast.Import, ast.ImportFrom)):
            found |= _targets(node, f"{PACKAGE}.benchmark", modules)
    assert found == modules - {PACKAGE}
    assert find_cycle({"a": {"b"}, "b": {"c"}, "c": {"a"}}) == ["a", "b", "c", "a"]
    assert find_cycle({"a": {"b", "c"}, "b": {"c"}, "c": set()}) is None


def test_agents_modules_import_no_cycle():
    graph = import_graph()
    assert {f"{PACKAGE}.{m}" for m in ("config", "common", "policies", "evaluate", "train")} \
        <= set(graph)
    cycle = find_cycle(graph)
    assert cycle is None, "import cycle in wheelgym.agents: " + " -> ".join(cycle or [])


def test_config_is_the_bottom_layer():
    graph = import_graph()
    assert graph[f"{PACKAGE}.pipeline"] == {f"{PACKAGE}.clone"}  # its defaults: clone.py
    assert graph[f"{PACKAGE}.config"] == {f"{PACKAGE}.pipeline"}
    assert graph[f"{PACKAGE}.bounded_policy"] == set()  # an SB3 policy class: torch and SB3 only
    assert graph[f"{PACKAGE}.clone"] == set()  # the envs' baseline and an SB3 model only
    assert graph[f"{PACKAGE}.her"] == set()  # an SB3 replay buffer class: SB3 only
    assert graph[f"{PACKAGE}.common"] == {f"{PACKAGE}.config", f"{PACKAGE}.bounded_policy",
                                          f"{PACKAGE}.her"}


def test_import_wheelgym_leaves_agents_and_heavy_packages_alone():
    code = ("import sys, wheelgym; "
            "bad = [m for m in sys.modules if m.startswith('wheelgym.agents') "
            "or m.split('.')[0] in ('torch', 'stable_baselines3', 'matplotlib', 'optuna')]; "
            "print(bad); sys.exit(1 if bad else 0)")
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert r.returncode == 0, r.stdout + r.stderr


def test_no_function_of_the_agents_package_is_over_80_lines():
    """Each job in a function of its own (issue 36): none in ``wheelgym/agents`` longer than
    80 lines, decorators and docstring included."""
    long = []
    for path in sorted(AGENTS_DIR.glob("*.py")):
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
                n = node.end_lineno - node.lineno + 1
                if n > 80:
                    long.append(f"{path.name}:{node.name} ({n} lines)")
    assert long == []
