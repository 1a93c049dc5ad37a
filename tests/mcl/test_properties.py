"""Property-based tests (Hypothesis) of the MCL front end and compiler.

* random valid missions (ASTs over the shipped task library, see tests/strategies.py) print
  and parse back to themselves, and the printer is a fixed point;
* they all compile, to a coherent net;
* random missions over the generic tasks (tests.support.GENERIC_TASKS) are sound by
  construction: the verifier proves the structural properties;
* random mutations of valid texts (generated ones and missions/*.mcl) never give anything but
  a result or an MclError with a located diagnostic, through the API and the real ``mclc``.

Bugs these properties found have tests of their own at the end of the file: regressions for
the fixes.
"""

from __future__ import annotations

import os
import re
from pathlib import Path

import pytest
from hypothesis import HealthCheck, event, example, given, settings
from hypothesis import strategies as st

from mcl import ast, printer, tasklib
from mcl.api import compile_source
from diagnostics import Diagnostic, MclError, Source, Span
from mcl.parser import parse
from petri.net import Net
from petri.verification.properties import verify
from tests import strategies as S
from tests.support import GENERIC_TASKS, MISSIONS, cli, single_missions, write

# A profile for this file only (registered, never loaded: other test files keep theirs).
# No derandomize: failures go to Hypothesis' example database and are replayed first.
settings.register_profile(
    "mcl-properties", deadline=None, print_blob=True,
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.filter_too_much,
                           HealthCheck.data_too_large])
PROFILE = settings.get_profile("mcl-properties")
# MCL_PROPERTY_SCALE=20 multiplies every example count (a longer bug hunt)
SCALE = float(os.environ.get("MCL_PROPERTY_SCALE", "1"))


def examples(n: int) -> int:
    return max(1, round(n * SCALE))


GENERIC = tasklib.load_sources([Source("generic.tasks", GENERIC_TASKS)])
MISSION_FILES = single_missions()
STRUCTURAL = ("one-safe", "no-deadlock", "proper-completion", "stop-safe")
# a WHILE whose condition cannot fail (e.g. WHILE { Now() } DO { A() }) never ends: then
# terminates (and no-zeno, for a loop of instant tasks) must fail with a lasso round a WHILE
LOOPS = ("terminates", "no-zeno")

ICTINEU = S.ictineu_missions(max_depth=3, max_calls=10)
ANY_MISSION = st.one_of(ICTINEU, S.generic_missions(lamps="free"),
                        S.generic_missions(lamps="paired"))


def text_of(m: ast.Mission) -> str:
    return printer.mission(m)


# -- round trip ------------------------------------------------------------------------
@settings(PROFILE, max_examples=examples(200))
@given(ANY_MISSION)
def test_print_then_parse_gives_the_same_mission(mission: ast.Mission) -> None:
    text = text_of(mission)
    parsed = parse(Source("rt.mcl", text))
    assert parsed == mission, text
    assert text_of(parsed) == text
    # spans of the parsed tree point into the text
    for call in ast.calls(parsed.body):
        assert call.span.line >= 1 and call.span.col >= 1
        line = text.splitlines()[call.span.line - 1]
        assert line[call.span.col - 1:].startswith(call.name + "("), (call, line)


# -- every valid mission compiles to a coherent net -------------------------------------
def assert_coherent(net: Net, mission: ast.Mission) -> None:
    n = len(net.places)
    names = [p.name for p in net.places]
    assert len(set(names)) == n, "place names are unique"
    for t in net.transitions:
        assert t.inputs, f"{t.name} has no input place: it could fire forever"
        for p, w in t.inputs + t.outputs:
            assert 0 <= p < n and w >= 1, (t.name, p, w)
    assert all(0 <= p < n and k >= 1 for p, k in net.initial.items()), net.initial
    begin = net.place("MISSION.begin")
    assert net.initial.get(begin) == 1
    assert sum(k for p, k in net.initial.items() if not names[p].endswith(".off")) == 1, \
        "the only tokens besides MISSION.begin are latches' 'off' states"
    ends = {net.place("MISSION.ok"), net.place("MISSION.fail")}
    assert len(net.finals) == 2
    for final in net.finals:
        assert all(0 <= p < n for p in final)
        assert len(ends & set(final)) == 1, final
    # every call of the mission is compiled: a task transition starts at its position
    starts = {(t.origin.line, t.origin.col) for t in net.transitions
              if t.origin is not None and t.origin.kind == "task"}
    for call in ast.calls(mission.body):
        assert (call.span.line, call.span.col) in starts, call


