"""Import rules, checked on the source by an AST walk (nothing is imported).

Every ``import`` statement of every ``.py`` file under ``solver/`` and ``pipeline/`` counts, at module level or
inside a function (a lazy import is still a dependency); relative imports are resolved against the importing
module.  The rules (the project's STYLE.md, "The shape"):

* the solver imports no dask, distributed, xarray, matplotlib, netCDF4 and nothing of :mod:`pipeline`;
* the pipeline imports no numba and nothing of :mod:`solver.kernels`;
* no import cycles among the project's modules: the module graph's strongly connected components are single
  modules.  A cycle is reported with every edge in it and the names imported along it;
* no module imports a private name (``_name``) of another project module: what is shared is public.

One test case per module and rule.  Violations known today are listed once in :data:`KNOWN_VIOLATIONS`: their
cases are expected failures (strict, so a case that starts passing fails the suite until its line is deleted).
A known cycle is one line naming one of its modules: every module of that module's cycle is expected to fail.
"""

from __future__ import annotations

import ast
import functools
from collections import defaultdict
from dataclasses import dataclass
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PACKAGES = ("solver", "pipeline")

#: Top-level packages the solver must not import (numerics only: numpy, scipy, numba).
SOLVER_FORBIDDEN = ("dask", "distributed", "xarray", "matplotlib", "netCDF4", "pipeline")
#: Packages and sub-packages the pipeline must not import (it reaches the kernels through solver wrappers).
PIPELINE_FORBIDDEN = ("numba", "solver.kernels")

#: (rule, module) -> why it is allowed to fail today.  Delete a line once its violation is fixed.
KNOWN_VIOLATIONS: dict[tuple[str, str], str] = {}


@dataclass(frozen=True)
class Import:
    """One imported module: ``target`` (dotted, absolute), the names taken from it, the line."""

    target: str
    names: tuple[str, ...]
    line: int


