"""The task timer rule (mcl/timers.py) and its three readers.

The rule: a per-call ``timeout =`` (which ends the call fail) replaces a declared fail
timeout; a declared ok timeout stays beside it. Each test states the expected timers of a call
from the call as written and its task's declaration (:func:`expected`, independent of
mcl/timers.py), then checks that

* :func:`mcl.timers.timers` says so;
* the compiled net (mcl/templates/task.py) has one timed transition per timer, in that order,
  to the ``ok`` or ``fail`` place the timer's status names;
* the duration bounds (mcl/analysis/duration.py) end the call no later than its first known
  timer, with the endings the timers and events allow;
* the structural route's outcome analysis (mcl/analysis/outcomes.py) lets the call end, at
  all, in zero time, and perhaps in zero time, exactly as the timers and events allow;

on hand-written calls, on the shipped missions and on random missions.
"""

from __future__ import annotations

import math

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from diagnostics import Source
from mcl import ast, printer, tasklib
from mcl.analysis.duration import analyse
from mcl.analysis.outcomes import Outcomes
from mcl.api import Compiled, compile_file, compile_source
from mcl.checker import Checked
from mcl.declarations import Field
from mcl.timers import Timer, timers
from mcl.values import Unresolved, evaluate
from petri.net import FAIL, OK
from tests import strategies as S
from tests.support import single_missions

INF = math.inf
# Tasks with every kind of timer: a declared fail timeout, a declared ok timeout, a timeout
# from a parameter of the task, none at all (a watcher); each may get ``timeout =`` per call.
TIMER_TASKS = """
behaviour Mover drives x events arrived, lost;
behaviour Eye events seen;
task Go() { start: enable Mover; ok: Mover.arrived; fail: Mover.lost; timeout: 10 s -> fail;
            stop: disable Mover; }
task Hold() { start: enable Mover; fail: Mover.lost; timeout: 5 s -> ok; stop: disable Mover; }
task Look(duration: duration = 3 s) { start: enable Eye; ok: Eye.seen;
                                      timeout: duration -> fail; stop: disable Eye; }
task Watch() { start: enable Eye; fail: Eye.seen; stop: disable Eye; }
task Pause(duration: duration) { timeout: duration -> ok; }
task Now() { }
"""
LIBRARY = tasklib.load_sources([tasklib.shipped_source("core.tasks"),
                                Source("timers.tasks", TIMER_TASKS)])
PARAMS = ("s", "maxTime")  # duration parameters: with a value (PARAM s = 2 s) or without
PROFILE = settings(deadline=None, max_examples=60,
                   suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])


def compile_text(text: str) -> Compiled:
    return compile_source(Source("m.mcl", text), library=LIBRARY)


def seconds_of(value: ast.Value, checked: Checked) -> float | str:
    try:
        seconds = evaluate(value, "duration", checked.params)
    except Unresolved as missing:
        return missing.name
    assert isinstance(seconds, float | int)
    return float(seconds)


def expected(checked: Checked, call: ast.Call) -> list[tuple[float | str, str]]:
    """The call's timers, (seconds or parameter, status), by the rule as the docs state it."""
    resolved = checked.resolved(call)
    form = resolved.form
    formals = {f.name for f in form.formals}
    given_ = [a.value for a in call.args if a.name == "timeout" and "timeout" not in formals]
    out = [(seconds_of(v, checked), FAIL) for v in given_]
    if form.timeout is not None:
        expr, status = form.timeout
        if not given_ or status == OK:
            assert not isinstance(expr, Field)  # the library refuses a point's field
            value = resolved.args[expr.name] if isinstance(expr, ast.Ref) else expr
            out.append((seconds_of(value, checked), status))
    return out


def agree(compiled: Compiled) -> int:
    """Check every call of a compiled mission; how many timers were seen."""
    checked, net = compiled.checked, compiled.net
    bounds = {(b.line, b.col): b for b in analyse(checked).blocks if b.construct == "Call"}
    outcomes = Outcomes(checked)
    seen = 0
    for call in ast.calls(checked.mission.body):
        form = checked.resolved(call).form
        want = expected(checked, call)
        where = f"{printer.call(call)} at {call.span.line}:{call.span.col}"
        said = timers(checked, call)
        assert [(t.seconds, t.status) for t in said] == want, where
        assert all(isinstance(t.seconds, str) == (t.known is None) for t in said)
        seen += len(want)
        # the template: one timed transition per timer, in order, to ok or fail
        made = [(t.timer, net.places[t.outputs[0][0]].role) for t in net.transitions
                if t.timer is not None and t.origin is not None and t.origin.kind == "task"
                and (t.origin.line, t.origin.col) == (call.span.line, call.span.col)]
        assert made == want, where
        if form.immediate:
            assert want == []
            continue
        events = ({OK} if form.ok else set()) | ({FAIL} if form.fail else set())
        known = [s for s, _ in want if not isinstance(s, str)]
        first = min(known, default=INF)
        # the duration bounds: no later than the first known timer; its endings
        bound = bounds[(call.span.line, call.span.col)]
        assert bound.worst == first, where
        endings = ({st for s, st in want if s == first or isinstance(s, str)}
                   | (events if first > 0 else set()))
        assert set(bound.ends) == endings, where
        # the outcome analysis: endings at all, in zero time, perhaps in zero time
        assert outcomes.call(call, "") == events | {st for _, st in want}, where
        assert outcomes.call(call, "must") == {st for s, st in want if s == 0}, where
        assert outcomes.call(call, "may") == {st for s, st in want
                                              if s == 0 or isinstance(s, str)}, where
    return seen


