"""The real-time player (petri/execution/player.py), trace by trace: sequence, TRY / CATCH / DO,
PARALLEL AND / OR, IF, WHILE, timers, latched behaviours, aborts at awkward moments, events
nobody waits for, and determinism. The harness, its trace notation T() and the task library
are in tests/harness.py.

Every trace test also checks that the run ended with no behaviour on and the net in a proper
final marking, and that its records, written as a run log, replay as conformant.
"""

from __future__ import annotations

import pytest

from petri.execution.player import Record
from tests.harness import TRY, Harness, T, drive, without_notes


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


# -- the outbox: what leaves the player for the vehicle -------------------------------------
def orders(h: Harness) -> list[tuple[float, str, str, str]]:
    """The outbox, drained: (t, kind, behaviour, task) of each order, oldest first."""
    out = []
    while h.player.outbox:
        o = h.player.outbox.popleft()
        out.append((o.t, o.kind, o.behaviour, o.task))
    return out


def action_records(h: Harness, since: int = 0) -> list[tuple[float, str, str, str]]:
    return [(r.t, r.data["action"], r.data["behaviour"], r.data["task"])
            for r in h.records[since:] if r.kind == "action"]


def test_orders_leave_through_the_outbox_in_the_order_they_are_decided() -> None:
    # The alarm stops A and starts B in one instant: the outbox holds exactly the actions
    # the records report, in the same order, after each call (nobody else sends them).
    h = Harness(TRY).start(0)
    assert orders(h) == action_records(h) == [(0, "enable", "Alpha", "A@2:7"),
                                              (0, "enable", "Watch", "Watch@2:21")]
    seen = len(h.records)
    h.event("Watch.alarm", 1)
    sent = orders(h)
    assert [(kind, b) for _, kind, b, _ in sent] == [
        ("disable", "Watch"), ("disable", "Alpha"), ("enable", "Beta")]
    assert sent == action_records(h, seen)
    assert orders(h) == []  # drained
    seen = len(h.records)
    h.event("Beta.ok", 2)
    assert orders(h) == action_records(h, seen) == [(2, "disable", "Beta", "B@2:36")]
    h.assert_finished("ok")


def test_an_observer_that_raises_cannot_leave_the_net_half_fired() -> None:
    # A(); Wait(2 s); B(): an observer (a run log on a full disk) raises on the firing that
    # Alpha.ok causes. That firing and the whole call still complete: Alpha's disable is in
    # the outbox, Wait's timer is armed from t = 1, the observer after it saw every record;
    # then the error reaches the caller, once.
    h = Harness("A(); Wait(2 s); B()").start(0)

    def full_disk(record: Record) -> None:
        if record.kind == "fire" and record.data["cause"] == "Alpha.ok":
            raise OSError(28, "No space left on device")

    h.player.observers.insert(0, full_disk)
    with pytest.raises(OSError, match="No space left"):
        h.event("Alpha.ok", 1)
    assert h.player.behaviours_on == {}
    assert h.player.next_deadline() == pytest.approx(3.0)
    assert h.trace()[-2:] == [("event", "Alpha.ok"), ("disable", "Alpha")]
    assert orders(h) == [(0, "enable", "Alpha", "A@2:1"), (1, "disable", "Alpha", "A@2:1")]
    h.player.settle(3)  # no error left over: the player goes on from a whole state
    assert orders(h) == [(3, "enable", "Beta", "B@2:17")]
    h.event("Beta.ok", 4)
    h.assert_finished("ok")


def test_an_observer_that_raises_during_the_abort_does_not_stop_the_abort() -> None:
    # The safe exit must finish: every block stopped, the latch off, the mission ended fail,
    # whatever the observers do; then the observer's error propagates.
    h = Harness("Light(enable); A()").start(0)

    def broken(record: Record) -> None:
        raise RuntimeError("observer broke")

    h.player.observers.insert(0, broken)
    with pytest.raises(RuntimeError, match="observer broke"):
        h.player.abort(1, "operator")
    assert h.player.status == "fail" and h.player.behaviours_on == {}
    assert sorted(b for _, kind, b, _ in orders(h) if kind == "disable") == ["Alpha", "Light"]
    h.player.observers.remove(broken)
    h.assert_conformant()


def test_note_ignored_records_an_event_that_fires_nothing() -> None:
    h = Harness("A()").start(0)
    fired = h.player.fired
    h.player.note_ignored("Alpha.ok", 1, "seq 3 after 5: duplicate or out of order")
    assert h.player.fired == fired and h.player.status == "running"
    assert h.records[-1].kind == "ignored"
    assert h.records[-1].data == {"event": "Alpha.ok",
                                  "reason": "seq 3 after 5: duplicate or out of order"}


# -- the cleanup: the last line of defence as a typed record --------------------------------
def test_the_switch_off_at_the_end_is_a_cleanup_record_before_its_disables() -> None:
    # Light is latched and never unlatched: at the end the player switches it off itself,
    # saying so in a ``cleanup`` record that names it, then the disable (task MISSION).
    h = Harness("Light(enable); A()").start(0)
    h.event("Alpha.ok", 1)
    kinds = [(r.kind, r.data.get("behaviours") or r.data.get("behaviour")) for r in h.records
             if r.kind in ("cleanup", "action", "status")][-4:]
    assert kinds == [("action", "Alpha"), ("cleanup", ["Light"]), ("action", "Light"),
                     ("status", None)]
    last = [r for r in h.records if r.kind == "action"][-1]
    assert last.data == {"action": "disable", "behaviour": "Light", "params": {},
                         "task": "MISSION"}
    h.assert_finished("ok", defence=True)


def test_a_mission_the_net_switches_off_itself_has_no_cleanup_record() -> None:
    h = Harness("Light(enable); A(); Light(disable)").start(0)
    h.event("Alpha.ok", 1)
    assert not [r for r in h.records if r.kind == "cleanup"]
    h.assert_finished("ok")