def module_name(path: Path) -> str:
    parts = list(path.relative_to(ROOT).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts = parts[:-1]
    return ".".join(parts)


@functools.cache
def project_modules() -> dict[str, Path]:
    """Every module of the project by dotted name (a package by its ``__init__.py``)."""
    return {module_name(p): p for pkg in PACKAGES for p in sorted((ROOT / pkg).rglob("*.py"))}


def resolve(module: str, is_package: bool, node: ast.ImportFrom) -> str:
    """The absolute module a ``from ... import`` statement reads from."""
    if not node.level:
        return node.module or ""
    base = module.split(".") if is_package else module.split(".")[:-1]
    base = base[: len(base) - (node.level - 1)]
    return ".".join(base + ([node.module] if node.module else []))


@functools.cache
def imports_of(module: str) -> tuple[Import, ...]:
    """Every import statement of ``module`` (module level and function level); ``from P import m`` with ``P.m``
    a project module counts as an import of ``P.m``."""
    path = project_modules()[module]
    tree = ast.parse(path.read_text(), str(path))
    modules = project_modules()
    found = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            found += [Import(alias.name, (), node.lineno) for alias in node.names]
        elif isinstance(node, ast.ImportFrom):
            target = resolve(module, path.name == "__init__.py", node)
            plain = []
            for alias in node.names:
                if f"{target}.{alias.name}" in modules:
                    found.append(Import(f"{target}.{alias.name}", (), node.lineno))
                else:
                    plain.append(alias.name)
            if plain:
                found.append(Import(target, tuple(plain), node.lineno))
    return tuple(found)


def within(target: str, package: str) -> bool:
    return target == package or target.startswith(package + ".")


@functools.cache
def graph() -> dict[str, dict[str, list[Import]]]:
    """module -> imported project module -> the imports (a module imports itself? never an edge)."""
    modules = project_modules()
    edges: dict[str, dict[str, list[Import]]] = {m: defaultdict(list) for m in modules}
    for m in modules:
        for imp in imports_of(m):
            if imp.target in modules and imp.target != m:
                edges[m][imp.target].append(imp)
    return edges


@functools.cache
def components() -> dict[str, frozenset[str]]:
    """Strongly connected components of the module graph (Tarjan), by member."""
    edges = graph()
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    of: dict[str, frozenset[str]] = {}

    def visit(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        on_stack.add(v)
        for w in sorted(edges[v]):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on_stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            members = []
            while True:
                w = stack.pop()
                on_stack.discard(w)
                members.append(w)
                if w == v:
                    break
            for w in members:
                of[w] = frozenset(members)

    for v in sorted(edges):
        if v not in index:
            visit(v)
    return of


def describe_cycle(members: frozenset[str]) -> str:
    edges = graph()
    lines = []
    for a in sorted(members):
        for b in sorted(set(edges[a]) & members):
            for imp in edges[a][b]:
                names = f" ({', '.join(imp.names)})" if imp.names else ""
                lines.append(f"  {a}:{imp.line} -> {b}{names}")
    return "import cycle among " + ", ".join(sorted(members)) + ":\n" + "\n".join(lines)


def known_reason(rule: str, module: str) -> str | None:
    """Why ``module`` may break ``rule`` today (for a cycle: any module of a listed module's cycle), or None."""
    if (rule, module) in KNOWN_VIOLATIONS:
        return KNOWN_VIOLATIONS[(rule, module)]
    if rule == "cycle":
        for (r, anchor), reason in KNOWN_VIOLATIONS.items():
            if r == "cycle" and anchor in project_modules() and module in components()[anchor]:
                return f"in the cycle of {anchor}: {reason}"
    return None


def cases(rule: str, package: str) -> list:
    out = []
    for m in project_modules():
        if not within(m, package):
            continue
        reason = known_reason(rule, m)
        marks = [pytest.mark.xfail(strict=True, reason=reason)] if reason else []
        out.append(pytest.param(m, id=m, marks=marks))
    return out


def forbidden_imports(module: str, forbidden: tuple[str, ...]) -> list[str]:
    return [
        f"{module}:{imp.line} imports {imp.target}" + (f" ({', '.join(imp.names)})" if imp.names else "")
        for imp in imports_of(module)
        if any(within(imp.target, f) for f in forbidden)
    ]


@pytest.mark.parametrize("module", cases("layer", "solver"))
def test_solver_imports_no_orchestration(module):
    assert forbidden_imports(module, SOLVER_FORBIDDEN) == []


@pytest.mark.parametrize("module", cases("layer", "pipeline"))
def test_pipeline_imports_no_numba_or_kernels(module):
    assert forbidden_imports(module, PIPELINE_FORBIDDEN) == []


@pytest.mark.parametrize("module", cases("private", "solver") + cases("private", "pipeline"))
def test_no_private_names_from_other_modules(module):
    private = [
        f"{module}:{imp.line} imports {name} from {imp.target}"
        for imp in imports_of(module)
        if imp.target in project_modules()
        for name in imp.names
        if name.startswith("_") and not name.startswith("__")
    ]
    assert private == []


@pytest.mark.parametrize("module", cases("cycle", "solver") + cases("cycle", "pipeline"))
def test_module_is_in_no_import_cycle(module):
    members = components()[module]
    assert len(members) == 1, describe_cycle(members)


def test_known_violations_name_existing_modules():
    # a moved or deleted module leaves a stale line that no case would ever check
    assert [m for _, m in KNOWN_VIOLATIONS if m not in project_modules()] == []


def test_the_walk_sees_relative_and_lazy_imports():
    # solver.kinds imports the kinds inside a function and relatively: both must be edges
    assert {"solver.kind", "solver.params", "solver.rails.kind", "solver.abs.kind"} <= set(graph()["solver.kinds"])
    assert "numba" in {imp.target for imp in imports_of("solver.jit")}
