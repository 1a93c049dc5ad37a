"""mcl/formatter.py: the canonical layout of ``mcl fmt``, comments kept.

The layout is pinned on a small mission written carelessly; then on every shipped mission and on
random missions (Hypothesis, tests/strategies.py) laid out with random blanks and comments
between their tokens: the formatted text parses to the same mission, formatting it again
changes nothing, and every comment is still there, in the same order.
"""

from __future__ import annotations

import re
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from diagnostics import MclError, Source
from mcl import printer
from mcl.formatter import WIDTH, format_text
from mcl.parser import parse
from tests import strategies as S
from tests.support import single_missions

COMMENT = re.compile(r"//[^\n]*|/\*.*?\*/", re.S)


def comments(text: str) -> list[str]:
    return [c.rstrip() for c in COMMENT.findall(text)]


def same_mission(a: str, b: str) -> bool:
    return parse(Source("a.mcl", a)) == parse(Source("b.mcl", b))


MESSY = """\
// the head comment

USES   "ictineu" ;
PARAM a=1 m;   // one
PARAM longer = (1,2,3 , 0deg);// two
PARAM lane=[
  (0,1),(0,4),
     (1,4)
];


MISSION   demo{StartLogs ( enable ) ;
  /* before the TRY */
  TRY{GoTo(a)}CATCH{Alarms()}DO{Surface()};   // a one-line TRY
  IF {GoTo((1,2,3,0 deg),timeout=5min)}THEN{Wait(1 s);Wait(2 s)}
  ELSE{
  Surface()
  // the end of ELSE
  }
}ON STOP{Surface()}
"""

EXPECTED = """\
// the head comment

USES "ictineu";
PARAM a      = 1 m;               // one
PARAM longer = (1, 2, 3, 0 deg);  // two
PARAM lane = [
    (0, 1), (0, 4),
    (1, 4)
];

MISSION demo {
    StartLogs(enable);
    /* before the TRY */
    TRY { GoTo(a) } CATCH { Alarms() } DO { Surface() };  // a one-line TRY
    IF { GoTo((1, 2, 3, 0 deg), timeout = 5 min) } THEN {
        Wait(1 s);
        Wait(2 s)
    } ELSE {
        Surface()
        // the end of ELSE
    }
} ON STOP {
    Surface()
}
"""


def test_the_canonical_layout() -> None:
    assert format_text(MESSY) == EXPECTED
    assert format_text(EXPECTED) == EXPECTED
    assert same_mission(MESSY, EXPECTED)


def test_a_construct_too_wide_for_a_line_is_broken_its_condition_kept() -> None:
    call = "GoTo((" + ", ".join(["1"] * 30) + "))"
    text = format_text(f"MISSION {{ WHILE {{ A() }} DO {{ {call} }} }}")
    assert len(f"    WHILE {{ A() }} DO {{ {call} }}") > WIDTH
    assert text == f"MISSION {{\n    WHILE {{ A() }} DO {{\n        {call}\n    }}\n}}\n"


def test_one_blank_line_kept_of_many_none_after_a_brace() -> None:
    text = format_text("MISSION {\n\n\n  A();\n\n\n\n  B()\n\n}\n")
    assert text == "MISSION {\n    A();\n\n    B()\n}\n"


def test_comments_inside_a_call_and_after_a_brace() -> None:
    source = "MISSION { // the body\n GoTo(1, // x\n 2 /* y */, 3) /* z */ }\n// the end\n"
    text = format_text(source)
    assert comments(text) == comments(source)
    assert text == ("MISSION {  // the body\n    GoTo(1,  // x\n        2 /* y */, 3) /* z */\n"
                    "}\n// the end\n")
    assert format_text(text) == text and same_mission(text, source)


def test_windows_line_ends_become_unix_ones_comments_included() -> None:
    text = format_text("MISSION { A() // x\r\n /* y\r\n z */ }\r\n")
    assert text == "MISSION {\n    A()  // x\n    /* y\n z */\n}\n"


def test_text_that_does_not_parse_is_the_parser_error() -> None:
    with pytest.raises(MclError, match="';' before '}'"):
        format_text("MISSION { A(); }")


SHIPPED = single_missions()


@pytest.mark.parametrize("path", SHIPPED, ids=lambda p: p.name)
def test_shipped_missions(path: Path) -> None:
    source = path.read_text("utf-8")
    text = format_text(source, str(path))
    assert same_mission(text, source)
    assert format_text(text, str(path)) == text
    assert comments(text) == comments(source)
    assert len(comments(source)) >= 2  # the shipped missions are full of comments


SEPARATORS = st.sampled_from([" ", "  ", "\n", "\n\n\n", "\t", " /* c{} */ ", "// c{}\n",
                              "\n  // c{}\n", " /* c{}\n  */\n"])


@st.composite
def laid_out(draw: st.DrawFn) -> tuple[str, str]:
    """A random mission, printed, then laid out again with random blanks and numbered comments
    between its tokens; with the printed text."""
    printed = printer.mission(draw(S.ictineu_missions(max_depth=3, max_calls=8)))
    tokens = [m.group() for m in S.TOKEN.finditer(printed)]
    parts = [tokens[0]]
    for i, tok in enumerate(tokens[1:]):
        parts += [draw(SEPARATORS).replace("{}", str(i)), tok]
    return printed, "".join(parts) + draw(st.sampled_from(["", "\n", "\n// the end\n"]))


@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(laid_out())
def test_random_layouts_and_comments(case: tuple[str, str]) -> None:
    printed, source = case
    text = format_text(source)
    assert same_mission(text, printed)
    assert format_text(text) == text
    assert comments(text) == comments(source)
    assert all(line == line.rstrip() for line in text.splitlines())  # no trailing blanks
