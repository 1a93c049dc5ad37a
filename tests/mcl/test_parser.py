"""mcl/parser.py on its own: MCL text -> AST (with spans), and syntax errors at their place.

The parser needs no task library: ``A()``, ``B()`` are just calls here. Every syntax error is an
:class:`MclError` whose first diagnostic has a stable code and an exact ``file:line:col``;
each row of :data:`mcl.parser.KNOWN_MISTAKES` is exercised with every example it lists.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from diagnostics import Diagnostic, MclError, Source
from mcl import ast
from mcl.parser import KEYWORDS, KNOWN_MISTAKES, MAX_DEPTH, parse, parse_file, parse_value, suggest


def _parse(text: str, name: str = "m.mcl") -> ast.Mission:
    return parse(Source(name, text))


def _error(text: str, name: str = "m.mcl") -> Diagnostic:
    with pytest.raises(MclError) as info:
        _parse(text, name)
    assert len(info.value.errors) == 1
    return info.value.errors[0]


def _where(d: Diagnostic) -> str:
    return str(d.span)


# -- text -> AST -----------------------------------------------------------------------------
EVERY_CONSTRUCT = """\
USES "ictineu";
PARAM h = 90 deg;
PARAM p;
MISSION dam {
  GoTo((1 m, 2, 3, 4 deg), tolerance = 0.5 m);
  TRY { A() } CATCH { B() } DO { C(); D() };
  PARALLEL { A() } AND { B() } AND { C() };
  PARALLEL { A() } OR { B() };
  IF { A() } THEN { B() } ELSE { C() };
  IF { A() } THEN { B() };
  WHILE { A() } DO { Lamp(enable) };
  Wait([x, [1, 2 km], (1, 2)])
}
"""


def test_every_construct_gives_its_node() -> None:
    n = ast.Number
    a, b, c, d = (ast.Call(x, ()) for x in "ABCD")
    expected = ast.Mission(
        "dam",
        ast.Sequence((
            ast.Call("GoTo", (ast.Arg(ast.Point((n(1, "m"), n(2), n(3), n(4, "deg")))),
                              ast.Arg(n(0.5, "m"), "tolerance"))),
            ast.TryCatchDo(a, b, ast.Sequence((c, d))),
            ast.ParallelAnd((a, b, c)),
            ast.ParallelOr((a, b)),
            ast.IfThenElse(a, b, c),
            ast.IfThenElse(a, b, None),
            ast.WhileDo(a, ast.Call("Lamp", (ast.Arg(ast.Ref("enable")),))),
            ast.Call("Wait", (ast.Arg(ast.ListValue((
                ast.Ref("x"), ast.ListValue((n(1), n(2, "km"))), ast.Point((n(1), n(2)))))),)),
        )),
        (ast.Param("h", n(90, "deg")), ast.Param("p", None)),
        uses=(ast.Uses("ictineu"),),
    )
    assert _parse(EVERY_CONSTRUCT) == expected


def test_spans_are_file_line_col_of_each_node() -> None:
    m = _parse(EVERY_CONSTRUCT, "every.mcl")
    assert isinstance(m.body, ast.Sequence)
    goto, try_ = m.body.items[0], m.body.items[1]
    assert isinstance(goto, ast.Call) and isinstance(try_, ast.TryCatchDo)
    point, tolerance = goto.args
    assert isinstance(point.value, ast.Point)
    spans = {
        "mission": m.span, "use": m.uses[0].span, "param h": m.params[0].span,
        "value of h": m.params[0].value.span if m.params[0].value else None,
        "body": m.body.span, "GoTo": goto.span, "point": point.span,
        "x of point": point.value.items[0].span, "yaw of point": point.value.items[3].span,
        "named arg": tolerance.span, "its value": tolerance.value.span,
        "TRY": try_.span, "DO's sequence": try_.do.span,
    }
    assert {k: str(s) for k, s in spans.items()} == {
        "mission": "every.mcl:4:1", "use": "every.mcl:1:6", "param h": "every.mcl:2:7",
        "value of h": "every.mcl:2:11", "body": "every.mcl:4:13", "GoTo": "every.mcl:5:3",
        "point": "every.mcl:5:8", "x of point": "every.mcl:5:9",
        "yaw of point": "every.mcl:5:20", "named arg": "every.mcl:5:28",
        "its value": "every.mcl:5:40", "TRY": "every.mcl:6:3", "DO's sequence": "every.mcl:6:32",
    }
    # ends are exclusive: "GoTo(...)" spans columns 3 to 45 of line 5
    assert (goto.span.end_line, goto.span.end_col) == (5, 46)
    assert (m.span.end_line, m.span.end_col) == (13, 2)


def test_a_block_of_one_item_is_that_item_and_of_several_a_sequence() -> None:
    assert _parse("MISSION { A() }").body == ast.Call("A", ())
    assert _parse("MISSION { A(); B() }").body == ast.Sequence(
        (ast.Call("A", ()), ast.Call("B", ())))
    inner = _parse("MISSION { TRY { A() } CATCH { B() } DO { C() } }").body
    assert isinstance(inner, ast.TryCatchDo) and inner.do == ast.Call("C", ())


def test_an_unnamed_mission_without_headers() -> None:
    m = _parse("MISSION { A() }")
    assert (m.name, m.params, m.uses) == (None, (), ())


def test_comments_and_blank_lines_are_ignored_and_positions_count_them() -> None:
    text = "// a mission\n/* several\n   lines */\nMISSION {\n\n  A() // end\n}\n"
    m = _parse(text)
    assert m.body == ast.Call("A", ())
    assert str(m.body.span) == "m.mcl:6:3"


def test_windows_line_endings_give_the_same_mission_and_positions() -> None:
    unix = _parse("MISSION {\n  A();\n  B()\n}\n")
    windows = _parse("MISSION {\r\n  A();\r\n  B()\r\n}\r\n")
    assert windows == unix
    assert isinstance(windows.body, ast.Sequence)
    assert str(windows.body.items[1].span) == "m.mcl:3:3"


def test_keywords_are_the_grammars() -> None:
    text = _parse(EVERY_CONSTRUCT)  # every keyword but none unknown to the parser
    assert text.name == "dam"
    assert set(KEYWORDS) == {"MISSION", "PARAM", "USES", "TRY", "CATCH", "DO", "PARALLEL",
                             "AND", "OR", "IF", "THEN", "ELSE", "WHILE", "ON", "STOP"}


# -- syntax errors at their place ------------------------------------------------------------
# Every example of the table, with where its error must point (line:col of "m.mcl").
MISTAKE_PLACES = {
    "MISSION { A(); }": "1:14",  # the ';' itself
    "MISSION { A(); B(); }": "1:19",
    "MISSION { TRY { A(); } CATCH { B() } DO { C() } }": "1:20",
    "MISSION { TRY { A() CATCH { B() } DO { C() } }": "1:21",  # CATCH
    "MISSION { TRY { A(); B() CATCH { B() } DO { C() } }": "1:26",
    "MISSION { TRY { A() } CATCH { B() DO { C() } }": "1:35",  # DO
    "MISSION { WHILE { A() DO { C() } }": "1:23",
    "MISSION { IF { A() THEN { B() } }": "1:20",  # THEN
    "MISSION { IF { A() } THEN { B() ELSE { C() } }": "1:33",  # ELSE
    "MISSION { PARALLEL { A() } AND { B() } OR { C() } }": "1:40",  # OR
    "MISSION { PARALLEL { A() } OR { B() } AND { C() } }": "1:39",  # AND
    "MISSION { A() B() }": "1:14",  # just after A()
    "MISSION { A() TRY { B() } CATCH { C() } DO { D() } }": "1:14",
    "MISSION { TRY { B() } CATCH { C() } DO { D() } A() }": "1:47",
    "MISSION { }": "1:11",  # the '}'
    "MISSION { TRY { } CATCH { A() } DO { B() } }": "1:17",
    "PARAM a = 1;": "1:13",  # the end of the file
    "A()": "1:4",
    "MISSION { A()": "1:14",
    "MISSION { TRY { A() } CATCH { B() } DO { C() }": "1:47",
    "MISSION { TRY A() }": "1:15",  # the A that should be a '{'
    "MISSION { PARALLEL { A() } AND B() }": "1:32",
    "MISSION { IF A() }": "1:14",
    "MISSION { A }": "1:11",  # the name without '()'
    "MISSION { A; B() }": "1:11",
    "MISSION { A() } B()": "1:17",  # what follows the mission
    "MISSION { A() } }": "1:17",
}


@pytest.mark.parametrize("code,example", [(code, ex) for code, (_, _, examples)
                                          in KNOWN_MISTAKES.items() for ex in examples])
def test_each_known_mistake_is_recognised_at_its_place(code: str, example: str) -> None:
    d = _error(example)
    assert d.code == code
    assert d.message == KNOWN_MISTAKES[code][0] and d.hint == KNOWN_MISTAKES[code][1]
    assert _where(d) == f"m.mcl:{MISTAKE_PLACES[example]}"


def test_the_table_of_places_covers_every_example() -> None:
    examples = {ex for _, _, exs in KNOWN_MISTAKES.values() for ex in exs}
    assert examples == set(MISTAKE_PLACES)


@pytest.mark.parametrize("code,example", [(code, ex) for code, (_, _, examples)
                                          in KNOWN_MISTAKES.items() for ex in examples])
@pytest.mark.parametrize("before", ["PARAM a = 1;\n", "PARAM a = 1;\nPARAM b = (1, 2);\n"])
def test_a_known_mistake_is_recognised_after_param_lines(code: str, example: str,
                                                          before: str) -> None:
    d = _error(before + example)
    assert d.code == code
    line, col = MISTAKE_PLACES[example].split(":")
    assert _where(d) == f"m.mcl:{int(line) + before.count(chr(10))}:{col}"


@pytest.mark.parametrize("text,where", [
    ("MISSION {\n  A();\n  B()\n", "3:6"),  # issue 21: was "'}' missing before CATCH"
    ("PARAM d = 1 m;\nMISSION {\n  A(d);\n  B(timeout = 2 min)\n", "4:21"),
    ("MISSION {\n  PARALLEL {\n    A();\n    B()\n  } AND { C() }\n", "5:16"),
])
def test_a_missing_final_brace_is_named_as_such(text: str, where: str) -> None:
    d = _error(text)
    assert (d.code, _where(d)) == ("unclosed-block", f"m.mcl:{where}")


@pytest.mark.parametrize("text,code,where,words", [
    ("mission { A() }", "lower-case-keyword", "1:1", "write MISSION, not mission"),
    ("MISSION {\n  A();\n  try { B() } CATCH { C() } DO { D() }\n}", "lower-case-keyword",
     "3:3", "write TRY, not try"),
    ("MISSION {\n  Wait(3 feet)\n}\n", "unknown-unit", "2:10", "unknown unit 'feet'"),
    ("MISSION {\n  A() $\n}\n", "bad-character", "2:7", "unexpected character '$'"),
    ("MISSION { /* never\n closed }\n", "unclosed-comment", "1:11", "never closed"),
    ("MISSION {\n  A(1e999)\n}\n", "number-out-of-range", "2:5", "1e999 is out of range"),
    ("MISSION { A(x = ) }", "syntax", "1:17", "unexpected ')'"),
    ("MISSION { IF { A() } THEN { B() } ELSE C() }", "syntax", "1:40", "unexpected name 'C'"),
    ("MISSION { PARALLEL { A() } }", "syntax", "1:28", "unexpected '}'"),
    ("MISSION {\r\n  A() B()\r\n}\r\n", "missing-semicolon", "2:6", "';' missing"),
    ("", "empty-file", "1:1", "the file is empty"),
    ("  \n\t\n", "empty-file", "1:1", "the file is empty"),
    ("   \n// only a comment\n", "missing-mission", "2:18", "no MISSION"),
])
def test_other_errors_at_their_place(text: str, code: str, where: str, words: str) -> None:
    d = _error(text)
    assert (d.code, _where(d)) == (code, f"m.mcl:{where}")
    assert words in d.message


@pytest.mark.parametrize("text,where", [
    ("MISSION { A(); B() C() }", "1:19"),
    ("MISSION { A(); B(); C() D() }", "1:24"),
])
def test_a_missing_semicolon_after_a_later_item_is_named_as_such(text: str, where: str) -> None:
    d = _error(text)
    assert (d.code, _where(d)) == ("missing-semicolon", f"m.mcl:{where}")


def test_an_error_quotes_its_source_line_with_a_caret_under_the_column() -> None:
    d = _error("MISSION {\n  A() B();\n  C()\n}\n")
    assert d.source_line == "  A() B();"
    lines = d.format().splitlines()
    assert lines[0] == "m.mcl:2:6: error: ';' missing between two items"
    assert lines[2].index("^") - 4 == 5  # column 6, under the four-space indent
    assert lines[-1] == "  hint: separate the items of a block with ';'"


def test_the_expected_tokens_are_named_in_the_hint() -> None:
    d = _error("MISSION { PARALLEL { A() } }")
    assert d.hint == "expected one of AND, OR"


def _brace_depth(text: str, index: int) -> int:
    return text[:index].count("{") - text[:index].count("}")


def test_nesting_up_to_the_limit_parses_and_one_more_is_refused_at_the_deepest_block() -> None:
    def nested(depth: int) -> str:  # the mission's block and depth - 1 IFs inside it
        return "MISSION " + "{ IF " * (depth - 1) + "{ A() }" + " THEN { B() } }" * (depth - 1)

    deepest = _parse(nested(MAX_DEPTH)).body
    for _ in range(MAX_DEPTH - 1):
        assert isinstance(deepest, ast.IfThenElse)
        deepest = deepest.condition
    assert deepest == ast.Call("A", ())
    text = nested(MAX_DEPTH + 1)
    d = _error(text)
    assert d.code == "too-deep" and f"more than {MAX_DEPTH} deep" in d.message
    assert d.span is not None and d.span.line == 1
    col = d.span.col - 1
    assert text[col] == "{" and _brace_depth(text, col) == MAX_DEPTH


# -- one value (command line, parameter files) -----------------------------------------------
def test_parse_value_gives_the_value_with_spans_where_it_was_written() -> None:
    v = parse_value("(1 m, 2)", "f.params", line=3, column=5)
    assert v == ast.Point((ast.Number(1, "m"), ast.Number(2)))
    assert isinstance(v, ast.Point)
    assert [str(s) for s in (v.span, v.items[0].span, v.items[1].span)] == [
        "f.params:3:5", "f.params:3:6", "f.params:3:11"]


@pytest.mark.parametrize("text,value", [
    ("90 deg", ast.Number(90, "deg")),
    ("-1.5", ast.Number(-1.5)),
    ("2e3 ms", ast.Number(2000, "ms")),
    ("home", ast.Ref("home")),
    ("[]", ast.ListValue(())),
    ("[a, [1, 2 km]]", ast.ListValue((ast.Ref("a"),
                                      ast.ListValue((ast.Number(1), ast.Number(2, "km")))))),
])
def test_parse_value_of_each_kind(text: str, value: ast.Value) -> None:
    assert parse_value(text) == value


@pytest.mark.parametrize("text,code,col", [
    ("1 feet", "bad-value", 3),
    ("(1)", "bad-value", 3),
    ("1e999", "number-out-of-range", 1),
    ("[" * (MAX_DEPTH + 1) + "]" * (MAX_DEPTH + 1), "too-deep", MAX_DEPTH + 1),
])
def test_parse_value_refuses_what_is_not_one_value(text: str, code: str, col: int) -> None:
    with pytest.raises(MclError) as info:
        parse_value(text)
    d = info.value.errors[0]
    assert (d.code, str(d.span)) == (code, f"<command line>:1:{col}")


def test_parse_value_places_an_error_where_the_value_was_written() -> None:
    with pytest.raises(MclError) as info:
        parse_value("1 feet", "f.params", line=3, column=5)
    assert str(info.value.errors[0].span) == "f.params:3:7"  # 'feet'


def test_parse_value_places_a_cut_short_value_after_its_end() -> None:
    with pytest.raises(MclError) as info:
        parse_value("(1,", "f.params", line=2, column=4)
    assert str(info.value.errors[0].span) == "f.params:2:7"


# -- files -----------------------------------------------------------------------------------
def test_parse_file_names_its_spans_after_the_path(tmp_path: Path) -> None:
    path = tmp_path / "m.mcl"
    path.write_text("PARAM d = 1 m;\nMISSION {\n  A(d)\n}\n", encoding="utf-8")
    m = parse_file(str(path))
    assert m.params == (ast.Param("d", ast.Number(1, "m")),)
    assert str(m.body.span) == f"{path}:3:3"


def test_parse_file_of_a_missing_file_is_an_error_naming_it(tmp_path: Path) -> None:
    path = str(tmp_path / "absent.mcl")
    with pytest.raises(MclError) as info:
        parse_file(path)
    d = info.value.errors[0]
    assert d.code == "missing-file" and d.span is not None and d.span.file == path


# -- suggestions -----------------------------------------------------------------------------
@pytest.mark.parametrize("name,hint", [
    ("Surfce", "did you mean Surface?"),
    ("goto", "did you mean GoTo?"),  # case only
    ("Xyzzy", ""),
])
def test_suggest_names_the_closest_candidate(name: str, hint: str) -> None:
    assert suggest(name, ["Surface", "GoTo", "Wait"]) == hint