@pytest.mark.slow
@settings(PROFILE, max_examples=examples(100))
@given(ICTINEU)
def test_every_valid_mission_compiles_to_a_coherent_net(mission: ast.Mission) -> None:
    text = text_of(mission)
    compiled = compile_source(Source("gen.mcl", text))
    assert compiled.mission == mission
    assert_coherent(compiled.net, compiled.mission)
    # parameters: each one is used (we only declare used ones) with the kind of its use,
    # and only those without a value are reported (as warnings)
    used = S.used_params(mission.body)
    assert {n: compiled.checked.param_kinds[n] for n in used} == \
        {n: S.KIND_OF_PARAM[n] for n in used}
    assert set(compiled.checked.param_kinds) == set(used)
    unset = {p.name for p in mission.params if p.value is None}
    assert compiled.checked.unset == sorted(unset)
    codes = sorted(d.code for d in compiled.warnings)
    assert all(d.severity == "warning" for d in compiled.warnings)
    assert codes == ["unset-param"] * len(unset), [d.format() for d in compiled.warnings]
    # compiling is deterministic
    again = compile_source(Source("gen.mcl", text)).net
    assert [p.name for p in again.places] == [p.name for p in compiled.net.places]
    assert [(t.name, t.inputs, t.outputs, t.actions, t.event, t.timer)
            for t in again.transitions] == \
        [(t.name, t.inputs, t.outputs, t.actions, t.event, t.timer)
         for t in compiled.net.transitions]


def test_the_shipped_missions_compile_to_coherent_nets() -> None:
    for path in MISSION_FILES:
        compiled = compile_source(Source(str(path), path.read_text("utf-8")))
        assert_coherent(compiled.net, compiled.mission)


# -- soundness by construction on the generic tasks ------------------------------------
SMALL_GENERIC = st.sampled_from(["paired", "free"]).flatmap(
    lambda lamps: S.generic_missions(max_depth=3, max_calls=6, lamps=lamps)
    .filter(lambda m: S.concurrency(m.body) <= 4)
    .map(lambda m: (lamps, m)))


# Four tasks at once, nested: 289,552 markings (Hypothesis found it when the bound below was
# 200,000 and the test failed as "too big"); such missions of six calls reach 905,650.
NESTED_FOUR = """MISSION {
    PARALLEL {
        PARALLEL { A(); A() } AND { A() } AND { A() }
    } AND { A() } AND { Lamp(disable) }
}
"""


@pytest.mark.slow
@settings(PROFILE, max_examples=examples(100))
@given(SMALL_GENERIC)
@example(("free", parse(Source("nested.mcl", NESTED_FOUR))))
def test_generic_missions_are_sound(case: tuple[str, ast.Mission]) -> None:
    lamps, mission = case
    text = text_of(mission)
    compiled = compile_source(Source("generic.mcl", text), library=GENERIC)
    assert_coherent(compiled.net, compiled.mission)
    verdict = verify(compiled.net, max_markings=2_000_000)
    results = {r.name: r for r in verdict.results}
    assert "complete" not in results, f"{verdict.markings} markings: too big\n{text}"
    wanted = STRUCTURAL + (("behaviours-off-at-end",) if lamps == "paired" else ())
    failed = {name: (results[name].message, verdict.to_json()["properties"])
              for name in wanted if not results[name].holds}
    assert not failed, f"{text}\n{failed}"
    for name in LOOPS:
        r = results[name]
        if not r.holds:
            assert r.cycle, f"{name} fails without a lasso\n{text}"
            kinds = {compiled.net.transitions[t].origin.kind for t in r.cycle
                     if compiled.net.transitions[t].origin is not None}
            assert "WHILE" in kinds, f"{name}: the lasso does not go round a WHILE\n{text}"
    if lamps == "paired" and all(results[n].holds for n in LOOPS):
        assert verdict.ok, [(r.name, r.message) for r in verdict.results if not r.holds]


