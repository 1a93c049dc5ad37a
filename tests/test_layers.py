"""The layers of the tree (issue 13): the import graph of the first-party packages, read with
``ast``, has no cycle between modules and no import that points up the order below; and only the
application layer parses command lines (``argparse``). Issue 20 adds: no module uses another's
private name, and no import inside a function hides a cycle (tests/private_names.py and
tests/import_graph.py are the readers).

Every import counts: at module level, inside functions, under ``if TYPE_CHECKING:``, relative
ones (``from .x import y``, ``from .. import m``), ``from pkg import module`` (an edge to the
module, not to the package), and ``importlib.import_module("literal")``.
"""

from __future__ import annotations

import tomllib
from collections.abc import Iterable, Sequence
from pathlib import Path

import pytest

from tests.import_graph import (
    Edge,
    cycles,
    deferred_imports,
    external_imports,
    import_edges,
    module_files,
    running_edges,
    upward,
)
from tests.private_names import PrivateUse, Reader
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
# Who else must keep off the packages' private names: the tests, the benchmarks and the examples
# (which show the public API). A test file alone may reach into the module it mirrors.
USERS = ("tests", "bench", "examples")


def mirrors(test: str, module: str) -> bool:
    """Whether ``test`` is the test file of ``module``: tests.<path>.test_<name> tests
    <path>.<name> (tests/petri/execution/test_player.py, petri/execution/player.py), or the
    package <path> itself when <name> is its name (tests/diagnostics/test_diagnostics.py)."""
    parts = test.split(".")
    if parts[0] != "tests" or not parts[-1].startswith("test_"):
        return False
    path, name = parts[1:-1], parts[-1].removeprefix("test_")
    return module in (".".join([*path, name]), ".".join(path) if path[-1:] == [name] else None)


def private_uses(root: Path, packages: Sequence[str], users: Sequence[str]) -> list[PrivateUse]:
    """The packages' modules, and the ``users``' ones, using a private name of another
    package module (a test of the module it mirrors excepted)."""
    owners = module_files(root, packages)
    return Reader(owners, root, mirrors).uses({**owners, **module_files(root, users)})


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


@pytest.mark.slow
def test_no_import_cycle_between_modules() -> None:
    found = cycles(import_edges(REPO, LAYERS))
    assert not found, "import cycles (module -> module (file:line)):\n" + _cycle_text(found)


@pytest.mark.slow
def test_every_import_between_packages_points_down() -> None:
    bad = upward(import_edges(REPO, LAYERS), LAYERS)
    assert not bad, (f"imports that point up or sideways the order {' > '.join(LAYERS)}:\n"
                     + _lines(bad))


@pytest.mark.slow
def test_only_the_application_layer_parses_command_lines() -> None:
    libraries = [p for p in LAYERS if p not in COMMAND_LINE_PACKAGES]
    bad = external_imports(REPO, libraries, "argparse")
    assert not bad, "argparse outside app/ (a library takes arguments, not argv):\n" + _lines(bad)


@pytest.mark.slow
def test_the_reader_sees_the_known_edges_of_the_tree() -> None:
    """A reader that resolves nothing would pass the tests above: it must see real edges."""
    edges = import_edges(REPO, LAYERS)
    pairs = {(e.source, e.target) for e in edges}
    assert ("petri.formats.pnml", "diagnostics") in pairs  # from diagnostics import ...
    assert ("petri.execution.runlog", "petri.net") in pairs  # from .net import Net
    assert len({e.source.split(".")[0] for e in edges}) >= len(LAYERS) - 1
    assert all(e.line > 0 and (REPO / e.file).is_file() for e in edges)


@pytest.mark.slow
def test_no_private_name_is_used_across_modules() -> None:
    """A private name is one its module may change without telling anyone: any other module
    that needs it asks for a public name (a test file may still use the module it mirrors)."""
    bad = private_uses(REPO, LAYERS, USERS)
    assert not bad, "private names used outside their module:\n" + "\n".join(f"  {u}" for u in bad)


@pytest.mark.slow
def test_no_import_inside_a_function_hides_a_cycle() -> None:
    """An import inside a function is for start-up speed only: moved to module level, with the
    package __init__ modules Python runs before it, it must close no cycle."""
    found = cycles(running_edges(REPO, LAYERS))
    assert not found, ("imports inside functions that hide a cycle (moved to module level, "
                       "they would not load):\n" + _cycle_text(found))


@pytest.mark.slow
def test_the_readers_see_the_known_function_imports_and_inheritance_of_the_tree() -> None:
    """Readers that resolve nothing would pass the two tests above: they must see real ones."""
    deferred = {(e.source, e.target) for e in deferred_imports(REPO, LAYERS)}
    running = {(e.source, e.target) for e in running_edges(REPO, LAYERS)}
    assert ("mosaic.hook", "mosaic.build") in deferred  # lazy: SciPy only for a mosaic
    assert ("app.run", "mosaic.hook") in deferred and ("app.run", "mosaic") in running
    assert deferred <= running
    reader = Reader(module_files(REPO, LAYERS), REPO)
    zenoh = reader.owner("vehicle_adapters.zenoh_link")
    assert zenoh is not None
    inherited = reader.inherited_members(zenoh.name, zenoh, zenoh.classes["ZenohVehicle"])
    assert inherited["_max_seq"] == "vehicle_adapters.link:RemoteVehicle"  # its base's own
    assert "lock" not in inherited and "_alive" not in inherited  # public; ZenohVehicle's own


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


