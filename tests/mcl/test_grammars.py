"""The grammars' parsers (mcl/grammars.py): built by lark once, then loaded from the cache,
parsing exactly as a parser lark builds afresh; the standalone parser of missions too, which
fails where and as lark's does, and loads without lark."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import lark
import pytest

from mcl import grammars
from tests.support import MISSIONS, REPO, subprocess_env

OPTIONS = {"parser": "lalr", "propagate_positions": True, "maybe_placeholders": True,
           "start": ["start", "value"]}


def shape(tree: lark.Tree[lark.Token]) -> list[tuple[str, int, int, int, int]]:
    """Every subtree's rule and place: what the syntax tree's spans are made from."""
    return [(t.data, t.meta.line, t.meta.column, t.meta.end_line, t.meta.end_column)
            for t in tree.iter_subtrees() if not t.meta.empty]


def test_a_second_call_loads_the_parser_without_building_it(
        folder: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    text = (MISSIONS / "dam_inspection.mcl").read_text("utf-8")
    fresh = lark.Lark.open_from_package("mcl", "mcl.lark", ("grammar",), **OPTIONS)
    built = grammars.parser("mcl.lark", **OPTIONS)
    assert [p.name for p in folder.iterdir()] == [
        next(folder.glob("grammar-mcl-*.pickle")).name]

    def no_build(*args: object, **kwargs: object) -> None:
        raise AssertionError("lark built the grammar again")

    monkeypatch.setattr(lark.Lark, "__init__", no_build)  # Lark.load does not call it
    loaded = grammars.parser("mcl.lark", **OPTIONS)
    expected = fresh.parse(text, start="start")
    for parser in (built, loaded):
        tree = parser.parse(text, start="start")
        assert tree == expected and shape(tree) == shape(expected)
    assert loaded.parse("(1, 2 m)", start="value") == fresh.parse("(1, 2 m)", start="value")


def test_another_grammar_text_or_option_is_another_entry(
        folder: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    grammars.parser("mcl.lark", **OPTIONS)
    shipped = grammars.grammar_text("mcl.lark")
    assert "MISSION" in shipped
    monkeypatch.setattr(grammars, "grammar_text",
                        lambda name: shipped + '\n// an edit\n')
    grammars.parser("mcl.lark", **OPTIONS)
    assert len(list(folder.glob("grammar-mcl-*.pickle"))) == 1  # the old entry was replaced
    before = {p.name for p in folder.iterdir()}
    grammars.parser("mcl.lark", **{**OPTIONS, "start": ["start"]})
    assert {p.name for p in folder.iterdir()} != before


def test_both_grammars_are_cached_apart(folder: Path) -> None:
    tasks = grammars.parser("tasks.lark", parser="lalr", propagate_positions=True,
                            maybe_placeholders=True, start="library")
    grammars.parser("mcl.lark", **OPTIONS)
    assert sorted(p.name.split("-")[1] for p in folder.iterdir()) == ["mcl", "tasks"]
    tree = tasks.parse("behaviour B events e;")
    assert tree.data == "library"


# -- the standalone parser missions are parsed with ----------------------------------------------
def test_the_standalone_parser_parses_every_shipped_mission_as_lark_does(folder: Path) -> None:
    fresh = lark.Lark.open_from_package("mcl", "mcl.lark", ("grammar",), **OPTIONS)
    made = grammars.standalone("mcl.lark", **OPTIONS)  # generated, then loaded
    loaded = grammars.standalone("mcl.lark", **OPTIONS)
    assert [p.name.split("-")[0] for p in folder.iterdir()] == ["standalone"]
    assert not isinstance(loaded.parser, lark.Lark)  # its own classes, not lark's
    texts = [p.read_text("utf-8") for p in sorted(MISSIONS.glob("*.mcl"))]
    assert len(texts) >= 4
    for text in texts:
        expected = fresh.parse(text, start="start")
        for standalone in (made, loaded):
            tree = standalone.parser.parse(text, start="start")
            assert tree == expected and shape(tree) == shape(expected)
    assert loaded.parser.parse("(1, 2 m)", start="value") == fresh.parse("(1, 2 m)",
                                                                           start="value")


@pytest.mark.parametrize("text", ["MISSION { A(); }", "MISSION { A() B() }", "MISSION { A()",
                                  "MISSION { A() $ }"])
def test_the_standalone_parser_fails_where_and_as_lark_does(folder: Path, text: str) -> None:
    fresh = lark.Lark.open_from_package("mcl", "mcl.lark", ("grammar",), **OPTIONS)
    standalone = grammars.standalone("mcl.lark", **OPTIONS)
    with pytest.raises(lark.UnexpectedInput) as expected:
        fresh.parse(text, start="start")
    with pytest.raises(standalone.unexpected_input) as got:
        standalone.parser.parse(text, start="start")
    assert type(got.value).__name__ == type(expected.value).__name__
    assert (got.value.line, got.value.column) == (expected.value.line, expected.value.column)
    for name in ("token", "expected", "accepts"):  # (the states' numbers are each table's)
        assert getattr(got.value, name, None) == getattr(expected.value, name, None), name


def test_without_a_cache_missions_are_parsed_by_lark_itself(
        monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("MCL_CACHE_DIR", "")
    standalone = grammars.standalone("mcl.lark", **OPTIONS)
    assert isinstance(standalone.parser, lark.Lark)
    assert standalone.unexpected_input is lark.UnexpectedInput
    assert standalone.unexpected_eof is lark.UnexpectedEOF


def imported_by_a_parse(folder: Path, names: tuple[str, ...]) -> str:
    """Which of the modules (or packages) ``names`` a fresh Python has imported once it has
    parsed a mission with the standalone parser in the cache ``folder``, as printed."""
    code = ("import sys; from mcl.parser import parse; from diagnostics import Source; "
            "parse(Source('m.mcl', 'MISSION { GoTo((0, 0, 1, 0)) }')); "
            f"print(sorted(m for m in sys.modules if m.split('.')[0] in {names!r}))")
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          env=subprocess_env(MCL_CACHE_DIR=str(folder)), cwd=REPO, timeout=60)
    assert proc.returncode == 0, proc.stderr
    return proc.stdout.strip()


def test_a_loaded_standalone_parser_imports_neither_lark_nor_logging(folder: Path) -> None:
    grammars.standalone("mcl.lark", **OPTIONS)  # generated into the cache
    assert imported_by_a_parse(folder, ("lark", "logging")) == "[]"


def test_lark_s_version_is_read_without_importing_lark(monkeypatch: pytest.MonkeyPatch) -> None:
    assert grammars.lark_version() == lark.__version__
    monkeypatch.delitem(sys.modules, "lark")
    assert grammars.lark_version() == lark.__version__  # read from its __init__.py
    assert "lark" not in sys.modules


def test_another_generator_is_another_standalone_entry(
        folder: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    grammars.standalone("mcl.lark", **OPTIONS)
    before = {p.name for p in folder.iterdir()}
    monkeypatch.setattr(grammars, "GENERATOR", grammars.GENERATOR + ", changed")
    grammars.standalone("mcl.lark", **OPTIONS)
    after = {p.name for p in folder.iterdir()}
    assert len(after) == 1 and after != before


def test_a_loaded_standalone_parser_imports_neither_zlib_nor_base64(folder: Path) -> None:
    grammars.standalone("mcl.lark", **OPTIONS)  # its tables are literals: nothing to decode
    assert imported_by_a_parse(folder, ("zlib", "base64", "binascii")) == "[]"