def test_a_lone_lamp_is_left_on_so_the_paired_assertion_can_fail() -> None:
    """The property above asserts behaviours-off-at-end only for paired lamps: a lone
    Lamp(enable) must indeed be reported (the check is not vacuous)."""
    compiled = compile_source(Source("g.mcl", "MISSION { A(); Lamp(enable) }"), library=GENERIC)
    results = {r.name: r for r in verify(compiled.net).results}
    assert not results["behaviours-off-at-end"].holds
    assert all(results[n].holds for n in STRUCTURAL)


# -- mutations never give a traceback ---------------------------------------------------
SOURCES = st.one_of(
    st.sampled_from([(str(p), p.read_text("utf-8")) for p in MISSION_FILES]),
    S.ictineu_missions(max_depth=2, max_calls=6).map(lambda m: ("gen.mcl", text_of(m))),
)
# Characters that str.splitlines() takes for line breaks but the parser (lark) does not.
ODD_LINE_BREAK = re.compile("\r(?!\n)|[\x0b\x0c\x1c\x1d\x1e\x85\u2028\u2029]")
END_OF_FILE_CODES = ("unclosed-block", "unexpected-eof", "missing-mission")


def assert_located_error(exc: MclError, name: str, text: str | None = None) -> None:
    """Every error has a span at line >= 1, col >= 1; the message starts NAME:LINE:COL: error:;
    given the text, the quoted line is the reported line and the column falls on it."""
    errors = exc.errors
    assert errors, f"an MclError without an error diagnostic: {exc.format()}"
    for d in errors:
        assert d.span is not None, d.format()
        assert d.span.line >= 1 and d.span.col >= 1, d.format()
        if text is None or d.span.file != name:
            continue
        lines = text.split("\n")
        assert d.span.line <= len(lines), d.format()
        assert d.source_line == lines[d.span.line - 1].removesuffix("\r"), d.format()
        assert d.span.col <= len(d.source_line) + 1, d.format()
    first = exc.diagnostics[0]
    assert first.severity == "error"
    assert first.span is not None
    assert exc.format().startswith(
        f"{name}:{first.span.line}:{first.span.col}: error: "), exc.format()


def compiles_or_located_error(name: str, text: str) -> None:
    """The property of every input: a compiled mission, or an MclError located in it. Any
    other exception (OverflowError, RecursionError, ...) is a bug and fails the test."""
    try:
        compiled = compile_source(Source(name, text))
    except MclError as exc:
        event(f"outcome: error {exc.errors[0].code if exc.errors else '?'}")
        assert_located_error(exc, name, text)
    else:
        event("outcome: compiles")
        assert_coherent(compiled.net, compiled.mission)


@pytest.mark.slow
@settings(PROFILE, max_examples=examples(300))
@given(st.data())
def test_mutated_programs_compile_or_give_a_located_error(data: st.DataObject) -> None:
    name, original = data.draw(SOURCES, label="source")
    text, _ = data.draw(S.mutated(st.just(original)), label="mutated")
    event(f"source: {Path(name).name}")
    compiles_or_located_error(name, text)


@pytest.mark.slow
@settings(PROFILE, max_examples=examples(200))
@given(S.any_missions())
def test_well_formed_but_meaningless_missions_compile_or_give_a_located_error(
        mission: ast.Mission) -> None:
    """Syntax right, meaning arbitrary (unknown tasks, wrong arguments, parameters undeclared,
    twice, of the wrong kind, defined by one another): every problem is a located MclError."""
    text = text_of(mission)
    assert parse(Source("any.mcl", text)) == mission
    compiles_or_located_error("any.mcl", text)


