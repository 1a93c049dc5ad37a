"""The real-time player (petri/player.py), the loop that runs it (petri/runner.py), the run log
and its replay (petri/runlog.py, petri/replay.py), and the in-process AAL adapter.

Trace tests in the py_trees style: each test writes the trace it expects *before* driving the
player, then drives it with ``handle_event`` / ``settle`` at chosen simulated times and asserts
the exact sequence of what the player did. A trace item is one of::

    ("enable", "Alpha")        an action the player sent (kind, behaviour)
    ("event", "Alpha.ok")      an event that fired something
    ("ignored", "Beta.ok")     an event nobody waited for (logged, no effect)
    ("note", "...")            a note (Link.lost turned into an abort, last line of defence)
    ("status", "ok")           the mission ended

The task library below gives every task its own behaviour, so that the actions say which
task sent them: A() drives Alpha, B() Beta, C() Gamma, D() Delta; Watch() is a CATCH that
switches the Watch behaviour on; Sentinel() only watches (like KeepHeadDistException);
LinkWatch() catches Link.lost; Light and Cam are latched behaviours.

Every trace test also checks that the run ended with no behaviour on and the net in a proper
final marking, and that its records, written as a run log, replay as conformant.

Then: the runner with vehicle stacks that send duplicated, out-of-order and malformed
messages; the AAL message schemas; and (Hypothesis) random generic missions on random
scripted vehicles, every log replayed and edited logs refused.
"""

from __future__ import annotations

import json
import os
import random
import tempfile
from pathlib import Path
from typing import Any
from unittest import mock

import pytest
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import event as statistic
from hypothesis import strategies as st

import petri.player
from mcl import ast, printer, tasklib
from mcl.api import compile_source
from mcl.errors import Source
from petri.net import Net
from petri.player import Player, Record
from petri.replay import check
from petri.runlog import FORMAT, LogError, RunLog, net_digest, read_log
from petri.runner import run
from tests import strategies as S
from tests.support import GENERIC_TASKS, REPO
from vehicle_adapters.aal import ActionMessage, EventMessage, InvalidMessage
from vehicle_adapters.inprocess import InProcess
from vehicle_adapters.scripted import ScriptedVehicle, load_script

CORE_TASKS = (REPO / "mcl" / "tasks" / "core.tasks").read_text("utf-8")  # Wait, Timeout
TRACE_TASKS = """
behaviour Alpha events ok, fail;
behaviour Beta  events ok, fail;
behaviour Gamma events ok, fail;
behaviour Delta events ok, fail;
behaviour Watch events alarm, clear;
behaviour Light;
behaviour Cam;
task A() { start: enable Alpha; ok: Alpha.ok; fail: Alpha.fail; stop: disable Alpha; }
task B() { start: enable Beta;  ok: Beta.ok;  fail: Beta.fail;  stop: disable Beta; }
task C() { start: enable Gamma; ok: Gamma.ok; fail: Gamma.fail; stop: disable Gamma; }
task D() { start: enable Delta; ok: Delta.ok; fail: Delta.fail; stop: disable Delta; }
task Watch() { start: enable Watch; ok: Watch.clear; fail: Watch.alarm; stop: disable Watch; }
task Sentinel() { fail: Watch.alarm; }
task AlphaWatch() { fail: Alpha.fail; }
task LinkWatch() { fail: Link.lost; }
task Now() { }
task Light(enable)  { start: enable Light;  latch: Light; }
task Light(disable) { start: disable Light; unlatch: Light; }
task Cam(enable)    { start: enable Cam;    latch: Cam; }
task Cam(disable)   { start: disable Cam;   unlatch: Cam; }
"""
LIBRARY = tasklib.load_sources([Source("core.tasks", CORE_TASKS),
                                Source("trace.tasks", TRACE_TASKS)])

Trace = list[tuple[str, str]]


# -- the harness --------------------------------------------------------------------------
def log_records(net: Net, records: list[Record]) -> list[dict[str, Any]]:
    """The records as ``read_log`` returns them from a RunLog file (header first)."""
    out: list[dict[str, Any]] = [{"kind": "header", "format": FORMAT, "net": net_digest(net),
                                  "_line": 1}]
    for i, r in enumerate(records, start=2):
        out.append({"t": round(r.t, 6), "kind": r.kind, **r.data, "_line": i})
    return out


class Harness:
    """A player on a mission written in the trace library, recording what it does."""

    def __init__(self, body: str, params: dict[str, Any] | None = None, header: str = ""):
        text = f"{header}MISSION {{\n{body}\n}}\n"
        self.net = compile_source(Source("m.mcl", text), library=LIBRARY).net
        self.records: list[Record] = []
        self.params = params or {}
        self.player = Player(self.net, dict(self.params), observers=[self.records.append])

    def start(self, now: float = 0.0) -> Harness:
        self.player.start(now)
        return self

    def event(self, name: str, now: float) -> int:
        return self.player.handle_event(name, now)

    def trace(self, since: int = 0) -> Trace:
        out: Trace = []
        for r in self.records[since:]:
            if r.kind == "action":
                out.append((r.data["action"], r.data["behaviour"]))
            elif r.kind == "event":
                out.append(("event", r.data["event"]))
            elif r.kind == "ignored":
                out.append(("ignored", r.data["event"]))
            elif r.kind == "note":
                out.append(("note", r.data["note"]))
            elif r.kind == "status" and r.data["status"] != "running":
                out.append(("status", r.data["status"]))
        return out

    def timed(self) -> list[tuple[float, str, str]]:
        """Actions with their times."""
        return [(r.t, r.data["action"], r.data["behaviour"]) for r in self.records
                if r.kind == "action"]

    def fired(self) -> list[str]:
        return [r.data["transition"] for r in self.records if r.kind == "fire"]

    def on(self) -> set[str]:
        return set(self.player.behaviours_on)

    def assert_finished(self, status: str, defence: bool = False) -> None:
        """Ended with ``status``; no behaviour on; a proper final marking; the records
        replay as conformant. ``defence``: the last line of defence was expected."""
        p = self.player
        assert p.status == status
        assert p.finished
        assert p.behaviours_on == {}, p.behaviours_on
        marking = {i: n for i, n in enumerate(p.marking) if n}
        if not defence:  # else the net itself leaves the latch on: not a proper final
            assert marking in self.net.finals, self.net.describe_marking(marking)
        notes = [r.data["note"] for r in self.records if r.kind == "note"]
        assert any("switching off" in n for n in notes) == defence, notes
        self.assert_conformant()

    def assert_conformant(self) -> None:
        result = check(self.net, log_records(self.net, self.records), self.params)
        assert result.ok, (result.line, result.reason)


# A trace helper for the expected side: ("enable", "Alpha") etc. from short strings.
def T(*items: str) -> Trace:  # a short name: it reads like a table
    """``T("+Alpha", "Alpha.ok>", "-Alpha", "Beta.ok?", "=ok")``: + enable, - disable,
    ``X.y>`` event, ``X.y?`` ignored, ``=s`` status."""
    out: Trace = []
    for it in items:
        if it.startswith("+"):
            out.append(("enable", it[1:]))
        elif it.startswith("-"):
            out.append(("disable", it[1:]))
        elif it.endswith(">"):
            out.append(("event", it[:-1]))
        elif it.endswith("?"):
            out.append(("ignored", it[:-1]))
        elif it.startswith("="):
            out.append(("status", it[1:]))
        else:
            raise ValueError(it)
    return out


def without_notes(trace: Trace) -> Trace:
    return [x for x in trace if x[0] != "note"]


