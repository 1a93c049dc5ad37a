"""The loop that runs the player (petri/execution/runner.py) against vehicle stacks that send duplicated,
out-of-order and delayed events, through the in-process adapter: events kept or dropped by
seq, batches in order, simulated time jumping to timers, and a mission waiting for nothing
reported as stuck. The harness and ListStack are in tests/harness.py.
"""

from __future__ import annotations

import pytest

from diagnostics import Source
from mcl.api import compile_source
from petri.execution.player import MAX_FIRINGS_PER_INSTANT, Order, Player, Record
from petri.execution.runner import Outcome, run
from tests.harness import TRY, Harness, ListStack, T, ev, run_with
from vehicle.scripted import ScriptedVehicle, parse_script
from vehicle_adapters.inprocess import InProcess


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


# -- the player's outbox, drained by the runner -----------------------------------------------
def test_the_runner_sends_the_outbox_in_order_and_leaves_the_observers_alone() -> None:
    # What reaches the vehicle is exactly the action records, in their order, numbered by
    # seq; the observers are the ones the caller gave (the runner adds none of its own).
    h, outcome, vehicle = run_with(TRY, [(5, ev(0, 5, "Watch.alarm")),
                                         (6, ev(1, 6, "Beta.ok"))])
    assert outcome.status == "ok"
    assert h.player.observers == [h.records.append]
    assert not h.player.outbox
    stack = vehicle.stack
    assert isinstance(stack, ListStack)
    sent = [(a.t, a.kind, a.behaviour, a.task, a.params) for a in stack.actions]
    assert sent == [(r.t, r.data["action"], r.data["behaviour"], r.data["task"],
                     r.data["params"]) for r in h.records if r.kind == "action"]
    assert [a.seq for a in stack.actions] == list(range(len(sent)))
    assert [(kind, b) for _, kind, b, _, _ in sent] == [
        ("enable", "Alpha"), ("enable", "Watch"), ("disable", "Watch"), ("disable", "Alpha"),
        ("enable", "Beta"), ("disable", "Beta")]


def test_an_observer_that_raises_stops_the_run_safely_with_the_net_whole() -> None:
    # A run log on a full disk: from t = 2 every record it is given raises. The firing under
    # way completes, the runner stops the run through the net's abort (which completes too),
    # and every behaviour is switched off on the vehicle; the outcome says why.
    h = Harness("Light(enable); A(); Wait(10 s)")
    seen: list[tuple[float, str]] = []

    def full_disk(record: Record) -> None:
        if record.t >= 2:
            raise OSError(28, "No space left on device")
        seen.append((record.t, record.kind))

    h.player.observers.append(full_disk)
    vehicle = InProcess(ListStack([(2, ev(0, 2, "Alpha.ok"))]))
    outcome = run(h.player, vehicle, "m", max_time=1000)
    assert outcome.status == "error" and "No space left" in outcome.reason, outcome
    assert outcome.time == 2
    assert h.player.finished and h.player.behaviours_on == {}
    stack = vehicle.stack
    assert isinstance(stack, ListStack)
    assert [(a.kind, a.behaviour) for a in stack.actions] == [
        ("enable", "Light"), ("enable", "Alpha"), ("disable", "Alpha"), ("disable", "Light")]
    assert sorted(outcome.switched_off) == ["Light"]
    assert seen and max(t for t, _ in seen) < 2
    h.assert_conformant()  # the records (the other observer's) are a legal run


# -- a loop that goes round without time passing (issue 21) ----------------------------------
SPIN = "MISSION spin { WHILE { GoTo((-1, 0, 1, 0)) } DO { Surface() } }"
AT_ONCE = {"behaviours": {"GoTo": {"on_enable": {"after": 0.0, "event": "reached"}},
                          "Surface": {"on_enable": {"after": 0.0, "event": "surfaced"}}}}


def spin_run(bound: int | None) -> tuple[Player, Outcome, list[Order]]:
    """The spinning loop on a scripted vehicle that answers at once, with ``bound`` firings
    at one instant (None: the player's default); returns the orders the vehicle got too."""
    compiled = compile_source(Source("spin.mcl", SPIN), require_values=True)
    player = Player(compiled.net) if bound is None else Player(
        compiled.net, max_firings_per_instant=bound)
    stack = ScriptedVehicle(parse_script(AT_ONCE))
    got: list[Order] = []
    player.observers.append(lambda r: got.append(Order(r.t, r.data["task"], r.data["action"],
                                                       r.data["behaviour"], {}))
                            if r.kind == "action" else None)
    outcome = run(player, InProcess(stack), "spin", max_time=60.0)
    return player, outcome, got


@pytest.mark.parametrize("bound", [None, 50, 1000])
def test_a_loop_that_spins_at_one_instant_is_stopped_past_the_bound(bound: int | None) -> None:
    # Reproduces issue 21: the loop fired 375,908 times at mission time 0, and --max-time
    # could not stop it since mission time never moved.
    player, outcome, got = spin_run(bound)
    limit = bound if bound is not None else MAX_FIRINGS_PER_INSTANT
    assert outcome.status == "zeno" and outcome.time == 0.0
    assert player.zeno is not None and f"more than {limit:,} firings at 0 s" in player.zeno
    assert outcome.reason == player.zeno
    # the bound, plus the few firings of the abort itself
    assert limit <= player.fired <= limit + 20, player.fired
    assert player.status == "fail" and not player.behaviours_on  # stopped through the abort
    on = {o.behaviour for o in got if o.kind == "enable"} - {
        o.behaviour for o in got if o.kind == "disable"}
    assert not on  # whatever the loop switched on was switched off
    assert set(outcome.switched_off) <= {"GoTo", "Surface"}


def test_the_bound_does_not_touch_a_mission_whose_time_passes() -> None:
    # The same loop on a vehicle that takes 1 s to answer: 60 s of mission time, about 60
    # rounds, well under a bound of 50 firings per instant; it ends at the time limit.
    compiled = compile_source(Source("spin.mcl", SPIN), require_values=True)
    player = Player(compiled.net, max_firings_per_instant=50)
    slow = {"behaviours": {b: {"on_enable": {"after": 1.0, "event": e}}
                           for b, e in (("GoTo", "reached"), ("Surface", "surfaced"))}}
    outcome = run(player, InProcess(ScriptedVehicle(parse_script(slow))), "spin",
                  max_time=60.0)
    assert outcome.status == "timeout" and player.zeno is None
    assert player.fired > 50