@settings(PROFILE, max_examples=examples(5))
@given(data=st.data())
def test_mutated_programs_through_mclc(data: st.DataObject,
                                       tmp_path_factory: pytest.TempPathFactory) -> None:
    name, original = data.draw(SOURCES, label="source")
    text, _ = data.draw(S.mutated(st.just(original)), label="mutated")
    # beside the mission files, so that USES "seabed.tasks" resolves as it would for them
    directory = tmp_path_factory.mktemp("mutated")
    if name != "gen.mcl":
        (directory / "seabed.tasks").write_text((MISSIONS / "seabed.tasks").read_text("utf-8"),
                                                encoding="utf-8")
    path = write(directory, text, Path(name).name)
    proc = cli("mclc", str(path), "--no-verify")
    assert proc.returncode in (0, 2), (proc.returncode, proc.stderr, text)
    assert "Traceback" not in proc.stderr and "internal error" not in proc.stderr, proc.stderr
    if proc.returncode == 2:
        assert re.match(rf"{re.escape(str(path))}:\d+:\d+: error: ", proc.stderr), proc.stderr


def test_the_mutations_do_mutate() -> None:
    """Each mutation operator changes a text it applies to (else the tests above prove
    little)."""
    text = "MISSION { TRY { Surface() } CATCH { Alarms() } DO { Wait(5 s); Timeout(2) } }\n"

    @settings(PROFILE, max_examples=examples(20))
    @given(st.data())
    def run(data: st.DataObject) -> None:
        for op_name, op in S.MUTATIONS.items():
            out = op(data.draw, text)
            if op_name == "truncate":
                assert text.startswith(out)
            elif op_name == "swap-tokens":
                assert sorted(out) == sorted(text)
            else:
                assert out != text, op_name

    run()


# -- regressions: bugs these properties found, fixed in d519a43 ----------------------------
def first_error(text: str, name: str = "bug.mcl") -> tuple[Diagnostic, Span]:
    with pytest.raises(MclError) as info:
        compile_source(Source(name, text))
    assert_located_error(info.value, name, text)
    d = info.value.errors[0]
    assert d.span is not None
    return d, d.span


@pytest.mark.parametrize("text,col", [
    ("MISSION { Wait(1e999 s) }", 16),
    ("MISSION { Wait(-1e999) }", 16),
    ("MISSION { GoTo((1, 2), timeout = 1e999 s) }", 34),
])
def test_number_literal_too_big_for_a_float(text: str, col: int) -> None:
    """Was: OverflowError in values.to_text (int(inf)), mclc exit 3."""
    d, span = first_error(text)
    assert (d.code, span.line, span.col) == ("number-out-of-range", 1, col), d.format()


def test_number_literal_too_big_for_a_float_through_mclc(tmp_path: Path) -> None:
    path = write(tmp_path, "MISSION { Wait(1e999 s) }\n")
    proc = cli("mclc", str(path), "--no-verify")
    assert proc.returncode == 2, proc.stderr
    assert proc.stderr.startswith(f"{path}:1:16: error: "), proc.stderr


@pytest.mark.parametrize("text", [
    "PARAM a = a;\nMISSION { Wait(a) }",
    "PARAM a = b;\nPARAM b = a;\nMISSION { Wait(a) }",
    "PARAM a = [b];\nPARAM b = (1, a);\nMISSION { WallInspect(a) }",
])
def test_self_referential_parameter(text: str) -> None:
    """Was: RecursionError in values.evaluate, mclc exit 3."""
    d, span = first_error(text)
    assert (d.code, span.line, span.col) == ("param-cycle", 1, 7), d.format()


