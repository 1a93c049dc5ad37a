"""mcl/analysis/termination.py: every run ends, decided from the proved worst case.

The quoted case of issue 21 (``WHILE { Wait(1 s) } DO { GoTo(start, timeout = 2 min) }``,
verified today, runs for ever on a vehicle that always reaches) fails here, with the WHILE
and the answer that keeps it going; bounded by a race it is proved. On random missions the
verdict holds exactly when duration's worst case is finite, with the explicit graph or
without, and a loop's lasso replays on the net. The graph rule for plain nets
(petri/verification/termination.py ``terminates``) fails exactly on a reachable cycle.
"""

from __future__ import annotations

import math
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from diagnostics import Source
from mcl import ast, printer
from mcl.analysis import structural, termination
from mcl.analysis.duration import analyse
from mcl.analysis.verification import verify_mission
from mcl.api import Compiled, compile_source
from mcl.tasklib import load
from petri.semantics import Semantics
from petri.verification.properties import Result, verify
from petri.verification.termination import terminates as every_run_ends
from tests.strategies import bodies
from tests.support import cli, write

GENERIC = load(["generic"])
QUOTED = "MISSION m {\n  WHILE { Wait(1 s) } DO { GoTo(start, timeout = 2 min) }\n}\n"


def _compile(text: str, generic: bool = False) -> Compiled:
    return compile_source(Source("m.mcl", text), library=GENERIC if generic else None)


def _explicit(compiled: Compiled) -> Result:
    """``terminates`` as the explicit route decides it (what ``mclc --method explicit`` says)."""
    verdict = verify_mission(compiled, "explicit", max_markings=200_000)
    return next(r for r in verdict.results if r.name == "terminates")


def _structural(compiled: Compiled) -> Result:
    """``terminates`` as the structural route decides it."""
    verdict = structural.analyse(compiled.checked)
    return next(r for r in verdict.results if r.name == "terminates")


def _replays(compiled: Compiled, r: Result) -> list[str]:
    """Fire the counterexample, then the loop: the loop comes back to where it started."""
    net, rules = compiled.net, Semantics(compiled.net)
    assert r.counterexample is not None
    marking = rules.initial()
    for t in r.counterexample:
        assert rules.enabled(marking, t), net.transitions[t].name
        rules.fire(marking, t)
    if r.cycle is None:
        return []
    start = list(marking)
    for t in r.cycle:
        assert rules.enabled(marking, t), net.transitions[t].name
        rules.fire(marking, t)
    assert marking == start
    return [net.transitions[t].name for t in r.cycle]


def test_the_quoted_loop_does_not_terminate_and_says_what_keeps_it_going() -> None:
    compiled = _compile(QUOTED)
    r = termination.result(compiled.checked)
    assert r.status == "fails"
    assert "the WHILE at line 2" in r.message
    assert "goes round for as long as GoTo(start, timeout = 2 min) ends ok on GoTo.reached" \
        in r.message
    explicit = _explicit(compiled)
    assert explicit.status == "fails" and explicit.message == r.message
    loop = _replays(compiled, explicit)
    assert "WHILE@2:3.body_ok" in loop and "GoTo@2:28.ok.GoTo.reached" in loop


def test_a_timeout_racing_the_loop_makes_every_run_end() -> None:
    text = ("MISSION m {\n  PARALLEL { WHILE { Wait(1 s) } DO { GoTo(start, timeout = 2 min) "
            "} } OR { Timeout(10 min) }\n}\n")
    compiled = _compile(text)
    r = termination.result(compiled.checked)
    assert r.status == "holds" and "600 s = 10 min" in r.message
    assert _explicit(compiled).status == "holds"


def test_a_task_that_waits_with_no_timeout_is_named_with_its_events() -> None:
    compiled = _compile("MISSION m {\n  Wait(1 s);\n  A()\n}\n", generic=True)
    r = _explicit(compiled)
    assert r.status == "fails"
    assert "line 3: A() waits for Probe.ok or Probe.fail with no timeout" in r.message
    _replays(compiled, r)
    assert r.counterexample is not None
    assert compiled.net.transitions[r.counterexample[-1]].name == "A@3:3.start"