# -- the rule on hand-written calls ------------------------------------------------------------
@pytest.mark.parametrize(("call", "want"), [
    ("Go()", [Timer(10.0, FAIL, True)]),
    ("Go(timeout = 2 s)", [Timer(2.0, FAIL, False)]),  # replaces the declared fail timeout
    ("Hold()", [Timer(5.0, OK, True)]),
    ("Hold(timeout = 1 min)", [Timer(60.0, FAIL, False), Timer(5.0, OK, True)]),  # ok stays
    ("Look()", [Timer(3.0, FAIL, True)]),  # the default of the task's parameter
    ("Look(7 s)", [Timer(7.0, FAIL, True)]),
    ("Look(7 s, timeout = 1 s)", [Timer(1.0, FAIL, False)]),
    ("Watch()", []),
    ("Watch(timeout = 4 s)", [Timer(4.0, FAIL, False)]),
    ("Pause(8 s, timeout = 3 s)", [Timer(3.0, FAIL, False), Timer(8.0, OK, True)]),
    ("Now()", []),
])
def test_a_per_call_timeout_replaces_a_declared_fail_timeout_and_keeps_an_ok_one(
        call: str, want: list[Timer]) -> None:
    compiled = compile_text(f"MISSION {{ {call} }}")
    body = compiled.checked.mission.body
    assert isinstance(body, ast.Call)
    assert list(timers(compiled.checked, body)) == want
    assert agree(compiled) == len(want)


def test_a_timer_from_a_parameter_without_a_value_is_named_and_filled_in_later() -> None:
    compiled = compile_text("PARAM wait; MISSION { Go(timeout = wait); Pause(wait) }")
    go, pause = ast.calls(compiled.checked.mission.body)
    assert timers(compiled.checked, go) == (Timer("wait", FAIL, False),)
    assert timers(compiled.checked, pause) == (Timer("wait", OK, True),)
    assert [t.known for t in timers(compiled.checked, go)] == [None]
    assert agree(compiled) == 2


def test_a_per_call_timeout_names_a_mission_parameter_even_when_a_formal_has_its_name() -> None:
    # 'duration' is Pause's formal (8 s here) and a mission parameter (2 s): the call's own
    # timeout is a mission value, so it is 2 s
    compiled = compile_text("PARAM duration = 2 s; MISSION { Pause(8 s, timeout = duration) }")
    body = compiled.checked.mission.body
    assert isinstance(body, ast.Call)
    assert timers(compiled.checked, body) == (Timer(2.0, FAIL, False), Timer(8.0, OK, True))
    assert agree(compiled) == 2


def test_zero_second_timers_end_a_call_before_any_event() -> None:
    compiled = compile_text("MISSION { Go(timeout = 0 s); Hold(timeout = 0 s) }")
    assert agree(compiled) == 3
    d = analyse(compiled.checked)
    assert (d.best, d.worst) == (0, 0) and set(d.ends) == {FAIL}


# -- the shipped missions and random ones -----------------------------------------------------
@pytest.mark.parametrize("path", single_missions(), ids=lambda p: p.name)
def test_the_three_readers_agree_on_each_shipped_mission(path: object) -> None:
    compiled = compile_file(str(path))
    assert agree(compiled) > 0


@st.composite
def timer_calls(draw: st.DrawFn) -> ast.Call:
    """A call of :data:`TIMER_TASKS` or core.tasks, perhaps with its own timeout: a literal
    (0 s included) or a duration parameter."""
    name = draw(st.sampled_from(["Go", "Hold", "Look", "Watch", "Pause", "Wait", "Timeout",
                                 "Now"]))
    duration = st.one_of(S.literal("duration"), st.just(ast.Number(0.0, "s")),
                         st.sampled_from(PARAMS).map(ast.Ref))
    args: list[ast.Arg] = []
    if name in ("Pause", "Wait", "Timeout") or (name == "Look" and draw(st.booleans())):
        args.append(ast.Arg(draw(duration)))
    if name != "Now" and draw(st.booleans()):
        args.append(ast.Arg(draw(duration), "timeout"))
    return ast.Call(name, tuple(args))


@st.composite
def timer_missions(draw: st.DrawFn) -> str:
    body = draw(S.bodies(timer_calls(), 2, 6))
    params = [f"PARAM {p}" + (" = 2 s;" if draw(st.booleans()) else ";")
              for p in S.used_params(body)]
    return " ".join(params) + printer.mission(ast.Mission(None, body))


@PROFILE
@given(timer_missions())
def test_the_three_readers_agree_on_random_missions_with_every_kind_of_timer(text: str) -> None:
    agree(compile_text(text))


@PROFILE
@given(S.ictineu_missions(max_depth=2, max_calls=6))
def test_the_three_readers_agree_on_random_missions_of_the_shipped_library(
        mission: ast.Mission) -> None:
    agree(compile_source(Source("m.mcl", printer.mission(mission))))