@pytest.mark.parametrize("text,col", [
    ("MISSION { Wait(1 s, duration = 2 s) }", 21),
    ("MISSION { GoTo(target = (1, 2), target = (3, 4)) }", 33),
])
def test_an_argument_given_twice_is_an_error(text: str, col: int) -> None:
    """Was: accepted, the last value silently winning."""
    d, span = first_error(text)
    assert (d.code, span.line, span.col) == ("duplicate-argument", 1, col), d.format()


@pytest.mark.parametrize("text,line", [
    ("mission {\n  Surface()\n}\n", 1),
    ("PARAM h = 1 deg;\nmission {\n  AchieveHeadDist(h, 1 m)\n}\n", 2),
    ("param h = 1 deg;\nMISSION {\n  AchieveHeadDist(h, 1 m)\n}\n", 1),
])
def test_lower_case_keyword_at_the_top_level(text: str, line: int) -> None:
    """Was: 'the file has no MISSION' (missing-mission) at the end of the file."""
    d, span = first_error(text)
    assert (d.code, span.line, span.col) == ("lower-case-keyword", line, 1), d.format()


@pytest.mark.parametrize("text", [
    "MISSION {\r  Surface() Alarms()\r}\r",
    "MISSION {\f  Surface() Alarms()\n}\n",
    "// a comment\u2028with a line separator\nMISSION {\n  Surface() Alarms()\n}\n",
], ids=["lone-CR", "form-feed", "U+2028-in-comment"])
def test_lone_carriage_return_keeps_the_caret_on_the_quoted_line(text: str) -> None:
    """Was: lines numbered by '\\n' (lark) but quoted by str.splitlines(): wrong line quoted,
    caret past its end."""
    d, span = first_error(text)
    assert d.code == "missing-semicolon", d.format()
    assert d.source_line[:span.col - 1].endswith("Surface()"), d.format()


@pytest.mark.parametrize("text", [
    "MISSION {\r  Surface()\r",
    "MISSION { Surface() // a comment\u2028",
    "PARAM a = 1 s;\rPARAM b = 2 s;\r",
], ids=["unclosed-block-CR", "unclosed-block-U+2028", "missing-mission-CR"])
def test_end_of_file_errors_count_lines_like_the_parser(text: str) -> None:
    """Was: end-of-file errors located by str.splitlines() while the parser counts '\\n'."""
    with pytest.raises(MclError) as info:
        compile_source(Source("eof.mcl", text))
    d = info.value.errors[0]
    assert d.code in END_OF_FILE_CODES and d.span is not None
    assert d.span.line == 1 and d.source_line, d.format()
    assert d.span.col == len(d.source_line.rstrip()) + 1, d.format()


def nested(kind: str, depth: int) -> str:
    if kind == "list":
        return "MISSION { WallInspect(" + "[" * depth + "]" * depth + ") }"
    return "MISSION { Wait(" + "(1, " * depth + "1" + ")" * depth + ") }"


@settings(PROFILE, max_examples=examples(10))
@given(kind=st.sampled_from(["list", "point"]), depth=st.integers(1, 1200))
@example(kind="list", depth=1000)
@example(kind="point", depth=1000)
def test_deeply_nested_values_give_a_result_or_an_error(kind: str, depth: int) -> None:
    compiles_or_located_error("deep.mcl", nested(kind, depth))


def test_deeply_nested_values_through_mclc(tmp_path: Path) -> None:
    path = write(tmp_path, nested("list", 1000) + "\n")
    proc = cli("mclc", str(path), "--no-verify")
    assert proc.returncode == 2, proc.stderr
    assert "internal error" not in proc.stderr


@pytest.mark.slow
def test_a_long_chain_of_parameters() -> None:
    n = 1500
    params = "".join(f"PARAM p{i} = p{i + 1};\n" for i in range(n)) + f"PARAM p{n} = 1 s;\n"
    net = compile_source(Source("chain.mcl", params + "MISSION { Wait(p0) }")).net
    assert {t.timer for t in net.transitions if t.timer is not None} == {1.0}