# -- sequence -----------------------------------------------------------------------------
def test_sequence_runs_every_item_whatever_the_status_of_the_one_before() -> None:
    # A fails, B still starts; the sequence ends with the status of its last item (C: ok).
    expected = T("+Alpha",
                 "Alpha.fail>", "-Alpha", "+Beta",
                 "Beta.ok>", "-Beta", "+Gamma",
                 "Gamma.ok>", "-Gamma", "=ok")
    h = Harness("A(); B(); C()").start(0)
    h.event("Alpha.fail", 1)
    h.event("Beta.ok", 2)
    h.event("Gamma.ok", 3)
    assert h.trace() == expected
    h.assert_finished("ok")


def test_sequence_ends_with_the_status_of_its_last_item() -> None:
    expected = T("+Alpha", "Alpha.ok>", "-Alpha", "+Beta", "Beta.fail>", "-Beta", "=fail")
    h = Harness("A(); B()").start(0)
    h.event("Alpha.ok", 1)
    h.event("Beta.fail", 2)
    assert h.trace() == expected
    h.assert_finished("fail")


# -- TRY / CATCH / DO ---------------------------------------------------------------------
TRY = "TRY { A() } CATCH { Watch() } DO { B() }"


@pytest.mark.parametrize("status", ["ok", "fail"])
def test_try_ends_first_aborts_catch_and_ends_with_try_status(status: str) -> None:
    # TRY and CATCH start together; TRY ends first: CATCH is stopped, DO never runs.
    expected = T("+Alpha", "+Watch", f"Alpha.{status}>", "-Alpha", "-Watch", f"={status}")
    h = Harness(TRY).start(0)
    h.event(f"Alpha.{status}", 1)
    assert h.trace() == expected
    h.assert_finished(status)


@pytest.mark.parametrize("catch_event", ["Watch.alarm", "Watch.clear"])
@pytest.mark.parametrize("do_status", ["ok", "fail"])
def test_catch_ends_first_aborts_try_then_do_decides(catch_event: str, do_status: str) -> None:
    # CATCH ends first (whatever its status): TRY is stopped (its stop action goes out before
    # DO starts), DO runs, and the structure ends with DO's status.
    expected = T("+Alpha", "+Watch",
                 f"{catch_event}>", "-Watch", "-Alpha", "+Beta",
                 f"Beta.{do_status}>", "-Beta", f"={do_status}")
    h = Harness(TRY).start(0)
    h.event(catch_event, 1)
    assert h.on() == {"Beta"}
    h.event(f"Beta.{do_status}", 2)
    assert h.trace() == expected
    h.assert_finished(do_status)


def test_try_catch_do_inside_a_sequence_continues_after_do() -> None:
    expected = T("+Alpha", "+Watch", "Watch.alarm>", "-Watch", "-Alpha", "+Beta",
                 "Beta.fail>", "-Beta", "+Gamma", "Gamma.ok>", "-Gamma", "=ok")
    h = Harness(f"{TRY}; C()").start(0)
    h.event("Watch.alarm", 1)
    h.event("Beta.fail", 2)
    h.event("Gamma.ok", 3)
    assert h.trace() == expected
    h.assert_finished("ok")


# -- PARALLEL AND -------------------------------------------------------------------------
def test_parallel_and_waits_for_every_branch_and_ends_ok_if_all_ok() -> None:
    expected = T("+Alpha", "+Beta", "Beta.ok>", "-Beta", "Alpha.ok>", "-Alpha", "=ok")
    h = Harness("PARALLEL { A() } AND { B() }").start(0)
    h.event("Beta.ok", 1)
    assert h.player.status == "running"
    h.event("Alpha.ok", 2)
    assert h.trace() == expected
    h.assert_finished("ok")


def test_parallel_and_with_a_failed_branch_still_waits_then_ends_fail() -> None:
    # A failing branch does not stop the others: B runs on until it ends.
    expected = T("+Alpha", "+Beta", "+Gamma",
                 "Alpha.fail>", "-Alpha",
                 "Gamma.ok>", "-Gamma",
                 "Beta.ok>", "-Beta", "=fail")
    h = Harness("PARALLEL { A() } AND { B() } AND { C() }").start(0)
    h.event("Alpha.fail", 1)
    assert h.on() == {"Beta", "Gamma"}
    h.event("Gamma.ok", 2)
    h.event("Beta.ok", 3)
    assert h.trace() == expected
    h.assert_finished("fail")


# -- PARALLEL OR --------------------------------------------------------------------------
@pytest.mark.parametrize("status", ["ok", "fail"])
def test_parallel_or_first_branch_aborts_the_others(status: str) -> None:
    # B ends first: A and C are stopped (lowest first), the OR ends with B's status, and a
    # late answer for A is ignored.
    expected = T("+Alpha", "+Beta", "+Gamma",
                 f"Beta.{status}>", "-Beta", "-Alpha", "-Gamma", f"={status}",
                 "Alpha.ok?")
    h = Harness("PARALLEL { A() } OR { B() } OR { C() }").start(0)
    h.event(f"Beta.{status}", 1)
    assert h.event("Alpha.ok", 2) == 0
    assert h.trace() == expected
    h.assert_finished(status)


def test_parallel_or_two_branches_ending_on_the_same_event() -> None:
    # One event ends both branches at once: the first branch wins, the second one's result
    # is absorbed (its abort arrives late). Alpha drives no degree of freedom: a watcher
    # shared by both tasks, it stays on until the last holder lets go, so one disable goes
    # out, after the second branch has stopped (issue 11, shared watchers).
    expected = T("+Alpha", "+Alpha", "Alpha.ok>", "-Alpha", "=ok")
    h = Harness("PARALLEL { A() } OR { A() }").start(0)
    assert h.event("Alpha.ok", 1) == 2
    assert without_notes(h.trace()) == expected
    assert ("note", "Alpha stays on: still held by A@2:23") in h.trace()
    assert any(n.endswith(".late_ok") for n in h.fired())
    h.assert_finished("ok")


# -- IF / THEN / ELSE ---------------------------------------------------------------------
@pytest.mark.parametrize("cond, branch, behaviour", [("ok", "Beta", "Beta"),
                                                     ("fail", "Gamma", "Gamma")])
def test_if_then_else_takes_the_branch_the_condition_says(cond: str, branch: str,
                                                          behaviour: str) -> None:
    expected = T("+Alpha", f"Alpha.{cond}>", "-Alpha", f"+{behaviour}",
                 f"{branch}.fail>", f"-{behaviour}", "=fail")
    h = Harness("IF { A() } THEN { B() } ELSE { C() }").start(0)
    h.event(f"Alpha.{cond}", 1)
    h.event(f"{branch}.fail", 2)
    assert h.trace() == expected
    h.assert_finished("fail")


def test_if_without_else_fails_when_the_condition_fails() -> None:
    expected = T("+Alpha", "Alpha.fail>", "-Alpha", "=fail")
    h = Harness("IF { A() } THEN { B() }").start(0)
    h.event("Alpha.fail", 1)
    assert h.trace() == expected
    h.assert_finished("fail")


# -- WHILE --------------------------------------------------------------------------------
def test_while_repeats_until_the_condition_fails_then_ends_ok() -> None:
    expected = T("+Alpha", "Alpha.ok>", "-Alpha", "+Beta", "Beta.ok>", "-Beta",
                 "+Alpha", "Alpha.ok>", "-Alpha", "+Beta", "Beta.ok>", "-Beta",
                 "+Alpha", "Alpha.fail>", "-Alpha", "=ok")
    h = Harness("WHILE { A() } DO { B() }").start(0)
    for t, e in enumerate(["Alpha.ok", "Beta.ok", "Alpha.ok", "Beta.ok", "Alpha.fail"], 1):
        h.event(e, t)
    assert h.trace() == expected
    h.assert_finished("ok")


