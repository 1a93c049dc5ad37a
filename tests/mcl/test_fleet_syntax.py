"""Syntax errors in a fleet file: the parser's messages for known mistakes work inside a
VEHICLE as in a file of one mission, and a fleet's own words get theirs."""

from __future__ import annotations

import pytest

from diagnostics import Diagnostic, MclError, Source
from mcl.parser import parse_unit
from tests.support import MISSIONS

RELAY = (MISSIONS / "fleet_relay.mcl").read_text("utf-8")


def _error(text: str) -> Diagnostic:
    with pytest.raises(MclError) as err:
        parse_unit(Source("relay.mcl", text))
    [d] = err.value.diagnostics
    return d


def _line_of(needle: str, text: str) -> int:
    return next(i for i, line in enumerate(text.split("\n"), 1) if needle in line)


@pytest.mark.parametrize(("old", "new", "code", "needle"), [
    ("            Surface()\n        } ON STOP {\n            Send",
     "            Surface();\n        } ON STOP {\n            Send", "trailing-semicolon",
     "Surface();"),
    ("GoTo(postPos);", "GoTo(postPos)", "missing-semicolon", "GoTo(postPos)"),
    ("LOSSY", "lossy", "lower-case-keyword", "2 s lossy"),
    ("ACOUSTIC", "acoustic", "lower-case-keyword", "follower acoustic"),
    ("VEHICLE leader", "vehicle leader", "lower-case-keyword", "vehicle leader"),
    ("MESSAGES start, abort;", "MESSAGES start, abort", "missing-semicolon", "MESSAGES"),
])
def test_a_mistake_in_a_fleet_is_named_where_it_is(old: str, new: str, code: str,
                                                   needle: str) -> None:
    assert old in RELAY
    text = RELAY.replace(old, new, 1)
    d = _error(text)
    assert d.code == code, d.format()
    assert d.span is not None and d.span.line == _line_of(needle, text)


def test_a_channel_with_a_delay_not_written_as_a_range_says_what_is_expected() -> None:
    d = _error(RELAY.replace("DELAY 1 s .. 4 s", "DELAY 1 s 4 s", 1))
    assert d.code == "syntax" and "'..'" in d.hint


def test_an_unknown_link_kind_names_the_three() -> None:
    d = _error(RELAY.replace("ACOUSTIC", "SONAR", 1))
    assert "ACOUSTIC, RADIO, TETHER" in d.hint
