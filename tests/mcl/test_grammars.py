"""The grammars' parsers (mcl/grammars.py): built by lark once, then loaded from the cache,
parsing exactly as a parser lark builds afresh."""

from __future__ import annotations

from pathlib import Path

import lark
import pytest

from mcl import grammars
from tests.support import MISSIONS

OPTIONS = {"parser": "lalr", "propagate_positions": True, "maybe_placeholders": True,
           "start": ["start", "value"]}


@pytest.fixture
def folder(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    place = tmp_path / "cache"
    monkeypatch.setenv("MCL_CACHE_DIR", str(place))
    return place


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