def test_while_ends_fail_when_the_body_fails() -> None:
    expected = T("+Alpha", "Alpha.ok>", "-Alpha", "+Beta", "Beta.fail>", "-Beta", "=fail")
    h = Harness("WHILE { A() } DO { B() }").start(0)
    h.event("Alpha.ok", 1)
    h.event("Beta.fail", 2)
    assert h.trace() == expected
    h.assert_finished("fail")


# -- timers -------------------------------------------------------------------------------
def test_wait_fires_at_its_time_and_not_before() -> None:
    # Wait(5) ends ok at t = 5 exactly: A starts then.
    expected = [(5.0, "enable", "Alpha"), (6.5, "disable", "Alpha")]
    h = Harness("Wait(5 s); A()").start(0)
    assert h.player.next_deadline() == pytest.approx(5.0)
    h.player.settle(4.999)
    assert h.timed() == []
    h.player.settle(5.0)
    assert h.player.next_deadline() is None
    h.event("Alpha.ok", 6.5)
    assert h.timed() == expected
    h.assert_finished("ok")


def test_timeout_in_parallel_or_bounds_a_task() -> None:
    expected = [(0.0, "enable", "Alpha"), (10.0, "disable", "Alpha")]
    h = Harness("PARALLEL { A() } OR { Timeout(10 s) }").start(0)
    assert h.player.next_deadline() == pytest.approx(10.0)
    h.player.settle(9.9)
    assert h.player.status == "running"
    h.player.settle(10.0)
    assert h.timed() == expected
    assert any(f.startswith("Timeout@") and f.endswith(".timeout") for f in h.fired())
    h.assert_finished("fail")


def test_timeout_in_parallel_or_is_disarmed_when_the_task_ends_first() -> None:
    expected = T("+Alpha", "Alpha.ok>", "-Alpha", "=ok")
    h = Harness("PARALLEL { A() } OR { Timeout(10 s) }").start(0)
    h.event("Alpha.ok", 3)
    assert h.player.next_deadline() is None
    assert h.trace() == expected
    h.assert_finished("ok")


def test_a_per_call_timeout_ends_the_task_fail_with_its_stop_actions() -> None:
    expected = [(2.0, "enable", "Alpha"), (6.0, "disable", "Alpha")]
    h = Harness("A(timeout = 4 s)").start(2.0)
    assert h.player.next_deadline() == pytest.approx(6.0)
    h.player.settle(6.0)
    assert h.timed() == expected
    h.assert_finished("fail")


def test_a_timer_is_armed_when_its_task_starts_not_before() -> None:
    # WHILE { A() } DO { Wait(3 s) }: each Wait counts from its own start.
    h = Harness("WHILE { A() } DO { Wait(3 s) }").start(0)
    assert h.player.next_deadline() is None
    h.event("Alpha.ok", 1)
    assert h.player.next_deadline() == pytest.approx(4.0)
    h.player.settle(4.0)  # Wait ends, A starts again
    assert h.player.next_deadline() is None
    h.event("Alpha.ok", 10)
    assert h.player.next_deadline() == pytest.approx(13.0)
    h.player.settle(12.99)
    assert h.on() == set()
    h.player.settle(13.0)
    h.event("Alpha.fail", 20)
    assert [t for t, kind, _ in h.timed() if kind == "enable"] == [0.0, 4.0, 13.0]
    h.assert_finished("ok")


def test_a_timer_due_at_the_same_instant_as_an_event_that_came_first_loses() -> None:
    h = Harness("PARALLEL { A() } OR { Timeout(1 s) }").start(0)
    h.event("Alpha.ok", 1.0)
    h.player.settle(1.0)
    assert h.trace() == T("+Alpha", "Alpha.ok>", "-Alpha", "=ok")
    h.assert_finished("ok")


def test_an_event_after_a_due_timer_comes_too_late() -> None:
    # The Timeout was due at 1.0; the event is handled at 1.5: the OR has already ended
    # fail at 1.0, so the event is ignored — whether or not settle(1.0) was called.
    expected = [(0.0, "enable", "Alpha"), (1.0, "disable", "Alpha")]
    h = Harness("PARALLEL { A() } OR { Timeout(1 s) }").start(0)
    h.event("Alpha.ok", 1.5)
    assert h.player.status == "fail"
    assert h.timed() == expected


def test_an_event_fires_only_what_waited_for_it_before_it_came() -> None:
    # A(); A(): one Alpha.ok ends the first A; the second one, started by that very event,
    # still waits.
    h = Harness("A(); A()").start(0)
    assert h.event("Alpha.ok", 1) == 1
    assert h.trace() == T("+Alpha", "Alpha.ok>", "-Alpha", "+Alpha")
    assert h.player.status == "running" and h.on() == {"Alpha"}
    h.event("Alpha.ok", 2)
    h.assert_finished("ok")


def test_a_timer_is_disarmed_by_an_abort() -> None:
    expected = T("+Watch", "Watch.alarm>", "-Watch", "+Beta")
    h = Harness("TRY { Wait(5 s); A() } CATCH { Watch() } DO { B() }").start(0)
    assert h.player.next_deadline() == pytest.approx(5.0)
    h.event("Watch.alarm", 2)
    assert h.player.next_deadline() is None
    h.player.settle(5.0)
    assert h.trace() == expected  # A never started
    h.event("Beta.ok", 6)
    h.assert_finished("ok")


def test_a_timer_given_by_a_mission_parameter_at_run_time() -> None:
    h = Harness("Wait(pause); A()", params={"pause": 2.5}, header="PARAM pause;\n").start(1.0)
    assert h.player.next_deadline() == pytest.approx(3.5)
    h.player.settle(3.5)
    assert h.timed() == [(3.5, "enable", "Alpha")]
    h.event("Alpha.ok", 4)
    h.assert_finished("ok")


# -- latched behaviours -------------------------------------------------------------------
def test_a_latched_behaviour_stays_on_until_switched_off() -> None:
    expected = T("+Light", "+Alpha", "Alpha.ok>", "-Alpha", "-Light", "=ok")
    h = Harness("Light(enable); A(); Light(disable)").start(0)
    assert h.on() == {"Light", "Alpha"}
    h.event("Alpha.ok", 1)
    assert h.trace() == expected
    h.assert_finished("ok")


def test_an_abort_switches_off_a_latch_from_inside_before_the_block_reports_back() -> None:
    # The CATCH fires while A runs with Light on from inside TRY: A stops, Light goes off,
    # and only then does DO start (Light must not still be on while B runs).
    expected = T("+Light", "+Alpha", "+Watch",
                 "Watch.alarm>", "-Watch", "-Alpha", "-Light", "+Beta",
                 "Beta.ok>", "-Beta", "=ok")
    h = Harness("TRY { Light(enable); A(); Light(disable) } CATCH { Watch() } DO { B() }")
    h.start(0)
    h.event("Watch.alarm", 1)
    assert h.on() == {"Beta"}
    h.event("Beta.ok", 2)
    assert h.trace() == expected
    h.assert_finished("ok")


def test_an_abort_leaves_a_latch_switched_on_outside_the_aborted_block() -> None:
    expected = T("+Light", "+Alpha", "+Watch",
                 "Watch.alarm>", "-Watch", "-Alpha", "+Beta",
                 "Beta.ok>", "-Beta", "-Light", "=ok")
    h = Harness("Light(enable); TRY { A() } CATCH { Watch() } DO { B() }; Light(disable)")
    h.start(0)
    h.event("Watch.alarm", 1)
    assert h.on() == {"Light", "Beta"}
    h.event("Beta.ok", 2)
    assert h.trace() == expected
    h.assert_finished("ok")


