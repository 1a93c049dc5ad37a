"""The loop that runs the player (petri/execution/runner.py) against vehicle stacks that send duplicated,
out-of-order and delayed events, through the in-process adapter: events kept or dropped by
seq, batches in order, simulated time jumping to timers, and a mission waiting for nothing
reported as stuck. The harness and ListStack are in tests/harness.py.
"""

from __future__ import annotations

import pytest

from tests.harness import TRY, T, ev, run_with


# -- the runner: duplicated and out-of-order messages ----------------------------------------
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


def test_runner_reports_a_mission_waiting_for_nothing_as_stuck() -> None:
    h, outcome, _ = run_with("A()", [])
    assert outcome.status == "stuck"  # and aborted through the net: nothing left on
    assert h.player.status == "fail" and h.on() == set()


def test_runner_jumps_to_timers_in_simulated_time() -> None:
    h, outcome, _ = run_with("Wait(5 s); A(); Wait(1.5 s)", [(6, ev(0, 6, "Alpha.ok"))])
    assert h.timed() == [(5.0, "enable", "Alpha"), (6.0, "disable", "Alpha")]
    assert outcome.status == "ok" and outcome.time == pytest.approx(7.5)
    h.assert_finished("ok")