def test_a_loop_left_only_by_failing_names_the_answer_it_goes_round_on() -> None:
    r = termination.result(_compile("MISSION m {\n  WHILE { A(timeout = 5 s) } DO { Wait(2 s) }\n}\n",
                                    generic=True).checked)
    assert r.status == "fails" and "as long as A(timeout = 5 s) ends ok on Probe.ok" in r.message


def test_a_loop_of_timers_alone_goes_round_whatever_the_vehicle_answers() -> None:
    r = termination.result(_compile("MISSION m {\n  WHILE { Wait(1 s) } DO { Wait(2 s) }\n}\n",
                                    generic=True).checked)
    assert r.status == "fails" and "whatever the vehicle answers" in r.message


# -- random missions ----------------------------------------------------------------------
TIMED = ["A()", "B()", "Now()", "Wait(1 s)", "Wait(3 s)", "Timeout(2 s)", "Timeout(5 s)"]
LEAVES = [_compile(f"MISSION {{ {c} }}", generic=True).checked.mission.body for c in TIMED]


def _leaf() -> st.SearchStrategy[ast.Call]:
    return st.sampled_from([c for c in LEAVES if isinstance(c, ast.Call)])


@pytest.mark.slow
@settings(max_examples=60, deadline=None, derandomize=True,
          suppress_health_check=[HealthCheck.too_slow])
@given(bodies(_leaf(), 3, 6))
def test_terminates_holds_exactly_when_the_worst_case_is_finite(body: ast.Block) -> None:
    text = printer.mission(ast.Mission(None, body))
    compiled = _compile(text, generic=True)
    finite = math.isfinite(analyse(compiled.checked).worst)
    alone = termination.result(compiled.checked)
    explicit = _explicit(compiled)
    tree = _structural(compiled)
    assert alone.holds == explicit.holds == tree.holds == finite, text
    assert not alone.undecided and not explicit.undecided and not tree.undecided
    assert tree.message == explicit.message, text  # one decision, one explanation
    if not finite:
        assert explicit.counterexample is not None or "WHILE" in explicit.message, text
        if explicit.counterexample is not None:
            _replays(compiled, explicit)


@settings(max_examples=40, deadline=None, derandomize=True,
          suppress_health_check=[HealthCheck.too_slow])
@given(bodies(_leaf(), 3, 5))
def test_the_graph_rule_fails_exactly_on_a_reachable_cycle(body: ast.Block) -> None:
    compiled = _compile(printer.mission(ast.Mission(None, body)), generic=True)
    verdict = verify(compiled.net, termination=every_run_ends)
    r = next(x for x in verdict.results if x.name == "terminates")
    loops = any(isinstance(b, ast.WhileDo) for b in ast.walk(body))
    if not loops:  # no WHILE: the net has no cycle
        assert r.holds
    if not r.holds:
        assert r.cycle and "graph rule" in r.method
        _replays(compiled, r)


# -- through a real mclc ------------------------------------------------------------------
QUOTED_FILE = ("PARAM start = (0, 0, 1, 0 deg);\n"
               "MISSION m { WHILE { Wait(1 s) } DO { GoTo(start, timeout = 2 min) } }\n")


@pytest.mark.slow
@pytest.mark.parametrize("method", ["auto", "explicit", "structural"])
def test_mclc_fails_the_quoted_loop_on_terminates_with_its_while(tmp_path: Path,
                                                                  method: str) -> None:
    proc = cli("mclc", str(write(tmp_path, QUOTED_FILE)), "--method", method)
    assert proc.returncode == 1, proc.stdout + proc.stderr
    assert ("[FAIL] terminates: some run never ends: the WHILE at line 2 (`Wait(1 s)`) goes "
            "round for as long as GoTo(start, timeout = 2 min) ends ok on GoTo.reached"
            ) in proc.stdout
    assert "[ok  ] can-end:" in proc.stdout  # the weaker property holds: it can always end
    if method != "structural":  # the lasso: to the loop, then round through the WHILE
        loop = proc.stdout.split("then round and round for ever:")[1]
        assert "WHILE { Wait(1 s) }: DO ended ok → again" in loop
        assert "GoTo(start, timeout = 2 min): GoTo.reached → ok on GoTo.reached" in loop