def test_mission_abort_switches_every_latch_off_before_the_mission_ends() -> None:
    # Latches are switched off one behaviour after the other, by name (Cam, Light), after
    # the running task stopped, and before the status; no last line of defence needed.
    expected = T("+Light", "+Cam", "+Alpha",
                 "Mission.abort>", "-Alpha", "-Cam", "-Light", "=fail")
    h = Harness("Light(enable); Cam(enable); A(); Cam(disable); Light(disable)").start(0)
    h.event("Mission.abort", 1)
    assert h.trace() == expected
    h.assert_finished("fail")


def test_an_abort_switches_off_latches_in_every_parallel_branch() -> None:
    expected = T("+Light", "+Alpha", "+Cam", "+Beta", "+Watch",
                 "Beta.ok>", "-Beta", "-Cam",
                 "Watch.alarm>", "-Watch", "-Alpha", "-Light", "+Gamma",
                 "Gamma.ok>", "-Gamma", "=ok")
    h = Harness("TRY { PARALLEL { Light(enable); A(); Light(disable) } "
                "AND { Cam(enable); B(); Cam(disable) } } CATCH { Watch() } DO { C() }")
    h.start(0)
    h.event("Beta.ok", 1)
    h.event("Watch.alarm", 2)
    assert h.on() == {"Gamma"}
    h.event("Gamma.ok", 3)
    assert h.trace() == expected
    h.assert_finished("ok")


def test_an_abort_of_a_while_body_switches_its_latch_off() -> None:
    expected = T("+Alpha", "+Watch", "Alpha.ok>", "-Alpha", "+Light", "+Beta",
                 "Watch.alarm>", "-Watch", "-Beta", "-Light", "=ok")
    h = Harness("TRY { WHILE { A() } DO { Light(enable); B(); Light(disable) } } "
                "CATCH { Watch() } DO { Now() }")
    h.start(0)
    h.event("Alpha.ok", 1)
    h.event("Watch.alarm", 2)
    assert h.trace() == expected
    h.assert_finished("ok")


def test_the_last_line_of_defence_switches_off_a_latch_left_on_and_says_so() -> None:
    # A mission that ends with Light on (mclc warns about it): the player switches it off
    # and notes it; the log still replays.
    h = Harness("Light(enable); A()").start(0)
    h.event("Alpha.ok", 1)
    trace = h.trace()
    assert without_notes(trace) == T("+Light", "+Alpha", "Alpha.ok>", "-Alpha", "-Light",
                                     "=ok")
    note = next(x for x in trace if x[0] == "note")
    assert "Light" in note[1]
    assert trace.index(note) == trace.index(("disable", "Light")) - 1
    h.assert_finished("ok", defence=True)


# -- aborts at awkward moments ------------------------------------------------------------
def test_a_task_ends_and_the_catch_fires_at_the_same_time_task_first() -> None:
    # Two events at t = 5: Alpha.ok arrives first, so TRY ended first: CATCH is stopped and
    # the alarm that follows at the same instant is ignored.
    expected = T("+Alpha", "+Watch", "Alpha.ok>", "-Alpha", "-Watch", "=ok", "Watch.alarm?")
    h = Harness(TRY).start(0)
    h.event("Alpha.ok", 5)
    h.event("Watch.alarm", 5)
    assert h.trace() == expected
    h.assert_finished("ok")


def test_a_task_ends_and_the_catch_fires_at_the_same_time_alarm_first() -> None:
    expected = T("+Alpha", "+Watch", "Watch.alarm>", "-Watch", "-Alpha", "+Beta",
                 "Alpha.ok?", "Beta.ok>", "-Beta", "=ok")
    h = Harness(TRY).start(0)
    h.event("Watch.alarm", 5)
    h.event("Alpha.ok", 5)
    h.event("Beta.ok", 6)
    assert h.trace() == expected
    h.assert_finished("ok")


def test_one_event_that_ends_both_try_and_catch_try_wins() -> None:
    # Alpha.fail ends A (TRY, fail) and AlphaWatch (CATCH) in the same step. The player's
    # tie-break (lowest index first; TRY's transitions come before CATCH's) lets TRY win:
    # the CATCH's late abort is absorbed, DO never runs.
    expected = T("+Alpha", "Alpha.fail>", "-Alpha", "=fail")
    h = Harness("TRY { A() } CATCH { AlphaWatch() } DO { B() }").start(0)
    assert h.event("Alpha.fail", 1) == 2
    assert h.trace() == expected
    assert any("stop_catch_fail.late_fail" in n for n in h.fired())
    h.assert_finished("fail")


def test_an_abort_during_do_the_abort_of_an_earlier_catch() -> None:
    # The CATCH fired (first abort: A stopped, Light off, DO runs B); then the mission is
    # aborted while DO runs (second abort): B stops, the mission ends fail.
    expected = T("+Light", "+Alpha", "+Watch",
                 "Watch.alarm>", "-Watch", "-Alpha", "-Light", "+Beta",
                 "Mission.abort>", "-Beta", "=fail")
    h = Harness("TRY { Light(enable); A(); Light(disable) } CATCH { Watch() } DO { B() }")
    h.start(0)
    h.event("Watch.alarm", 1)
    h.event("Mission.abort", 2)
    assert h.trace() == expected
    h.assert_finished("fail")


NESTED = ("TRY { TRY { Light(enable); A(); Light(disable) } CATCH { Watch() } DO { B() } } "
          "CATCH { Sentinel() } DO { D() }")


def test_an_abort_while_an_inner_catch_is_aborting_its_try_ends_clean() -> None:
    # One alarm reaches both the inner CATCH (Watch) and the outer one (Sentinel): the inner
    # TRY is aborted by the outer CATCH while it is itself handling its own CATCH (an abort
    # during an abort). However the race resolves: A and Watch stop, Light goes off, the
    # outer DO (D) runs alone, and the run ends clean.
    h = Harness(NESTED).start(0)
    h.event("Watch.alarm", 1)
    assert h.on() == {"Delta"}
    h.event("Delta.ok", 2)
    got = h.trace()
    assert got[:6] == T("+Light", "+Alpha", "+Watch", "Watch.alarm>", "-Watch", "-Alpha")
    assert got[-4:] == T("+Delta", "Delta.ok>", "-Delta", "=ok")
    assert got.index(("disable", "Light")) < got.index(("enable", "Delta"))
    h.assert_finished("ok")


def test_an_abort_while_an_inner_catch_is_aborting_its_try() -> None:
    # Expected: the inner DO (B), whose structure is being aborted, never starts.
    expected = T("+Light", "+Alpha", "+Watch",
                 "Watch.alarm>", "-Watch", "-Alpha", "-Light", "+Delta",
                 "Delta.ok>", "-Delta", "=ok")
    h = Harness(NESTED).start(0)
    h.event("Watch.alarm", 1)
    h.event("Delta.ok", 2)
    assert h.trace() == expected


def test_an_alarm_and_a_mission_abort_at_the_same_instant() -> None:
    # Alarm first: DO starts, then the mission abort stops it at once.
    expected = T("+Alpha", "+Watch", "Watch.alarm>", "-Watch", "-Alpha", "+Beta",
                 "Mission.abort>", "-Beta", "=fail")
    h = Harness(TRY).start(0)
    h.event("Watch.alarm", 3)
    h.event("Mission.abort", 3)
    assert h.trace() == expected
    h.assert_finished("fail")
    # Abort first: everything stops; the alarm at the same instant is ignored.
    expected = T("+Alpha", "+Watch", "Mission.abort>", "-Alpha", "-Watch", "=fail",
                 "Watch.alarm?")
    h = Harness(TRY).start(0)
    h.event("Mission.abort", 3)
    h.event("Watch.alarm", 3)
    assert h.trace() == expected
    h.assert_finished("fail")


