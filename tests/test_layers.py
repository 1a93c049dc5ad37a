"""The layers of the tree (issue 13): the import graph of the first-party packages, read with
``ast``, has no cycle between modules and no import that points up the order below; and only the
application layer parses command lines (``argparse``).

Every import counts: at module level, inside functions, under ``if TYPE_CHECKING:``, relative
ones (``from .x import y``, ``from .. import m``), ``from pkg import module`` (an edge to the
module, not to the package), and ``importlib.import_module("literal")``.
"""

from __future__ import annotations

import ast
import tomllib
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from pathlib import Path

from tests.support import REPO

# The one statement of the layer order, top down. A package may import any package BELOW it;
# not one above, and not a peer (strict levels). README.md's layout section repeats it.
LAYERS: tuple[str, ...] = (
    "app",               # the commands: mclc, mcl run | replay | check | vehicle | monitor | mosaic
    "mission",           # a run as a library call: run_mission, capability check, time bound
    "mcl",               # the language: grammar, parser, checker, compiler, templates
    "mosaic",            # the photomosaic of a run's images
    "vehicle_adapters",  # player-side transports: inprocess, scripted, zenoh, mavlink
    "vehicle",           # the vehicle side: simulated stack, its Zenoh server, ArduSub-like
    "petri",             # Petri nets: semantics, player, runner, verification, PNML
    "behaviours",        # the behaviours, their coordinator, capability declarations
    "aal",               # what crosses player <-> vehicle: messages, zenoh, mavlink, signing
    "diagnostics",       # the error root
)
# Modules that may parse a command line: the application layer only.
COMMAND_LINE_PACKAGES = frozenset({"app"})


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


def _is_package(module: str, modules: dict[str, Path]) -> bool:
    return modules[module].name == "__init__.py"


def _resolve(name: str, modules: dict[str, Path]) -> str | None:
    """The first-party module an absolute dotted name lands in: the longest prefix that is one."""
    parts = name.split(".")
    while parts:
        candidate = ".".join(parts)
        if candidate in modules:
            return candidate
        parts.pop()
    return None


def _base(module: str, level: int, modules: dict[str, Path]) -> str:
    """The package a relative import of ``level`` dots in ``module`` starts from."""
    package = module if _is_package(module, modules) else module.rpartition(".")[0]
    for _ in range(level - 1):
        package = package.rpartition(".")[0]
    return package


def _targets(node: ast.AST, module: str, modules: dict[str, Path]) -> list[str]:
    """The first-party modules one AST node imports (empty for anything else)."""
    names: list[str] = []
    if isinstance(node, ast.Import):
        names = [alias.name for alias in node.names]
    elif isinstance(node, ast.ImportFrom):
        if node.level:
            base = _base(module, node.level, modules)
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
        target = _resolve(name, modules) if name else None
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
            for target in _targets(node, module, modules):
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


def _lines(edges: Iterable[Edge]) -> str:
    return "\n".join(f"  {e}" for e in edges)


def _cycle_text(found: list[list[Edge]]) -> str:
    return "\n".join("cycle:\n" + _lines(c) for c in found)


# -- the tree -------------------------------------------------------------------------------------

def test_the_layers_name_every_first_party_package() -> None:
    """A new package must be placed in the order (pyproject's package list is the truth)."""
    config = tomllib.loads((REPO / "pyproject.toml").read_text(encoding="utf-8"))
    include = config["tool"]["setuptools"]["packages"]["find"]["include"]
    assert {p.rstrip("*") for p in include} == set(LAYERS)
    for package in LAYERS:
        assert (REPO / package / "__init__.py").is_file(), package


def test_no_import_cycle_between_modules() -> None:
    found = cycles(import_edges(REPO, LAYERS))
    assert not found, "import cycles (module -> module (file:line)):\n" + _cycle_text(found)


def test_every_import_between_packages_points_down() -> None:
    bad = upward(import_edges(REPO, LAYERS), LAYERS)
    assert not bad, (f"imports that point up or sideways the order {' > '.join(LAYERS)}:\n"
                     + _lines(bad))


