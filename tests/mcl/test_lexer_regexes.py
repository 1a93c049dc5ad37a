"""The standalone parser's regular expressions kept compiled (mcl/lexer_regexes.py): a pattern
made from its kept parts is the one ``re`` compiles, a parser loaded from the cache compiles
none of its lexer's patterns again, and what cannot be kept is compiled as always."""

from __future__ import annotations

import re
from pathlib import Path

import lark
import pytest

from mcl import grammars, lexer_regexes
from tests.support import MISSIONS

OPTIONS = {"parser": "lalr", "propagate_positions": True, "maybe_placeholders": True,
           "start": ["start", "value"]}
PATTERNS = [("(?P<NAME>[A-Za-z_][A-Za-z0-9_]*)|(?P<NUMBER>[0-9]+(?:\\.[0-9]*)?)", 0),
            ("//[^\\n]*", 0), ("(?i:mission)", 0), ("[ \\t\\f\\r\\n]+", re.MULTILINE),
            ('".*?(?<!\\\\)(\\\\\\\\)*?"', 0)]


@pytest.mark.parametrize(("pattern", "flags"), PATTERNS)
def test_a_pattern_made_from_its_kept_parts_is_the_one_re_compiles(pattern: str,
                                                                   flags: int) -> None:
    recorder, kept = lexer_regexes.recording()
    assert recorder.compile(pattern, flags) == re.compile(pattern, flags)
    assert set(kept) == {(pattern, flags)}
    made = lexer_regexes.kept(kept).compile(pattern, flags)
    assert made == re.compile(pattern, flags)  # text, flags and the engine's code
    assert made.groupindex == re.compile(pattern, flags).groupindex
    text = 'x1 3.5 // c\n "a\\"b" MISSION'
    assert [m.group(0) for m in made.finditer(text)] == [
        m.group(0) for m in re.compile(pattern, flags).finditer(text)]


def test_parts_the_engine_refuses_are_compiled_by_re() -> None:
    pattern, flags = PATTERNS[0]
    parts = lexer_regexes.parts_of(pattern, flags)
    assert parts is not None
    broken = (parts[0], [0, 0, 0], *parts[2:])  # code that is not a pattern's
    made = lexer_regexes.kept({(pattern, flags): broken}).compile(pattern, flags)
    assert made == re.compile(pattern, flags)
    other = lexer_regexes.kept({}).match("[0-9]+", "42abc")
    assert other is not None and other.group(0) == "42"


def test_a_loaded_parser_compiles_none_of_its_lexers_patterns(
        folder: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    text = (MISSIONS / "dam_inspection.mcl").read_text("utf-8")
    fresh = lark.Lark.open_from_package("mcl", "mcl.lark", ("grammar",), **OPTIONS)
    expected = fresh.parse(text, start="start")
    grammars.standalone("mcl.lark", **OPTIONS)  # built: its patterns kept with it
    loaded = grammars.standalone("mcl.lark", **OPTIONS).parser  # its scanners not built yet
    compiled: list[str] = []
    real = re.compile

    def counted(pattern: str, flags: int = 0) -> re.Pattern[str]:
        compiled.append(pattern)
        return real(pattern, flags)

    monkeypatch.setattr(re, "compile", counted)
    assert loaded.parse(text, start="start") == expected  # every state's scanner built
    with pytest.raises(Exception) as refused:  # noqa: PT011 - lark's own class of error
        loaded.parse("MISSION { A( }", start="start")
    assert compiled == []
    assert type(refused.value).__name__ == "UnexpectedToken"
    monkeypatch.setattr(lexer_regexes, "kept", lambda regexes: re)  # the check can fail:
    plain = grammars.standalone("mcl.lark", **OPTIONS).parser  # as re compiles them
    assert plain.parse(text, start="start") == expected
    assert len(compiled) > 10