def test_a_late_abort_of_a_block_that_has_just_ended_is_absorbed() -> None:
    # PARALLEL OR: A ends at t=1 just as the Timeout(1 s) falls due: the event comes first,
    # the timer's branch is aborted (the timer never fires); then a second settle at the same
    # time changes nothing.
    expected = T("+Alpha", "Alpha.ok>", "-Alpha", "=ok")
    h = Harness("PARALLEL { A() } OR { Timeout(1 s) }").start(0)
    h.event("Alpha.ok", 1.0)
    h.player.settle(1.0)
    assert h.trace() == expected
    assert not any(".timeout" in n for n in h.fired())
    h.assert_finished("ok")


def test_link_lost_with_a_catch_for_it_runs_do() -> None:
    expected = T("+Alpha", "Link.lost>", "-Alpha", "+Beta", "Beta.ok>", "-Beta", "=ok")
    h = Harness("TRY { A() } CATCH { LinkWatch() } DO { B() }").start(0)
    h.event("Link.lost", 1)
    h.event("Beta.ok", 2)
    assert h.trace() == expected  # no note: a block caught it
    h.assert_finished("ok")


def test_link_lost_without_a_catch_aborts_the_mission() -> None:
    # Nobody waits for Link.lost: the player notes it, fires Mission.abort; A stops, Light
    # goes off, B never starts, the mission ends fail.
    h = Harness("Light(enable); A(); B(); Light(disable)").start(0)
    assert h.event("Link.lost", 1) >= 1
    trace = h.trace()
    assert trace[0:2] == T("+Light", "+Alpha")
    assert trace[2][0] == "note" and "Link.lost" in trace[2][1]
    assert trace[3:] == T("Link.lost>", "-Alpha", "-Light", "=fail")
    assert "MISSION.abort" in h.fired()
    fire = next(r for r in h.records if r.kind == "fire" and r.data["transition"] ==
                "MISSION.abort")
    assert fire.data["cause"] == "Link.lost"
    h.assert_finished("fail")


def test_link_lost_when_its_catch_is_no_longer_running_aborts_the_mission() -> None:
    h = Harness("TRY { A() } CATCH { LinkWatch() } DO { B() }; C()").start(0)
    h.event("Alpha.ok", 1)
    h.event("Link.lost", 2)
    assert without_notes(h.trace()) == T("+Alpha", "Alpha.ok>", "-Alpha", "+Gamma",
                                          "Link.lost>", "-Gamma", "=fail")
    h.assert_finished("fail")


def test_a_second_mission_abort_is_ignored() -> None:
    h = Harness("A()").start(0)
    h.event("Mission.abort", 1)
    assert h.event("Mission.abort", 2) == 0
    assert h.event("Link.lost", 3) == 0
    assert h.trace() == T("+Alpha", "Mission.abort>", "-Alpha", "=fail",
                          "Mission.abort?", "Link.lost?")
    h.assert_finished("fail")


# -- events nobody waits for ----------------------------------------------------------------
def test_events_nobody_waits_for_are_ignored_and_logged() -> None:
    expected = T("+Alpha", "Beta.ok?", "Nobody.knows?", "Alpha.ok>", "-Alpha", "=ok",
                 "Alpha.ok?")
    h = Harness("A()").start(0)
    before = list(h.player.marking)
    assert h.event("Beta.ok", 1) == 0
    assert h.event("Nobody.knows", 1.5) == 0
    assert h.player.marking == before
    assert h.event("Alpha.ok", 2) == 1
    assert h.event("Alpha.ok", 3) == 0  # after the end
    assert h.trace() == expected
    ignored = [r for r in h.records if r.kind == "ignored"]
    assert [r.t for r in ignored] == [1, 1.5, 3]
    assert all(r.data["reason"] for r in ignored)
    h.assert_finished("ok")


def test_snapshot_shows_the_running_tasks_and_the_behaviours_on() -> None:
    h = Harness("Light(enable); PARALLEL { A() } AND { B() }; Light(disable)").start(0)
    snap = h.player.snapshot()
    assert snap["status"] == "running"
    assert [t.split("@")[0] for t in snap["running_tasks"]] == ["A", "B"]
    assert snap["behaviours_on"] == ["Alpha", "Beta", "Light"]
    h.event("Alpha.ok", 1)
    h.event("Beta.ok", 2)
    snap = h.player.snapshot()
    assert snap["status"] == "ok" and snap["running_tasks"] == [] and \
        snap["behaviours_on"] == []
    assert snap["fired"] == h.player.fired == len(h.fired())


# -- determinism ----------------------------------------------------------------------------
EVERY_CONSTRUCT = """
Light(enable);
TRY {
    PARALLEL { A(); Cam(enable); B(); Cam(disable) } AND { WHILE { C() } DO { Wait(2 s) } };
    IF { D() } THEN { PARALLEL { A() } OR { Timeout(5 s) } } ELSE { B() }
} CATCH { Watch() } DO { Now() };
Light(disable)
"""
SCHEDULE = [(1, "Alpha.ok"), (2, "Gamma.ok"), (3, "Beta.ok"), (4, "Gamma.ok"), (6.5, "Junk.x"),
            (7, "Gamma.fail"), (8, "Delta.ok"), (9, "Alpha.ok"), (9, "Watch.alarm")]


def drive(h: Harness, schedule: list[tuple[float, str]]) -> None:
    """Events at their times, and every timer that falls due in between, as a runner would."""
    h.start(0)
    for t, event in schedule:
        while (d := h.player.next_deadline()) is not None and d <= t:
            h.player.settle(d)
        h.event(event, t)


def test_the_same_events_at_the_same_times_give_the_same_firings() -> None:
    runs = []
    for _ in range(3):
        h = Harness(EVERY_CONSTRUCT)
        drive(h, SCHEDULE)
        runs.append(h)
    assert runs[0].records == runs[1].records == runs[2].records
    assert runs[0].player.finished
    runs[0].assert_finished(runs[0].player.status)


def test_every_construct_schedule_trace() -> None:
    # Light on; the AND runs A then Cam/B and a WHILE of C / Wait(2 s); Junk is ignored; the
    # WHILE ends when C fails at 7; D ok at 8 -> the OR of A and Timeout(5 s), A ends at 9,
    # and the alarm at the same instant comes too late.
    expected = T("+Light", "+Alpha", "+Gamma", "+Watch",
                 "Alpha.ok>", "-Alpha", "+Cam", "+Beta",
                 "Gamma.ok>", "-Gamma",                       # Wait(2 s) 2 -> 4
                 "Beta.ok>", "-Beta", "-Cam",
                 "+Gamma",                                    # t = 4: WHILE again
                 "Gamma.ok>", "-Gamma",                       # Wait 4 -> 6
                 "+Gamma",                                    # t = 6
                 "Junk.x?",
                 "Gamma.fail>", "-Gamma",                     # the AND ends ok
                 "+Delta", "Delta.ok>", "-Delta", "+Alpha",
                 "Alpha.ok>", "-Alpha", "-Watch", "-Light", "=ok",
                 "Watch.alarm?")
    h = Harness(EVERY_CONSTRUCT)
    drive(h, SCHEDULE)
    assert h.trace() == expected
    h.assert_finished("ok")