def test_only_the_application_layer_parses_command_lines() -> None:
    libraries = [p for p in LAYERS if p not in COMMAND_LINE_PACKAGES]
    bad = external_imports(REPO, libraries, "argparse")
    assert not bad, "argparse outside app/ (a library takes arguments, not argv):\n" + _lines(bad)


def test_the_reader_sees_the_known_edges_of_the_tree() -> None:
    """A reader that resolves nothing would pass the tests above: it must see real edges."""
    edges = import_edges(REPO, LAYERS)
    pairs = {(e.source, e.target) for e in edges}
    assert ("petri.formats.pnml", "diagnostics") in pairs  # from diagnostics import ...
    assert ("petri.execution.runlog", "petri.net") in pairs  # from .net import Net
    assert len({e.source.split(".")[0] for e in edges}) >= len(LAYERS) - 1
    assert all(e.line > 0 and (REPO / e.file).is_file() for e in edges)


# -- the checker itself, on a tree made to fail -----------------------------------------------------

def _tree(root: Path, files: dict[str, str]) -> None:
    for name, text in files.items():
        path = root / name
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(text, encoding="utf-8")


BAD_LAYERS = ("top", "mid", "low")


def test_the_checker_finds_a_cycle_and_an_upward_import(tmp_path: Path) -> None:
    _tree(tmp_path, {
        "top/__init__.py": "",
        "top/cmd.py": "import argparse\nfrom mid import a\n",
        "mid/__init__.py": "",
        "mid/a.py": "from . import b\n",  # mid.a -> mid.b
        "mid/b.py": "def f():\n    from .a import thing\n    return thing\n",  # mid.b -> mid.a
        "mid/c.py": "from .sub.deep import x\n",
        "mid/sub/__init__.py": "",
        "mid/sub/deep.py": "from ..c import y\n",  # mid.sub.deep -> mid.c: a second cycle
        "low/__init__.py": "from typing import TYPE_CHECKING\n"
                           "if TYPE_CHECKING:\n    import mid.a\n",  # low -> mid: upward
        "low/util.py": "import importlib\n\n"
                       "def load():\n    return importlib.import_module('top.cmd')\n",
        "low/peer.py": "from argparse import ArgumentParser\nfrom low import util\n",
    })
    edges = import_edges(tmp_path, BAD_LAYERS)
    assert {(e.source, e.target) for e in edges} == {
        ("top.cmd", "mid.a"), ("mid.a", "mid.b"), ("mid.b", "mid.a"), ("mid.c", "mid.sub.deep"),
        ("mid.sub.deep", "mid.c"), ("low", "mid.a"), ("low.util", "top.cmd"),
        ("low.peer", "low.util")}
    found = cycles(edges)
    assert [[str(e) for e in c] for c in found] == [
        ["mid.a -> mid.b (mid/a.py:1)", "mid.b -> mid.a (mid/b.py:2)"],
        ["mid.c -> mid.sub.deep (mid/c.py:1)", "mid.sub.deep -> mid.c (mid/sub/deep.py:1)"]]
    assert [str(e) for e in upward(edges, BAD_LAYERS)] == [
        "low -> mid.a (low/__init__.py:3)", "low.util -> top.cmd (low/util.py:4)"]
    assert [str(e) for e in external_imports(tmp_path, ["mid", "low"], "argparse")] == [
        "low.peer -> argparse (low/peer.py:1)"]


def test_the_checker_passes_a_clean_tree_and_follows_the_order(tmp_path: Path) -> None:
    _tree(tmp_path, {
        "top/__init__.py": "from low import base\nimport mid.m\n",
        "mid/__init__.py": "",
        "mid/m.py": "from low.base import X\n",
        "low/__init__.py": "",
        "low/base.py": "X = 1\n",
    })
    edges = import_edges(tmp_path, BAD_LAYERS)
    assert cycles(edges) == [] and upward(edges, BAD_LAYERS) == []
    assert len(edges) == 3
    # the same tree with low placed above mid: mid.m -> low.base now points up
    swapped = upward(edges, ("top", "low", "mid"))
    assert [str(e) for e in swapped] == ["mid.m -> low.base (mid/m.py:1)"]
