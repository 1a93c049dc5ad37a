"""The import graph of first-party modules, read with ``ast`` (the reader behind
tests/test_layers.py): which module imports which, its cycles, the imports that point up an
order of layers, and the imports that run when a module loads or a function runs.

Every import counts: at module level, inside functions, under ``if TYPE_CHECKING:``, relative
ones (``from .x import y``, ``from .. import m``), ``from pkg import module`` (an edge to the
module, not to the package), and ``importlib.import_module("literal")``.
"""

from __future__ import annotations

import ast
from collections.abc import Iterable, Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path


@dataclass(frozen=True, order=True)
class Edge:
    source: str  # the importing module, e.g. "petri.execution.runner"
    target: str  # the imported first-party module, e.g. "diagnostics"
    file: str  # the importing file, relative to the root
    line: int

    def __str__(self) -> str:
        return f"{self.source} -> {self.target} ({self.file}:{self.line})"


def module_files(root: Path, packages: Iterable[str]) -> dict[str, Path]:
    """Every module of the packages: dotted name -> file (a package is its __init__.py)."""
    modules: dict[str, Path] = {}
    for package in packages:
        base = root / package
        if not base.is_dir():
            continue
        for path in sorted(base.rglob("*.py")):
            if "__pycache__" in path.parts:
                continue
            parts = list(path.relative_to(root).with_suffix("").parts)
            if parts[-1] == "__init__":
                parts.pop()
            modules[".".join(parts)] = path
    return modules


def is_package(module: str, modules: dict[str, Path]) -> bool:
    """Whether the module is a package (its file is an ``__init__.py``)."""
    return modules[module].name == "__init__.py"


def resolve(name: str, modules: dict[str, Path]) -> str | None:
    """The first-party module an absolute dotted name lands in: the longest prefix that is one."""
    parts = name.split(".")
    while parts:
        candidate = ".".join(parts)
        if candidate in modules:
            return candidate
        parts.pop()
    return None


def relative_base(module: str, level: int, modules: dict[str, Path]) -> str:
    """The package a relative import of ``level`` dots in ``module`` starts from."""
    package = module if is_package(module, modules) else module.rpartition(".")[0]
    for _ in range(level - 1):
        package = package.rpartition(".")[0]
    return package


def import_targets(node: ast.AST, module: str, modules: dict[str, Path]) -> list[str]:
    """The first-party modules one AST node imports (empty for anything else)."""
    names: list[str] = []
    if isinstance(node, ast.Import):
        names = [alias.name for alias in node.names]
    elif isinstance(node, ast.ImportFrom):
        if node.level:
            base = relative_base(module, node.level, modules)
            origin = ".".join(p for p in (base, node.module or "") if p)
        else:
            origin = node.module or ""
        for alias in node.names:
            # from pkg import module -> that module; from module import name -> the module
            sub = f"{origin}.{alias.name}" if origin else alias.name
            names.append(sub if sub in modules else origin)
    elif isinstance(node, ast.Call):
        func = node.func
        called = (func.attr if isinstance(func, ast.Attribute)
                  else func.id if isinstance(func, ast.Name) else "")
        if called in ("import_module", "__import__") and node.args and \
                isinstance(node.args[0], ast.Constant) and isinstance(node.args[0].value, str):
            names = [node.args[0].value]
    out = []
    for name in names:
        target = resolve(name, modules) if name else None
        if target is not None and target != module:
            out.append(target)
    return out


def import_edges(root: Path, packages: Sequence[str]) -> list[Edge]:
    """Every import between first-party modules under ``root``."""
    modules = module_files(root, packages)
    edges = set()
    for module, path in modules.items():
        tree = ast.parse(path.read_text(encoding="utf-8"), str(path))
        rel = path.relative_to(root).as_posix()
        for node in ast.walk(tree):
            for target in import_targets(node, module, modules):
                edges.add(Edge(module, target, rel, getattr(node, "lineno", 0)))
    return sorted(edges)


FUNCTIONS = (ast.FunctionDef, ast.AsyncFunctionDef, ast.Lambda)


def is_type_checking(test: ast.expr) -> bool:
    """Whether an ``if`` tests ``TYPE_CHECKING`` (its body never runs)."""
    return ((isinstance(test, ast.Name) and test.id == "TYPE_CHECKING")
            or (isinstance(test, ast.Attribute) and test.attr == "TYPE_CHECKING"))


def scoped_nodes(tree: ast.AST) -> Iterator[tuple[ast.AST, bool, bool]]:
    """Every node with where it sits: (node, inside a function, under ``if TYPE_CHECKING:``)."""
    stack: list[tuple[ast.AST, bool, bool]] = [(tree, False, False)]
    while stack:
        node, in_function, typing_only = stack.pop()
        yield node, in_function, typing_only
        function = in_function or isinstance(node, FUNCTIONS)
        guarded = node.body if isinstance(node, ast.If) and is_type_checking(node.test) else []
        for child in ast.iter_child_nodes(node):
            stack.append((child, function, typing_only or any(child is g for g in guarded)))


def enclosing_packages(module: str, modules: dict[str, Path]) -> list[str]:
    """The packages Python runs before a module, outermost first: ``a``, ``a.b`` for ``a.b.c``."""
    parts = module.split(".")
    found = (".".join(parts[:i]) for i in range(1, len(parts)))
    return [package for package in found if package in modules]