# -- the runner: duplicated, out-of-order and malformed messages --------------------------
class Raw:
    """A message as it travels: ``to_json`` gives exactly this text."""

    def __init__(self, text: str):
        self.text = text

    def to_json(self) -> str:
        return self.text


class ListStack:
    """A simulated vehicle stack that sends prepared messages at given times, whatever the
    actions (which it records)."""

    def __init__(self, messages: list[tuple[float, Any]]):
        self.pending = sorted(messages, key=lambda m: m[0])
        self.actions: list[ActionMessage] = []

    def on_action(self, action: ActionMessage, now: float) -> None:
        self.actions.append(action)

    def next_time(self) -> float | None:
        return self.pending[0][0] if self.pending else None

    def due(self, t: float) -> list[Any]:
        out = [m for when, m in self.pending if when <= t]
        self.pending = [(when, m) for when, m in self.pending if when > t]
        return out


def ev(seq: int, t: float, event: str) -> EventMessage:
    source, name = event.split(".")
    return EventMessage(seq, t, source, name)


def run_with(body: str, messages: list[tuple[float, Any]]) -> tuple[Harness, Any, InProcess]:
    h = Harness(body)
    vehicle = InProcess(ListStack(messages))
    outcome = run(h.player, vehicle, "m", max_time=1000)
    return h, outcome, vehicle


def test_runner_drops_duplicated_and_out_of_order_events_by_seq() -> None:
    # A(); A(): seq 1 ends the first A; a duplicate of seq 1 (t=2) and an old seq 0 (t=3)
    # must not end the second A; seq 2 (t=4) does.
    expected = T("+Alpha", "Alpha.ok>", "-Alpha", "+Alpha",
                 "Alpha.ok?", "Alpha.ok?",
                 "Alpha.ok>", "-Alpha", "=ok")
    h, outcome, _ = run_with("A(); A()", [(1, ev(1, 1, "Alpha.ok")), (2, ev(1, 2, "Alpha.ok")),
                                          (3, ev(0, 3, "Alpha.ok")), (4, ev(2, 4, "Alpha.ok"))])
    assert h.trace() == expected
    assert outcome.status == "ok" and outcome.time == 4
    reasons = [r.data["reason"] for r in h.records if r.kind == "ignored"]
    assert reasons == ["seq 1 after 1: duplicate or out of order",
                       "seq 0 after 1: duplicate or out of order"]
    h.assert_finished("ok")


def test_runner_accepts_gaps_in_seq() -> None:
    h, outcome, _ = run_with("A(); B()", [(1, ev(5, 1, "Alpha.ok")), (2, ev(90, 2, "Beta.ok"))])
    assert outcome.status == "ok"
    h.assert_finished("ok")


def test_runner_two_events_in_one_batch_are_handled_in_order() -> None:
    # Both due at t = 5, in seq order: the alarm first, then A's answer comes too late.
    h, outcome, _ = run_with(TRY, [(5, ev(0, 5, "Watch.alarm")), (5, ev(1, 5, "Alpha.ok")),
                                   (6, ev(2, 6, "Beta.ok"))])
    assert h.trace() == T("+Alpha", "+Watch", "Watch.alarm>", "-Watch", "-Alpha", "+Beta",
                          "Alpha.ok?", "Beta.ok>", "-Beta", "=ok")
    assert outcome.status == "ok"
    h.assert_finished("ok")


MALFORMED = [
    "{not json",
    "[1, 2, 3]",
    '{"v": 2, "seq": 0, "t": 1.0, "source": "Alpha", "name": "ok", "data": {}}',
    '{"seq": 0, "t": 1.0, "source": "Alpha", "name": "ok", "data": {}}',
    '{"v": 1, "t": 1.0, "source": "Alpha", "name": "ok", "data": {}}',
    '{"v": 1, "seq": "0", "t": 1.0, "source": "Alpha", "name": "ok", "data": {}}',
    '{"v": 1, "seq": true, "t": 1.0, "source": "Alpha", "name": "ok", "data": {}}',
    '{"v": 1, "seq": 0, "t": "now", "source": "Alpha", "name": "ok", "data": {}}',
    '{"v": 1, "seq": 0, "t": NaN, "source": "Alpha", "name": "ok", "data": {}}',
    '{"v": 1, "seq": -1, "t": 1.0, "source": "Alpha", "name": "ok", "data": {}}',
    '{"v": 1, "seq": 0, "t": 1.0, "source": "Al pha", "name": "ok", "data": {}}',
    '{"v": 1, "seq": 0, "t": 1.0, "source": "Alpha", "name": "ok", "data": []}',
    '{"v": 1, "seq": 0, "t": 1.0, "source": "Alpha", "data": {}}',
]


def test_in_process_drops_malformed_events_and_the_mission_goes_on() -> None:
    # Every malformed message claims to be Alpha.ok; none may end A; the valid one at t=9
    # does. Nothing crashes.
    messages: list[tuple[float, Any]] = [(1 + i * 0.5, Raw(text))
                                         for i, text in enumerate(MALFORMED)]
    messages.append((9, ev(0, 9, "Alpha.ok")))
    h, outcome, vehicle = run_with("A()", messages)
    assert vehicle.dropped == len(MALFORMED)
    assert h.trace() == T("+Alpha", "Alpha.ok>", "-Alpha", "=ok")
    assert outcome.status == "ok" and outcome.time == 9
    h.assert_finished("ok")


def test_in_process_drops_an_invalid_action_instead_of_passing_it_on() -> None:
    stack = ListStack([])
    vehicle = InProcess(stack)
    vehicle.send(ActionMessage(0, 0.0, "m", "A@1:1", "explode", "Alpha", {}))
    vehicle.send(ActionMessage(1, float("nan"), "m", "A@1:1", "enable", "Alpha", {}))
    assert vehicle.dropped == 2 and stack.actions == []
    vehicle.send(ActionMessage(2, 0.0, "m", "A@1:1", "enable", "Alpha", {"x": [1, 2]}))
    assert vehicle.dropped == 2 and len(stack.actions) == 1


def test_runner_reports_a_mission_waiting_for_nothing_as_stuck() -> None:
    h, outcome, _ = run_with("A()", [])
    assert outcome.status == "stuck"  # and aborted through the net: nothing left on
    assert h.player.status == "fail" and h.on() == set()


def test_runner_jumps_to_timers_in_simulated_time() -> None:
    h, outcome, _ = run_with("Wait(5 s); A(); Wait(1.5 s)", [(6, ev(0, 6, "Alpha.ok"))])
    assert h.timed() == [(5.0, "enable", "Alpha"), (6.0, "disable", "Alpha")]
    assert outcome.status == "ok" and outcome.time == pytest.approx(7.5)
    h.assert_finished("ok")


# -- the AAL message schemas ---------------------------------------------------------------
GOOD_ACTION = {"v": 1, "seq": 17, "t": 12.503, "mission": "dam_inspection",
               "task": "GoTo@12:9", "kind": "enable", "behaviour": "GoTo",
               "params": {"x": 1.0}}
GOOD_EVENT = {"v": 1, "seq": 42, "t": 12.9, "source": "GoTo", "name": "reached", "data": {}}


def edited(d: dict[str, Any], **changes: Any) -> str:
    out = dict(d)
    for k, v in changes.items():
        if v is ...:
            out.pop(k)
        else:
            out[k] = v
    return json.dumps(out)


def test_valid_messages_round_trip() -> None:
    a = ActionMessage.from_json(json.dumps(GOOD_ACTION))
    assert a == ActionMessage(17, 12.503, "dam_inspection", "GoTo@12:9", "enable", "GoTo",
                              {"x": 1.0})
    assert ActionMessage.from_json(a.to_json()) == a
    e = EventMessage.from_json(json.dumps(GOOD_EVENT).encode())
    assert e.event == "GoTo.reached"
    assert EventMessage.from_json(e.to_json()) == e
    assert EventMessage.from_json(edited(GOOD_EVENT, t=3)).t == 3.0  # an int time is fine


