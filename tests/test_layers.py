"""The package's layers only point down, and no import cycle joins its modules.

Layers, lowest first (a module may import its own layer and the ones below)::

    _numba_cache, integrators, registration, safe_yaml  <-  models  <-  kinematics  <-  control
    <-  world  <-  planning  <-  tasks  <-  render  <-  envs  <-  vector  <-  agents
    <-  validate, cli, warmup

``wheelgym/__init__.py`` stands outside the layers (it registers the ids and reaches the
subpackages lazily). Every ``import`` statement counts: module level, function-local and
``TYPE_CHECKING`` alike, found by walking each module's syntax tree.

``KNOWN_UPWARD`` lists the upward imports that the architecture work has still to remove; a
new upward import fails, and so does an entry that no longer exists (the list only shrinks).

No module uses a ``_private`` name (or a ``_private`` module) of another top-level package:
what one package offers another is public. ``KNOWN_PRIVATE`` lists today's uses, still to be
replaced by public kernel modules; it only shrinks, like ``KNOWN_UPWARD``.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

PKG = Path(__file__).resolve().parents[1] / "wheelgym"

RANK = {
    "_numba_cache": 0, "integrators": 0, "registration": 0, "resources": 0, "safe_yaml": 0,
    "models": 1, "kinematics": 2, "control": 3, "world": 4, "planning": 4.5, "tasks": 5,
    "render": 6,
    "envs": 7, "vector": 8, "agents": 9, "validate": 10, "cli": 10, "warmup": 10,
}

#: (importer, imported) upward edges still to remove, and why they exist today.
KNOWN_UPWARD: set[tuple[str, str]] = set()


#: (importer, owner module): the private names (``<module>``: the private module itself) that
#: the importer still reads from another package; to become public kernel modules.
KNOWN_PRIVATE: dict[tuple[str, str], set[str]] = {}


def _module_name(path: Path) -> str:
    parts = list(path.relative_to(PKG.parent).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


MODULES = {_module_name(p): p for p in sorted(PKG.rglob("*.py"))}


def _import_statements(name: str, path: Path):
    """Each wheelgym import of module ``name``: ``(target, names)`` with the absolute target
    module (relative imports resolved) and the imported names (``None`` for ``import x``)."""
    tree = ast.parse(path.read_text(encoding="utf-8"))
    package = name if path.name == "__init__.py" else name.rpartition(".")[0]
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            for a in node.names:
                if a.name.split(".")[0] == "wheelgym":
                    yield a.name, None, a.asname or a.name
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")[: len(package.split(".")) - node.level + 1]
                target = ".".join(base + ([node.module] if node.module else []))
            else:
                target = node.module or ""
            if target.split(".")[0] == "wheelgym":
                yield target, [(a.name, a.asname or a.name) for a in node.names], None


def _imports(name: str, path: Path) -> set[str]:
    """The wheelgym modules that ``name`` imports (``from pkg import sub`` counts as ``sub``)."""
    out: set[str] = set()
    for target, names, _ in _import_statements(name, path):
        if names is None:
            out.add(target)
        for n, _ in names or ():
            sub = f"{target}.{n}"
            out.add(sub if sub in MODULES else target)
    return {m for m in out if m in MODULES and m != name}


GRAPH = {name: _imports(name, path) for name, path in MODULES.items()}


def _layer(module: str) -> str | None:
    parts = module.split(".")
    return parts[1] if len(parts) > 1 else None  # the root __init__ stands outside


def _upward() -> set[tuple[str, str]]:
    out = set()
    for a, targets in GRAPH.items():
        la = _layer(a)
        for b in targets:
            lb = _layer(b)
            if la is not None and lb is not None and RANK[lb] > RANK[la]:
                out.add((a, b))
    return out


def test_every_module_has_a_layer():
    layers = {_layer(m) for m in MODULES} - {None}
    assert layers <= set(RANK), f"modules outside the layer table: {layers - set(RANK)}"


def test_no_new_upward_import():
    new = _upward() - KNOWN_UPWARD
    assert not new, "imports pointing up the layers: " + ", ".join(f"{a} -> {b}" for a, b in
                                                                   sorted(new))


def test_known_upward_imports_still_exist():
    gone = KNOWN_UPWARD - _upward()
    assert not gone, f"remove these from KNOWN_UPWARD (they are gone): {sorted(gone)}"


def _cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """Strongly connected components of more than one module (Tarjan)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on: set[str] = set()
    out: list[list[str]] = []
    counter = [0]

    def visit(v: str) -> None:
        index[v] = low[v] = counter[0]
        counter[0] += 1
        stack.append(v)
        on.add(v)
        for w in graph[v]:
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                on.discard(w)
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1:
                out.append(sorted(comp))

    for v in graph:
        if v not in index:
            visit(v)
    return out


def test_no_import_cycle_apart_from_the_known_upward_edges():
    # a package's __init__ importing its own modules is not a cycle of the code
    graph = {a: {b for b in targets if (a, b) not in KNOWN_UPWARD
                 and not (MODULES[a].name == "__init__.py" and b.startswith(a + "."))}
             for a, targets in GRAPH.items()}
    assert _cycles(graph) == []


@pytest.mark.parametrize("edge", sorted(KNOWN_UPWARD))
def test_known_edges_are_upward(edge):
    a, b = edge
    assert RANK[_layer(b)] > RANK[_layer(a)]


def _private_uses() -> dict[tuple[str, str], set[str]]:
    """(importer, owner) -> private names of ``owner`` (another top-level package) used by
    ``importer``: ``from owner import _x``, ``owner_alias._x``, or a ``_private`` module."""
    out: dict[tuple[str, str], set[str]] = {}
    for name, path in MODULES.items():
        tree = ast.parse(path.read_text(encoding="utf-8"))
        alias: dict[str, str] = {}
        for target, names, bound in _import_statements(name, path):
            if names is None:
                alias[bound] = target
                continue
            foreign = _layer(target) != _layer(name)
            if foreign and any(p.startswith("_") for p in target.split(".")[1:]):
                out.setdefault((name, target), set()).add("<module>")
            for n, local in names:
                if f"{target}.{n}" in MODULES:
                    alias[local] = f"{target}.{n}"
                elif n.startswith("_") and foreign:
                    out.setdefault((name, target), set()).add(n)
        for node in ast.walk(tree):
            if (isinstance(node, ast.Attribute) and isinstance(node.value, ast.Name)
                    and node.value.id in alias and node.attr.startswith("_")
                    and not node.attr.startswith("__")
                    and _layer(alias[node.value.id]) != _layer(name)):
                out.setdefault((name, alias[node.value.id]), set()).add(node.attr)
    return out


def test_no_new_private_name_across_packages():
    uses = _private_uses()
    new = {k: v - KNOWN_PRIVATE.get(k, set()) for k, v in uses.items()}
    new = {k: v for k, v in new.items() if v}
    assert not new, f"private names used across packages (make them public): {new}"
    gone = {k: v - uses.get(k, set()) for k, v in KNOWN_PRIVATE.items()}
    gone = {k: v for k, v in gone.items() if v}
    assert not gone, f"remove these from KNOWN_PRIVATE (no longer used): {gone}"