def test_the_private_name_checker_finds_each_kind_of_use(tmp_path: Path) -> None:
    _tree(tmp_path, {
        "low/__init__.py": "from low.base import Base as Base\n_PKG = 1\n",
        "low/base.py": ("_SECRET = 1\n\n"
                        "def _helper():\n    return _SECRET\n\n"  # its own: fine
                        "class Base:\n    _shared = 0\n\n"
                        "    def __init__(self):\n        self._lock = None\n\n"
                        "    def _hook(self):\n        return self._lock\n\n"
                        "class Player:\n    def _emit(self):\n        pass\n"),
        "mid/__init__.py": "",
        "mid/a.py": ("import os\n"
                     "import low.base\n"
                     "from low import base as b\n"
                     "from low.base import _helper, Base, Player as _Player\n"  # 4: _helper
                     "from low import Base as Again\n"  # a re-export
                     "x = low.base._SECRET + b._SECRET + Base._shared\n"  # 6: module, class
                     "y = low.base.__name__\n"  # a dunder: fine
                     "class Sub(Base):\n"
                     "    def _hook(self):\n"  # 9: overrides the base's private hook
                     "        return self._lock\n"  # 10: the base's private attribute
                     "    def _mine(self):\n"
                     "        self._own = 1\n"  # its own: fine
                     "        return self._own\n"
                     "class Deeper(Again):\n"
                     "    _shared = 1\n"  # 15: through the re-export
                     "def run(player: _Player) -> None:\n"  # a private alias of its own: fine
                     "    player._emit()\n"  # 17: by name, defined in low.base only
                     "    os._exit(0)\n"  # the standard library's: fine
                     "    player._replace()\n"  # no first-party module defines it: fine
                     "    _ = _helper()\n"),
        "mid/sub/__init__.py": "",
        "mid/sub/c.py": "from .. import a\nfrom ..a import Sub, _Player\nSub()._mine()\na._own\n",
        "tests/mid/test_a.py": "from mid.a import _Player\n",  # its module: fine
        "tests/mid/sub/test_c.py": "from mid.a import _Player\n",  # not its module
        "tests/low/test_low.py": "import low\nimport low.base\nlow._PKG, low.base._SECRET\n",
    })
    found = [str(u) for u in private_uses(tmp_path, BAD_LAYERS, ["tests"])]
    assert found == [
        "mid/a.py:4: mid.a uses _helper of low.base (imported)",
        "mid/a.py:6: mid.a uses _SECRET of low.base (module attribute)",
        "mid/a.py:6: mid.a uses _shared of low.base (class attribute)",
        "mid/a.py:9: mid.a uses _hook of low.base:Base (inherited)",
        "mid/a.py:10: mid.a uses _lock of low.base:Base (inherited)",
        "mid/a.py:15: mid.a uses _shared of low.base:Base (inherited)",
        "mid/a.py:17: mid.a uses _emit of low.base (attribute)",
        "mid/sub/c.py:2: mid.sub.c uses _Player of mid.a (imported)",
        "mid/sub/c.py:3: mid.sub.c uses _mine of mid.a (attribute)",
        "mid/sub/c.py:4: mid.sub.c uses _own of mid.a (module attribute)",
        "tests/low/test_low.py:3: tests.low.test_low uses _SECRET of low.base (module attribute)",
        "tests/mid/sub/test_c.py:1: tests.mid.sub.test_c uses _Player of mid.a (imported)"]
    assert mirrors("tests.mid.test_a", "mid.a") and mirrors("tests.low.test_low", "low")
    assert not mirrors("tests.mid.test_a", "mid") and not mirrors("bench.test_a", "a")


def test_the_running_graph_shows_a_cycle_an_import_inside_a_function_hides(
        tmp_path: Path) -> None:
    _tree(tmp_path, {
        "pkg/__init__.py": "from pkg.a import A\nfrom other.b import f\n",
        "pkg/a.py": ("from typing import TYPE_CHECKING\n"
                     "if TYPE_CHECKING:\n    from other.c import g\n"  # never runs
                     "else:\n    import other.c\n"
                     "A = 1\n"),
        "pkg/d.py": "def h():\n    from pkg.a import A  # start-up speed\n    return A\n",
        "other/__init__.py": "",
        # moved to module level, this runs pkg/__init__.py, which imports other.b half-loaded
        "other/b.py": "def f():\n    from pkg.a import A\n    return A\n",
        "other/c.py": "",
    })
    packages = ("pkg", "other")
    assert cycles(import_edges(tmp_path, packages)) == []  # the plain graph sees none
    assert [str(e) for e in deferred_imports(tmp_path, packages)] == [
        "other.b -> pkg.a (other/b.py:2)", "pkg.d -> pkg.a (pkg/d.py:2)"]
    running = running_edges(tmp_path, packages)
    assert {(e.source, e.target) for e in running} == {
        ("pkg", "pkg.a"), ("pkg", "other.b"), ("pkg", "other"), ("pkg.a", "other.c"),
        ("pkg.a", "other"), ("pkg.d", "pkg.a"), ("other.b", "pkg.a"), ("other.b", "pkg")}
    assert [[str(e) for e in c] for c in cycles(running)] == [
        ["other.b -> pkg (other/b.py:2)", "pkg -> other.b (pkg/__init__.py:2)"]]