def running_edges(root: Path, packages: Sequence[str]) -> list[Edge]:
    """The imports that run, as if every import inside a function stood at module level: all
    but those under ``if TYPE_CHECKING:``, each with the packages Python runs first (``import
    a.b.c`` runs ``a/__init__.py`` and ``a/b/__init__.py``) except those the importing module
    is itself inside (they are already running when it runs).

    A cycle here that :func:`import_edges` does not show is one an import inside a function
    hides: moved to module level, it would make modules import each other while loading."""
    modules = module_files(root, packages)
    edges = set()
    for module, path in modules.items():
        tree = ast.parse(path.read_text(encoding="utf-8"), str(path))
        rel = path.relative_to(root).as_posix()
        for node, _, typing_only in scoped_nodes(tree):
            if typing_only:
                continue
            for target in import_targets(node, module, modules):
                line = getattr(node, "lineno", 0)
                edges.add(Edge(module, target, rel, line))
                for package in enclosing_packages(target, modules):
                    if package != module and not module.startswith(package + "."):
                        edges.add(Edge(module, package, rel, line))
    return sorted(edges)


def deferred_imports(root: Path, packages: Sequence[str]) -> list[Edge]:
    """The imports of first-party modules made inside a function (not under TYPE_CHECKING)."""
    modules = module_files(root, packages)
    edges = set()
    for module, path in modules.items():
        tree = ast.parse(path.read_text(encoding="utf-8"), str(path))
        rel = path.relative_to(root).as_posix()
        for node, in_function, typing_only in scoped_nodes(tree):
            if in_function and not typing_only:
                for target in import_targets(node, module, modules):
                    edges.add(Edge(module, target, rel, getattr(node, "lineno", 0)))
    return sorted(edges)


def external_imports(root: Path, packages: Sequence[str], name: str) -> list[Edge]:
    """Where a first-party module imports the outside module ``name`` (e.g. argparse)."""
    found = []
    for module, path in module_files(root, packages).items():
        tree = ast.parse(path.read_text(encoding="utf-8"), str(path))
        rel = path.relative_to(root).as_posix()
        for node in ast.walk(tree):
            imported: list[str] = []
            if isinstance(node, ast.Import):
                imported = [alias.name for alias in node.names]
            elif isinstance(node, ast.ImportFrom) and not node.level and node.module:
                imported = [node.module]
            if any(n == name or n.startswith(name + ".") for n in imported):
                found.append(Edge(module, name, rel, node.lineno))  # type: ignore[attr-defined]
    return sorted(found)


def cycles(edges: Iterable[Edge]) -> list[list[Edge]]:
    """One cycle (as its edges) for each strongly connected group of modules (Tarjan)."""
    graph: dict[str, dict[str, Edge]] = {}
    for e in edges:
        graph.setdefault(e.source, {}).setdefault(e.target, e)
        graph.setdefault(e.target, {})
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    groups: list[list[str]] = []
    counter = 0
    for start in sorted(graph):  # iterative Tarjan: no recursion limit on a deep graph
        if start in index:
            continue
        work = [(start, iter(sorted(graph[start])))]
        index[start] = low[start] = counter
        counter += 1
        stack.append(start)
        on_stack.add(start)
        while work:
            node, successors = work[-1]
            advanced = False
            for nxt in successors:
                if nxt not in index:
                    index[nxt] = low[nxt] = counter
                    counter += 1
                    stack.append(nxt)
                    on_stack.add(nxt)
                    work.append((nxt, iter(sorted(graph[nxt]))))
                    advanced = True
                    break
                if nxt in on_stack:
                    low[node] = min(low[node], index[nxt])
            if advanced:
                continue
            work.pop()
            if work:
                low[work[-1][0]] = min(low[work[-1][0]], low[node])
            if low[node] == index[node]:
                group = []
                while True:
                    member = stack.pop()
                    on_stack.discard(member)
                    group.append(member)
                    if member == node:
                        break
                if len(group) > 1:
                    groups.append(sorted(group))
    found = []
    for group in sorted(groups):
        members = set(group)
        path = _path_back(graph, members, group[0])
        found.append([graph[a][b] for a, b in zip(path, path[1:])])
    return found


def _path_back(graph: dict[str, dict[str, Edge]], members: set[str], start: str) -> list[str]:
    """A shortest path start -> ... -> start inside one strongly connected group (BFS)."""
    previous: dict[str, str] = {}
    frontier = [start]
    while frontier:
        following = []
        for node in frontier:
            for nxt in sorted(graph[node]):
                if nxt == start:
                    path = [node]
                    while path[-1] != start:
                        path.append(previous[path[-1]])
                    return [*reversed(path), start]
                if nxt in members and nxt not in previous:
                    previous[nxt] = node
                    following.append(nxt)
        frontier = following
    raise AssertionError(f"{start} is in a cycle but no path leads back to it")


def upward(edges: Iterable[Edge], layers: Sequence[str]) -> list[Edge]:
    """Imports between packages that do not point strictly down ``layers`` (top first)."""
    level = {package: i for i, package in enumerate(layers)}
    bad = []
    for e in edges:
        a, b = e.source.split(".")[0], e.target.split(".")[0]
        if a != b and level[b] <= level[a]:
            bad.append(e)
    return bad