BAD_ACTIONS = {
    "not JSON": "{",
    "not an object": '"enable"',
    "bytes not UTF-8": b"\xff\xfe{}",
    "wrong version": edited(GOOD_ACTION, v=2),
    "no version": edited(GOOD_ACTION, v=...),
    "missing seq": edited(GOOD_ACTION, seq=...),
    "missing params": edited(GOOD_ACTION, params=...),
    "seq a float": edited(GOOD_ACTION, seq=1.0),
    "seq a bool": edited(GOOD_ACTION, seq=False),
    "seq negative": edited(GOOD_ACTION, seq=-3),
    "t a string": edited(GOOD_ACTION, t="12"),
    "t infinite": json.dumps(GOOD_ACTION).replace("12.503", "Infinity"),
    "behaviour a number": edited(GOOD_ACTION, behaviour=3),
    "params a list": edited(GOOD_ACTION, params=[]),
    "unknown kind": edited(GOOD_ACTION, kind="explode"),
    "too large": edited(GOOD_ACTION, params={"x": "a" * 70_000}),
}
BAD_EVENTS = {
    "not JSON": "nope",
    "wrong version": edited(GOOD_EVENT, v="1"),
    "missing name": edited(GOOD_EVENT, name=...),
    "missing data": edited(GOOD_EVENT, data=...),
    "name a number": edited(GOOD_EVENT, name=7),
    "source not a name": edited(GOOD_EVENT, source="Go To"),
    "name with a dot": edited(GOOD_EVENT, name="reached.twice"),
    "data a string": edited(GOOD_EVENT, data="{}"),
    "t NaN": json.dumps(GOOD_EVENT).replace("12.9", "NaN"),
}


@pytest.mark.parametrize("text", list(BAD_ACTIONS.values()), ids=list(BAD_ACTIONS))
def test_invalid_actions_are_refused_with_invalid_message(text: str | bytes) -> None:
    with pytest.raises(InvalidMessage):
        ActionMessage.from_json(text)


@pytest.mark.parametrize("text", list(BAD_EVENTS.values()), ids=list(BAD_EVENTS))
def test_invalid_events_are_refused_with_invalid_message(text: str) -> None:
    with pytest.raises(InvalidMessage):
        EventMessage.from_json(text)


def test_invalid_message_says_which_field() -> None:
    with pytest.raises(InvalidMessage, match="'seq'"):
        EventMessage.from_json(edited(GOOD_EVENT, seq="x"))
    with pytest.raises(InvalidMessage, match="'params' is missing"):
        ActionMessage.from_json(edited(GOOD_ACTION, params=...))
    with pytest.raises(InvalidMessage, match="version"):
        ActionMessage.from_json(edited(GOOD_ACTION, v=0))


# -- the run log: RunLog and read_log --------------------------------------------------------
def test_run_log_round_trip_and_replay(tmp_path: Path) -> None:
    h = Harness(TRY)
    path = tmp_path / "run.jsonl"
    with RunLog(path, {"mission": "m", "net": net_digest(h.net), "params": {}}) as log:
        h.player.observers.append(log)
        drive(h, [(1, "Watch.alarm"), (2, "Beta.ok")])
    records = read_log(path)
    assert records[0]["kind"] == "header" and records[0]["format"] == FORMAT
    assert len(records) == len(h.records) + 1
    assert [r["kind"] for r in records[1:]] == [r.kind for r in h.records]
    assert check(h.net, records, {}).ok


# -- Hypothesis: random generic missions on random scripted vehicles -------------------------
# The shipped generic library (A()..D() end on Probe.ok / Probe.fail, Now() ends at once,
# Lamp(enable/disable) latch Lamp), and a variant in which A()..D() switch Probe on while
# they run, so that the scripted vehicle's on_enable answers for Probe reach them.
PROBING_TASKS = GENERIC_TASKS
for _name in "ABCD":
    PROBING_TASKS = PROBING_TASKS.replace(
        f"task {_name}() {{ ok: Probe.ok; fail: Probe.fail; }}",
        f"task {_name}() {{ start: enable Probe; ok: Probe.ok; fail: Probe.fail; "
        f"stop: disable Probe; }}")
assert PROBING_TASKS.count("enable Probe") == 4
LIBRARIES = {
    "generic": tasklib.load(["generic"]),
    "probing": tasklib.load_sources([Source("core.tasks", CORE_TASKS),
                                     Source("probing.tasks", PROBING_TASKS)]),
}
AT_EVENTS = ["Probe.ok"] * 4 + ["Probe.fail"] * 3 + ["Mission.abort", "Link.lost", "Lamp.on",
                                                    "Other.thing"]

# MCL_PROPERTY_SCALE=20 multiplies the example count (a longer bug hunt, new examples)
SCALE = float(os.environ.get("MCL_PROPERTY_SCALE", "1"))
HYPOTHESIS = settings(deadline=None, max_examples=max(1, round(300 * SCALE)),
                      derandomize=SCALE == 1,
                      suppress_health_check=[HealthCheck.too_slow,
                                             HealthCheck.filter_too_much])


def may_loop_without_events(block: ast.Block) -> bool:
    """True if a WHILE inside may go round without any event (a livelock, which mclc
    refuses and the player stops after a million firings): over-approximated."""
    bad = False

    def instant(b: ast.Block) -> set[str]:
        """Statuses a block may end with, from its start, with no event (no abort)."""
        nonlocal bad
        match b:
            case ast.Call(name=n):
                return {"ok"} if n in ("Now", "Lamp") else set()
            case ast.Sequence(items=items):
                sets = [instant(i) for i in items]
                return sets[-1] if all(sets) else set()
            case ast.TryCatchDo(try_=t, catch=c, do=d):
                ts, cs, ds = instant(t), instant(c), instant(d)
                return ts | (ds if cs else set())
            case ast.ParallelAnd(branches=bs):
                sets = [instant(x) for x in bs]
                if not all(sets):
                    return set()
                return ({"ok"} if all("ok" in s for s in sets) else set()) | \
                    ({"fail"} if any("fail" in s for s in sets) else set())
            case ast.ParallelOr(branches=bs):
                return set().union(*[instant(x) for x in bs])
            case ast.IfThenElse(condition=c, then=a, else_=e):
                cs, as_ = instant(c), instant(a)
                es = instant(e) if e is not None else {"fail"}
                return (as_ if "ok" in cs else set()) | (es if "fail" in cs else set())
            case ast.WhileDo(condition=c, body=body):
                cs, bs = instant(c), instant(body)
                if "ok" in cs and "ok" in bs:
                    bad = True
                return ({"ok"} if "fail" in cs else set()) | \
                    ({"fail"} if "ok" in cs and "fail" in bs else set())
        raise AssertionError(b)

    instant(block)
    return bad


def waits_for_events(mission: ast.Mission) -> bool:
    """At least one task that waits (A..D), so that events matter."""
    return any(c.name in "ABCD" for c in ast.calls(mission.body))