def test_mclc_verifies_the_quoted_loop_raced_by_a_timeout(tmp_path: Path) -> None:
    raced = QUOTED_FILE.replace("MISSION m { WHILE { Wait(1 s) } DO { GoTo(start, timeout = 2 "
                                "min) } }", "MISSION m { PARALLEL { WHILE { Wait(1 s) } DO { "
                                "GoTo(start, timeout = 2 min) } } OR { Timeout(10 min) } }")
    assert raced != QUOTED_FILE
    proc = cli("mclc", str(write(tmp_path, raced)))
    assert proc.returncode == 0, proc.stdout + proc.stderr
    assert "[ok  ] terminates: every run ends, whatever the vehicle answers" in proc.stdout


# -- stop-ends: the stop handler ends within a proved bound (ON STOP, issue 21) ---------------
@pytest.mark.parametrize("method", ["explicit", "structural", "auto"])
def test_a_stop_handler_that_can_loop_for_ever_is_refused_on_every_route(method: str) -> None:
    text = ("MISSION m {\n  GoTo((0, 0, 5, 0), timeout = 2 min)\n} ON STOP {\n"
            "  WHILE { Wait(1 s) } DO { Surface() }\n}\n")
    verdict = verify_mission(_compile(text), method)
    ends = {r.name: r for r in verdict.results}[termination.STOP_NAME]
    assert ends.status == "fails" and not verdict.ok
    assert "the WHILE at line 4" in ends.message and "Surface.surfaced" in ends.message
    assert {r.name: r for r in verdict.results}["terminates"].holds  # the body itself ends


@pytest.mark.parametrize("method", ["explicit", "structural"])
def test_a_bounded_stop_handler_is_proved_with_its_bound(method: str) -> None:
    text = ("MISSION m {\n  Wait(1 min)\n} ON STOP {\n"
            "  PARALLEL { WHILE { Wait(1 s) } DO { Surface() } } OR { Timeout(90 s) }\n}\n")
    verdict = verify_mission(_compile(text), method)
    ends = {r.name: r for r in verdict.results}[termination.STOP_NAME]
    assert ends.holds and "within 90 s" in ends.message, ends
    assert verdict.ok, [r for r in verdict.results if not r.holds]


def test_a_clash_inside_the_stop_handler_fails_on_both_routes() -> None:
    text = ("MISSION m {\n  Wait(1 min)\n} ON STOP {\n"
            "  PARALLEL { Surface() } AND { GoTo((0, 0, 0, 0), timeout = 1 min) }\n}\n")
    for method in ("explicit", "structural"):
        clash = {r.name: r for r in verify_mission(_compile(text), method).results}[
            "dof-exclusive"]
        assert clash.status == "fails", (method, clash)


def test_a_mission_without_a_handler_has_no_stop_ends() -> None:
    verdict = verify_mission(_compile("MISSION m { Wait(1 s) }"))
    assert termination.STOP_NAME not in {r.name for r in verdict.results}


@settings(max_examples=40, deadline=None, derandomize=True,
          suppress_health_check=[HealthCheck.too_slow])
@given(bodies(_leaf(), 2, 4), bodies(_leaf(), 3, 5))
def test_stop_ends_holds_exactly_when_the_handlers_worst_case_is_finite(
        body: ast.Block, handler: ast.Block) -> None:
    compiled = _compile(printer.mission(ast.Mission("m", body, on_stop=handler)), generic=True)
    on_stop = compiled.checked.mission.on_stop
    assert on_stop is not None
    finite = math.isfinite(analyse(compiled.checked, ast.Mission("m", on_stop)).worst)
    ends = termination.stop_result(compiled.checked)
    assert ends is not None and not ends.undecided and ends.holds == finite, ends
    structural_ends = {r.name: r for r in structural.analyse(compiled.checked).results}
    explicit = {r.name: r for r in verify_mission(compiled, "explicit").results}
    assert explicit[termination.STOP_NAME].holds == finite
    # a second stop halts any handler: the stop is safe on both routes
    assert explicit["stop-safe"].holds and structural_ends["stop-safe"].holds
