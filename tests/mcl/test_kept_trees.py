"""The syntax trees mclc keeps between calls (mcl/parser.py: trees_kept): within trees_kept, a
file's text parsed before is loaded from the cache, equal to a fresh parse; an edit, another
file or a syntax error is parsed afresh; outside it, nothing is kept."""

from __future__ import annotations

import io
from contextlib import redirect_stdout
from pathlib import Path

import pytest

from app.mclc import main as mclc
from diagnostics import MclError, Source
from mcl import parser
from tests.support import MISSIONS


@pytest.fixture
def counted(monkeypatch: pytest.MonkeyPatch) -> list[str]:
    """The texts parse_text parsed (not loaded from the cache)."""
    texts: list[str] = []
    real = parser.parse_text

    def parse_text(source: Source) -> object:
        texts.append(source.text)
        return real(source)

    monkeypatch.setattr(parser, "parse_text", parse_text)
    return texts


def dam(name: str = "dam.mcl") -> Source:
    return Source(name, (MISSIONS / "dam_inspection.mcl").read_text("utf-8"))


def test_a_kept_tree_is_loaded_and_equals_a_fresh_parse(folder: Path,
                                                        counted: list[str]) -> None:
    fresh = parser.parse_text(dam())
    counted.clear()
    with parser.trees_kept():
        first, again = parser.parse_unit(dam()), parser.parse_unit(dam())
    assert len(counted) == 1  # the second came from the cache
    assert first == again == fresh and again is not first
    assert len(list(folder.glob("syntax-*.pickle"))) == 1


def test_an_edit_or_another_file_is_parsed_afresh(folder: Path, counted: list[str]) -> None:
    edited = Source("dam.mcl", dam().text.replace("1.5 m;", "1.6 m;", 1))
    with parser.trees_kept():
        parser.parse_unit(dam())
        assert parser.parse_unit(edited) == parser.parse_text(edited)
        parser.parse_unit(dam("other.mcl"))
        parser.parse_unit(dam("other.mcl"))
    assert len(counted) == 4  # dam, edited, the check of it, other (once)
    assert len(list(folder.glob("syntax-*.pickle"))) == 2  # dam.mcl's entry replaced


def test_a_syntax_error_is_never_kept(folder: Path) -> None:
    broken = Source("m.mcl", "MISSION { A(); }")
    with parser.trees_kept():
        for _ in range(2):
            with pytest.raises(MclError, match="';' before '}'"):
                parser.parse_unit(broken)
    assert not list(folder.glob("syntax-*.pickle"))


def test_outside_trees_kept_nothing_is_kept(folder: Path, counted: list[str]) -> None:
    parser.parse_unit(dam())
    parser.parse_unit(dam())
    assert len(counted) == 2 and not list(folder.glob("syntax-*"))
    with parser.trees_kept():
        assert parser.KEEP_TREES
    assert not parser.KEEP_TREES


def test_mclc_keeps_trees_and_leaves_the_setting_as_it_was(folder: Path, counted: list[str],
                                                          tmp_path: Path) -> None:
    path = tmp_path / "m.mcl"
    path.write_text("MISSION { GoTo((0, 0, 5, 0), timeout = 60 s); Surface() }", "utf-8")
    for _ in range(2):
        with redirect_stdout(io.StringIO()):
            assert mclc([str(path), "--no-verify"]) == 0
    assert len(counted) == 1 and not parser.KEEP_TREES
    assert len(list(folder.glob("syntax-*.pickle"))) == 1


def test_the_trees_of_the_files_parsed_last_are_kept(folder: Path,
                                                      monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(parser, "KEEP_TREES_OF", 2)
    with parser.trees_kept():
        for name in ("a.mcl", "b.mcl", "c.mcl"):
            parser.parse_unit(dam(name))
    assert len(list(folder.glob("syntax-*.pickle"))) == 2