@st.composite
def scripted_vehicles(draw: st.DrawFn) -> str:
    """A scripted vehicle as TOML text: random on_enable answers for Probe and Lamp, random
    [[at]] events."""
    lines = []
    for behaviour, names in (("Probe", ["ok", "fail"]), ("Lamp", ["on", "ok"])):
        answers = draw(st.lists(st.tuples(st.sampled_from([0.0, 0.5, 1.0, 2.0, 3.5]),
                                          st.sampled_from(names)), max_size=2))
        if answers:
            items = ", ".join(f'{{ after = {a}, event = "{e}" }}' for a, e in answers)
            lines += [f"[behaviours.{behaviour}]", f"on_enable = [{items}]", ""]
    for t, event in draw(st.lists(st.tuples(st.sampled_from([0.0, 0.5, 1.0, 1.5, 2.0, 3.0,
                                                             5.0, 8.0]),
                                            st.sampled_from(AT_EVENTS)),
                                 min_size=1, max_size=12)):
        lines += ["[[at]]", f"time = {t}", f'event = "{event}"', ""]
    return "\n".join(lines)


def run_logged(net: Net, script_text: str, folder: Path) -> tuple[Player, Any, Path]:
    (folder / "vehicle.toml").write_text(script_text, "utf-8")
    vehicle = InProcess(ScriptedVehicle(load_script(str(folder / "vehicle.toml"))))
    player = Player(net)
    log_path = folder / "run.jsonl"
    with RunLog(log_path, {"mission": "m", "net": net_digest(net), "params": {}}) as log, \
            vehicle, mock.patch.object(petri.player, "MAX_IMMEDIATE_FIRINGS", 20_000):
        player.observers.append(log)
        outcome = run(player, vehicle, "m", max_time=100, max_rounds=400)
    return player, outcome, log_path


def edits(records: list[dict[str, Any]], finished: bool, rnd: random.Random
          ) -> list[tuple[str, list[dict[str, Any]]]]:
    """Edited copies of a log, each of which must be refused."""
    out = []
    fires = [i for i, r in enumerate(records) if r["kind"] == "fire"]
    drop = rnd.choice(fires) if finished else fires[0]
    out.append((f"drop fire line {drop + 1}", records[:drop] + records[drop + 1:]))
    i = rnd.choice(fires)
    renamed = [dict(r) for r in records]
    renamed[i]["transition"] = renamed[i]["transition"] + "x"
    out.append((f"rename line {i + 1}", renamed))
    # (the last line of defence's actions are left out: see the xfail test below)
    actions = [i for i, r in enumerate(records) if r["kind"] == "action"
               and r.get("task") != "MISSION"]
    if actions:
        i = rnd.choice(actions)
        changed = [dict(r) for r in records]
        changed[i]["params"] = {**changed[i]["params"], "edited": 1}
        out.append((f"params line {i + 1}", changed))
    return out


def write_lines(path: Path, records: list[dict[str, Any]]) -> None:
    path.write_text("".join(json.dumps({k: v for k, v in r.items() if k != "_line"}) + "\n"
                            for r in records), "utf-8")


@HYPOTHESIS
@given(mission=st.one_of(S.generic_missions(max_depth=3, max_calls=8, lamps="paired"),
                         S.generic_missions(max_depth=2, max_calls=6, lamps="free")
                         ).filter(waits_for_events),
       library=st.sampled_from(sorted(LIBRARIES)),
       script=scripted_vehicles(), seed=st.integers(0, 2**16))
def test_random_missions_on_random_vehicles_replay_as_conformant(
        mission: ast.Mission, library: str, script: str, seed: int) -> None:
    assume(not may_loop_without_events(mission.body))
    text = printer.mission(mission)
    net = compile_source(Source("random.mcl", text), library=LIBRARIES[library]).net
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        player, outcome, log_path = run_logged(net, script, folder)
        records = read_log(log_path)
        result = check(net, records, {})
        assert result.ok, (text, script, result.line, result.reason)
        assert outcome.status in ("ok", "fail", "stuck", "timeout"), outcome
        statistic(f"outcome {outcome.status}")
        statistic(f"{len(list(ast.calls(mission.body)))} calls")
        statistic(f"{sum(r['kind'] == 'event' for r in records)} events fired")
        # stuck and timeout runs are aborted through the net (issue 12): all end finished
        assert player.finished and player.behaviours_on == {}, (text, script, outcome)
        if outcome.status in ("ok", "fail"):
            assert outcome.status == player.status
            if mission_is_paired(mission):
                # every Lamp(enable) has its Lamp(disable): the net itself switched it off
                # (by the pair or by an abort); no last line of defence, a proper final
                marking = {i: n for i, n in enumerate(player.marking) if n}
                assert marking in net.finals, net.describe_marking(marking)
                notes = [r for r in records if r["kind"] == "note" and
                         "switching off" in r.get("note", "")]
                assert not notes, (text, script)

        # determinism: the same vehicle, the same log (but for the file name)
        again = folder / "again"
        again.mkdir()
        run_logged(net, script, again)
        assert (again / "run.jsonl").read_text() == log_path.read_text()

        # a log cut mid-line is refused, whatever line is cut
        raw = log_path.read_bytes()
        rnd = random.Random(seed)
        cut = rnd.randrange(1, len(raw) - 1)
        while raw[cut - 1:cut] == b"\n":
            cut -= 1
        (folder / "cut.jsonl").write_bytes(raw[:cut])
        with pytest.raises(LogError, match=r"cut\.jsonl:\d+"):
            read_log(folder / "cut.jsonl")

        # edited logs are reported non-conformant, naming a line
        for what, edited_records in edits(records, player.finished, rnd):
            path = folder / "edited.jsonl"
            write_lines(path, edited_records)
            verdict = check(net, read_log(path), {})
            assert not verdict.ok, (what, text, script)
            assert verdict.line is not None and verdict.reason


def mission_is_paired(mission: ast.Mission) -> bool:
    """Every Lamp(enable) is followed later in its own sequence by a Lamp(disable)."""
    def ok(b: ast.Block) -> bool:
        if isinstance(b, ast.Call):
            return not (b.name == "Lamp" and b.args[0].value == ast.Ref("enable"))
        if isinstance(b, ast.Sequence):
            names = [printer.call(i) if isinstance(i, ast.Call) else "" for i in b.items]
            pending = 0
            for item, name in zip(b.items, names):
                if name == "Lamp(enable)":
                    pending += 1
                elif name == "Lamp(disable)":
                    pending = 0
                elif not ok(item):
                    return False
            return pending == 0
        return all(ok(c) for c in ast.children(b))
    return ok(mission.body)


@pytest.mark.parametrize("edit", ["params", "behaviour", "extra"])
def test_replay_refuses_an_edited_last_line_of_defence(edit: str) -> None:
    h = Harness("Light(enable); A()").start(0)
    h.event("Alpha.ok", 1)
    records = log_records(h.net, h.records)
    assert check(h.net, records, {}).ok
    i = next(i for i, r in enumerate(records) if r["kind"] == "action" and
             r["task"] == "MISSION")
    if edit == "params":
        records[i] = {**records[i], "params": {"edited": 1}}
    elif edit == "behaviour":
        records[i] = {**records[i], "behaviour": "Beta"}  # Beta was never on
    else:
        records.insert(i + 1, {**records[i], "behaviour": "Gamma"})
    assert not check(h.net, records, {}).ok


def test_the_livelock_filter_knows_the_obvious_cases() -> None:
    def body(text: str) -> ast.Block:
        from mcl.parser import parse
        return parse(Source("x.mcl", f"MISSION {{ {text} }}")).body
    assert may_loop_without_events(body("WHILE { Now() } DO { Lamp(disable) }"))
    assert may_loop_without_events(body("WHILE { PARALLEL { A() } OR { Now() } } DO { Now() }"))
    assert not may_loop_without_events(body("WHILE { A() } DO { Now() }"))
    assert not may_loop_without_events(body("WHILE { Now() } DO { B() }"))
