"""mcl/printer.py on its own: an AST back to MCL text, in one canonical layout.

The layout is pinned on a small mission; then ``parse(print(m)) == m`` and printing is a fixed
point (print(parse(print(m))) == print(m)) on every shipped mission and on random missions
(Hypothesis, tests/strategies.py), and every call of the reparsed mission sits where the
printed text has it.
"""

from __future__ import annotations

from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from diagnostics import Source
from mcl import ast, printer
from mcl.parser import parse
from tests import strategies as S
from tests.support import single_missions

N = ast.Number


def test_the_canonical_layout() -> None:
    m = ast.Mission(
        "demo",
        ast.Sequence((
            ast.Call("GoTo", (ast.Arg(ast.Point((N(1, "m"), N(-2.5), N(3), N(90, "deg")))),
                              ast.Arg(N(2, "min"), "timeout"))),
            ast.TryCatchDo(ast.Call("A", ()), ast.Call("B", ()),
                           ast.Sequence((ast.Call("C", ()), ast.Call("D", ())))),
            ast.IfThenElse(ast.Call("A", ()), ast.Call("B", ()), None),
            ast.ParallelOr((ast.Call("A", ()), ast.Call("Wait", (ast.Arg(N(1, "s")),)))),
        )),
        (ast.Param("lane", ast.ListValue((ast.Point((N(0), N(1))), ast.Ref("other")))),
         ast.Param("h", None)),
        uses=(ast.Uses("my.tasks"),),
    )
    assert printer.mission(m) == (
        'USES "my.tasks";\n'
        "PARAM lane = [(0, 1), other];\n"
        "PARAM h;\n"
        "MISSION demo {\n"
        "    GoTo((1 m, -2.5, 3, 90 deg), timeout = 2 min);\n"
        "    TRY {\n"
        "        A()\n"
        "    } CATCH {\n"
        "        B()\n"
        "    } DO {\n"
        "        C();\n"
        "        D()\n"
        "    };\n"
        "    IF {\n"
        "        A()\n"
        "    } THEN {\n"
        "        B()\n"
        "    };\n"
        "    PARALLEL {\n"
        "        A()\n"
        "    } OR {\n"
        "        Wait(1 s)\n"
        "    }\n"
        "}\n")


def test_an_unnamed_mission_and_each_remaining_construct() -> None:
    body = ast.Sequence((
        ast.ParallelAnd((ast.Call("A", ()), ast.Call("B", ()), ast.Call("C", ()))),
        ast.WhileDo(ast.Call("A", ()), ast.Call("Lamp", (ast.Arg(ast.Ref("enable")),))),
        ast.IfThenElse(ast.Call("A", ()), ast.Call("B", ()), ast.Call("C", ())),
    ))
    text = printer.mission(ast.Mission(None, body))
    assert text.startswith("MISSION {\n    PARALLEL {\n        A()\n    } AND {\n")
    assert "    } AND {\n        C()\n    };\n" in text
    assert "    WHILE {\n        A()\n    } DO {\n        Lamp(enable)\n    };\n" in text
    assert "    } THEN {\n        B()\n    } ELSE {\n        C()\n    }\n}\n" in text


@pytest.mark.parametrize("call,text", [
    (ast.Call("Surface", ()), "Surface()"),
    (ast.Call("KeepHeadDist", (ast.Arg(ast.Ref("enable")), ast.Arg(N(10, "deg")),
                               ast.Arg(N(1.5, "m")))), "KeepHeadDist(enable, 10 deg, 1.5 m)"),
    (ast.Call("GoTo", (ast.Arg(ast.Ref("home")), ast.Arg(N(0.25, "m"), "tolerance"))),
     "GoTo(home, tolerance = 0.25 m)"),
    (ast.Call("Wait", (ast.Arg(N(1e20, "s")),)), "Wait(1e+20 s)"),
    (ast.Call("W", (ast.Arg(ast.ListValue(())),)), "W([])"),
])
def test_a_call_as_written(call: ast.Call, text: str) -> None:
    assert printer.call(call) == text
    parsed = parse(Source("c.mcl", f"MISSION {{ {text} }}")).body
    assert parsed == call


def test_a_braced_block_at_a_depth() -> None:
    block = ast.Sequence((ast.Call("A", ()), ast.Call("B", ())))
    assert printer.block(block, 1) == "{\n        A();\n        B()\n    }"
    assert printer.block(ast.Call("A", ()), 0) == "{\n    A()\n}"


def _round_trip(mission: ast.Mission) -> None:
    text = printer.mission(mission)
    again = parse(Source("printed.mcl", text))
    assert again == mission, text
    assert printer.mission(again) == text
    lines = text.split("\n")
    for call in ast.calls(again.body):  # each call sits where the text has it
        line = lines[call.span.line - 1]
        assert line[call.span.col - 1:].startswith(printer.call(call))


SHIPPED = single_missions()


@pytest.mark.parametrize("path", SHIPPED, ids=[p.stem for p in SHIPPED])
def test_round_trip_of_each_shipped_mission(path: Path) -> None:
    _round_trip(parse(Source(str(path), path.read_text("utf-8"))))


def test_there_are_shipped_missions_to_round_trip() -> None:
    assert len(SHIPPED) >= 4


@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.one_of(S.ictineu_missions(max_depth=3, max_calls=8), S.any_missions(),
                 S.generic_missions(lamps="free")))
def test_round_trip_of_random_missions(mission: ast.Mission) -> None:
    _round_trip(mission)
