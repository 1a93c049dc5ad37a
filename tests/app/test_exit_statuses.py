"""The exit statuses in one table (issue 20): no command in ``app/`` returns, exits with or
names a bare number, each takes its statuses from ``mission.exits.Exit``, and each points to
docs/EXIT.md, the one page that documents them (tests/mission/test_exits.py checks the page
against the table)."""

from __future__ import annotations

import ast
import re
from pathlib import Path

import pytest

from app.mcl import COMMANDS
from mission.exits import SIGNAL_BASE
from tests.support import REPO


def bare_statuses(path: Path, root: Path = REPO) -> list[str]:
    """Where a module writes an exit status as a number: ``return 3``, ``sys.exit(4)``,
    ``SystemExit(1)``, ``128 + ...``, ``EXIT_X = 2`` (``file:line: code``, the file relative
    to ``root``)."""
    tree = ast.parse(path.read_text("utf-8"), str(path))
    found: list[tuple[int, str]] = []

    def number(node: ast.AST | None) -> bool:
        return (isinstance(node, ast.Constant) and type(node.value) is int) or (
            isinstance(node, ast.Tuple) and any(number(e) for e in node.elts)) or (
            isinstance(node, ast.IfExp) and (number(node.body) or number(node.orelse)))

    for node in ast.walk(tree):
        bad = False
        if isinstance(node, ast.Return):
            bad = number(node.value)
        elif isinstance(node, ast.Call):
            f = node.func
            name = f.attr if isinstance(f, ast.Attribute) else getattr(f, "id", "")
            bad = name in ("exit", "SystemExit", "_exit") and any(number(a) for a in node.args)
        elif isinstance(node, ast.BinOp) and isinstance(node.op, ast.Add):
            bad = any(isinstance(s, ast.Constant) and s.value == SIGNAL_BASE
                      for s in (node.left, node.right))
        elif isinstance(node, ast.Assign):
            names = [n.id for t in node.targets for n in ast.walk(t) if isinstance(n, ast.Name)]
            bad = any(re.fullmatch(r"EXIT_[A-Z_]+", n) for n in names) and number(node.value)
        if bad:
            found.append((getattr(node, "lineno", 0), ast.unparse(node).splitlines()[0]))
    return [f"{path.relative_to(root)}:{line}: {code}" for line, code in sorted(found)]


def test_no_command_writes_an_exit_status_as_a_number() -> None:
    found = [hit for path in sorted((REPO / "app").rglob("*.py")) for hit in bare_statuses(path)]
    assert not found, "exit statuses not taken from mission.exits.Exit:\n" + "\n".join(found)


def test_the_scan_finds_what_it_looks_for(tmp_path: Path) -> None:
    probe = tmp_path / "probe.py"
    probe.write_text("import sys\nEXIT_OK, EXIT_BAD = 0, 1\n"
                     "def main():\n    if x:\n        return 3\n    sys.exit(4)\n"
                     "def f(signum):\n    return 128 + signum\n"
                     "def g():\n    return Exit.OK if y else 1\n"
                     "def fine():\n    return Exit.OK\n")
    hits = [h.split(": ", 1)[1] for h in bare_statuses(probe, tmp_path)]
    assert hits == ["EXIT_OK, EXIT_BAD = (0, 1)", "return 3", "sys.exit(4)",
                    "128 + signum", "return Exit.OK if y else 1"], hits


@pytest.mark.parametrize("module", ["app.mclc", "app.mcl", *(m for m, _ in COMMANDS.values()),
                                    "app.check", "app.pnml_report", "app.guard"])
def test_each_command_points_to_the_page(module: str) -> None:
    path = REPO / Path(*module.split(".")).with_suffix(".py")
    doc = ast.get_docstring(ast.parse(path.read_text("utf-8"))) or ""
    assert "docs/EXIT.md" in doc, f"{path.relative_to(REPO)}: its docstring does not point " \
        "to docs/EXIT.md"
