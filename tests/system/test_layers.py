"""The house: esba's packages stand in layers and import only downward, with no import cycle.

Every module of ``esba/`` is read as source (its AST, so imports inside functions count as well as
those at the top), each import is resolved to the esba module it names, and two rules are held:

* **downward only**: a module imports from its own package or from a package on a lower floor of
  :data:`FLOORS` (packages on the same floor do not import each other);
* **no cycle**: the graph of module imports has no cycle, lazy imports included.

A failure names the two modules. ``from esba import __version__`` is the one import of the façade
that any module may make (the version lives there).
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
ESBA = ROOT / "esba"

#: Each package's floor, from the bottom: a module may import from its own package and from any
#: package on a lower floor. ``esba`` itself (the lazy façade and ``python -m esba``) is the roof.
FLOORS = {
    "infra": 0,
    "model": 1,
    "solvers": 2,
    "paths": 3,
    "statics": 4,
    "analysis": 5,
    "export": 5,
    "design": 6,
    "calibration": 6,
    "studies": 7,
    "figures": 8,
    "bench": 9,
    "pages": 10,
    "cli": 11,
}
ROOF = 12


def _modules() -> dict[str, Path]:
    out = {}
    for path in sorted(ESBA.rglob("*.py")):
        parts = path.relative_to(ROOT).with_suffix("").parts
        name = ".".join(parts[:-1] if parts[-1] == "__init__" else parts)
        out[name] = path
    return out


MODULES = _modules()


def _package_of(module: str) -> str:
    parts = module.split(".")
    return parts[1] if len(parts) > 1 and parts[1] in FLOORS else ""


def _floor(module: str) -> int:
    package = _package_of(module)
    return FLOORS[package] if package else ROOF


def _resolve(base: str, names: list[str]) -> list[str]:
    """The esba modules an ``from base import names`` reads: base itself, or base.name when that is a module."""
    found = []
    for name in names:
        if f"{base}.{name}" in MODULES:
            found.append(f"{base}.{name}")
        elif base in MODULES:
            found.append(base)
    return found


def imports_of(module: str) -> list[tuple[str, int, tuple[str, ...]]]:
    """(imported module, line, names) for every esba import in ``module``, wherever it stands."""
    path = MODULES[module]
    tree = ast.parse(path.read_text(encoding="utf-8"))
    package = module if path.name == "__init__.py" else module.rsplit(".", 1)[0]
    out = []
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom):
            if node.level:
                base_parts = package.split(".")[: len(package.split(".")) - node.level + 1]
                base = ".".join(base_parts + ([node.module] if node.module else []))
            else:
                base = node.module or ""
            if base != "esba" and not base.startswith("esba."):
                continue
            names = [a.name for a in node.names]
            for target in _resolve(base, names):
                out.append((target, node.lineno, tuple(names)))
        elif isinstance(node, ast.Import):
            for alias in node.names:
                if alias.name == "esba" or alias.name.startswith("esba."):
                    out.append((alias.name, node.lineno, ()))
    return out


def test_every_package_has_a_floor():
    packages = {p.parent.name for p in ESBA.glob("*/__init__.py")}
    assert packages == set(FLOORS), f"give these packages a floor in FLOORS: {sorted(packages ^ set(FLOORS))}"


def test_at_most_a_handful_of_modules_at_the_top():
    top = sorted(p.name for p in ESBA.glob("*.py"))
    assert top == ["__init__.py", "__main__.py"], f"modules at the top of esba/: {top} (each belongs in a package)"


@pytest.mark.parametrize("module", sorted(MODULES))
def test_imports_go_downward(module):
    upward = []
    for target, line, names in imports_of(module):
        if target == "esba" and set(names) <= {"__version__"}:
            continue
        if target == module or _package_of(target) == _package_of(module) and _package_of(module):
            continue
        if module in ("esba", "esba.__main__"):
            continue
        if _floor(target) >= _floor(module):
            upward.append(f"{module} (line {line}) imports {target}")
    assert not upward, "imports that run up or sideways: " + "; ".join(upward)


def test_no_import_cycle():
    graph = {m: sorted({t for t, _, names in imports_of(m) if t != m and not (t == "esba" and set(names) <= {"__version__"})}) for m in MODULES}
    # a package's __init__ is entered whenever one of its modules is: an import of esba.x.y also reads esba.x
    state: dict[str, int] = {}
    stack: list[str] = []

    def visit(m: str) -> list[str] | None:
        state[m] = 1
        stack.append(m)
        for t in graph.get(m, []):
            if state.get(t) == 1:
                return stack[stack.index(t):] + [t]
            if state.get(t) is None:
                found = visit(t)
                if found:
                    return found
        stack.pop()
        state[m] = 2
        return None

    for m in sorted(graph):
        if state.get(m) is None:
            cycle = visit(m)
            assert cycle is None, "import cycle: " + " -> ".join(cycle)
