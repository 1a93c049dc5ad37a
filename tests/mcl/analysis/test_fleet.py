"""The fleet proof under loss: the product net, its properties, its counterexamples (which
interleave the vehicles' lines and replay on the players) and the compositional route."""

from __future__ import annotations

import pytest

from mcl.analysis.fleet import product
from mcl.analysis.fleet_replay import ReplayError, replay, visited
from mcl.analysis.fleet_verification import PROPERTIES, verify_fleet
import numpy as np

from petri.verification.reachability import StateSpace, explore
from petri.verification.verdict import Result
from mcl.fleet import CompiledFleet
from tests.mcl.analysis.fleet_missions import (ASV_ALWAYS_SENDS, ASV_MAY_NOT_SEND,
                                               UUV_NO_SURFACING, UUV_WAITS, fleet, fleet_text,
                                               where)


def results(f: CompiledFleet, method: str = "explicit") -> dict[str, Result]:
    verdict = verify_fleet(f, method)
    return {r.name: r for r in verdict.results}


def test_the_product_keeps_every_vehicle_and_adds_two_places_per_link() -> None:
    f = fleet()
    fnet = product(f)
    own = sum(len(c.net.places) for c in f.vehicles.values())
    # release and fix to uuv, and "not waiting" for each of uuv's two Receives
    assert len(fnet.net.places) == own + 2 * 2 + 2
    waits = [p.name for p in fnet.net.places if p.name.endswith("(not waiting)")]
    assert len(waits) == 2 and all(w.startswith("uuv/Receive@") for w in waits)
    assert all(p.name.split("/")[0] in ("asv", "uuv") for p in fnet.net.places[:own])
    sends = [t for t in fnet.net.transitions if any(a.kind == "send" for a in t.actions)]
    assert len(sends) == 4  # two sends, each from an empty and from a full link
    losses = [s for s in fnet.steps if s.kind == "lose"]
    assert len(losses) == 2
    assert not [s for s in product(fleet(lossy=False, every=False)).steps if s.kind == "lose"]
    dropped = [s for s in product(fleet(lossy=False)).steps if s.kind == "lose"]
    assert len(dropped) == 2  # EVERY 2 s: a message too close to the previous one is dropped


def test_a_guided_vehicle_that_surfaces_when_the_guide_is_silent_is_proved() -> None:
    verdict = verify_fleet(fleet(), "explicit")
    assert [r.name for r in verdict.results] == list(PROPERTIES)
    assert verdict.ok, [(r.name, r.message) for r in verdict.results if not r.holds]
    assert verdict.markings > 1000


def test_removing_the_surfacing_fails_with_both_vehicles_lines() -> None:
    f = fleet(uuv=UUV_NO_SURFACING)
    verdict = verify_fleet(f, "explicit")
    failed = {r.name: r for r in verdict.results if r.status == "fails"}
    assert {"fleet-silence", "fleet-nothing-on-at-end"} <= set(failed)
    r = failed["fleet-silence"]
    assert "AchieveHeadDist" in r.message  # KeepHeadDist's latched behaviour
    text = fleet_text(uuv=UUV_NO_SURFACING)
    lines = verdict.lines(r.counterexample or [])
    assert f"asv {where(text, 'Send(guide, release)')} Send(guide, release): start and end" \
        in lines
    receive = "Receive(guide, release, timeout = 5 min)"
    assert f"uuv {where(text, receive)} {receive}: guide.release → ok (delivered: " \
        "guide.release)" in lines
    fix = "Receive(guide, fix, timeout = 10 s)"
    assert f"uuv {where(text, fix)} {fix}: timeout 10 s → fail" in lines
    players = replay(verdict.fleet, r.counterexample or [])
    assert "AchieveHeadDist" in players["uuv"].behaviours_on
    as_json = verdict.to_json()["properties"]
    steps = next(p for p in as_json if p["property"] == "fleet-silence")["counterexample"]
    assert {"asv", "uuv"} <= {s["vehicle"] for s in steps}


def test_a_vehicle_waiting_for_ever_on_a_reliable_channel_is_shown() -> None:
    f = fleet(ASV_MAY_NOT_SEND, UUV_WAITS, lossy=False, every=False)
    verdict = verify_fleet(f, "explicit")
    r = next(r for r in verdict.results if r.name == "fleet-no-deadlock")
    text = fleet_text(ASV_MAY_NOT_SEND, UUV_WAITS, lossy=False, every=False)
    at = where(text, "Receive(guide, release)")
    assert r.status == "fails" and f"Receive@{at.split(':', 1)[1]}" in r.message
    lines = verdict.lines(r.counterexample or [])
    assert any(x.startswith(f"asv {where(text, 'Surface()')} Surface()") for x in lines)
    players = replay(verdict.fleet, r.counterexample or [])
    assert players["asv"].rules.end_status(players["asv"].marking) == "ok"
    assert players["uuv"].rules.end_status(players["uuv"].marking) is None


def test_a_message_heard_by_no_one_is_ignored_and_the_wait_shown_endless() -> None:
    # the guide always sends, but in the untimed product its message may reach the vehicle
    # before the vehicle waits for it: the player ignores an event nobody waits for
    f = fleet(ASV_ALWAYS_SENDS, UUV_WAITS, lossy=False, every=False)
    verdict = verify_fleet(f, "explicit")
    r = next(r for r in verdict.results if r.name == "fleet-no-deadlock")
    assert r.status == "fails"
    lines = verdict.lines(r.counterexample or [])
    assert "channel guide: release reaches uuv, where no Receive waits: ignored" in lines
    players = replay(verdict.fleet, r.counterexample or [])
    assert players["uuv"].rules.end_status(players["uuv"].marking) is None
    # alone, the guided vehicle may never get its message: never a verdict, undecided
    alone = results(f, "compositional")
    assert alone["fleet-no-deadlock"].status == "undecided"
    assert "uuv alone" in alone["fleet-no-deadlock"].message
    assert alone["fleet-terminates"].status == "undecided"


def test_the_compositional_route_proves_the_good_fleet_and_never_fails() -> None:
    good = results(fleet(), "compositional")
    assert all(r.status == "holds" for r in good.values())
    bad = results(fleet(uuv=UUV_NO_SURFACING), "compositional")
    statuses = {r.status for r in bad.values()}
    assert "fails" not in statuses and "undecided" in statuses


def test_auto_takes_the_compositional_route_when_the_product_is_over_budget() -> None:
    verdict = verify_fleet(fleet(), "auto", max_bytes=200_000)
    assert verdict.note.startswith("auto:") and "compositional" in verdict.note
    assert all(r.method.startswith(("compositional", "each vehicle")) for r in verdict.results)
    small = verify_fleet(fleet(), "auto")
    assert small.note == "" and small.markings > 1000


@pytest.mark.slow  # a cut search goes on in numba's engine: its first compilation, ~1.5 s
def test_a_cut_product_decides_nothing_that_holds() -> None:
    verdict = verify_fleet(fleet(), "explicit", max_markings=500)
    statuses = {r.name: r.status for r in verdict.results}
    assert statuses["fleet-can-end"] == "undecided"
    assert statuses["fleet-nothing-on-at-end"] == "undecided"
    # a violation seen before the cut stands
    f = fleet(ASV_MAY_NOT_SEND, UUV_WAITS, lossy=False, every=False)
    bad = verify_fleet(f, "explicit", max_markings=85)  # of 91
    statuses = {r.name: r.status for r in bad.results}
    assert bad.markings == 85 and statuses["fleet-no-deadlock"] == "fails"
    assert statuses["fleet-can-end"] == "undecided"


def test_every_joint_state_a_replayed_run_visits_is_in_the_verified_graph() -> None:
    f = fleet()
    fnet = product(f)
    ss = explore(fnet.net)
    assert ss.complete
    # walk a long run of the product (the BFS path to its last marking) on the players
    path = []
    row = ss.n_markings - 1
    assert ss.parent is not None and ss.parent_transition is not None
    while row > 0:
        path.append(int(ss.parent_transition[row]))
        row = int(ss.parent[row])
    path.reverse()
    for k in range(len(path) + 1):
        players = replay(fnet, path[:k])
        assert visited(ss, fnet, {v: p.marking for v, p in players.items()})
    # a joint state no run reaches: both vehicles at their initial marking but uuv ended
    players = replay(fnet, [])
    ended = list(players["uuv"].marking)
    ended[next(iter(players["uuv"].rules.ends))] = 1
    assert not visited(ss, fnet, {"asv": players["asv"].marking, "uuv": ended})


def test_a_reception_without_its_message_does_not_replay() -> None:
    fnet = product(fleet())
    receive = next(t for t, s in enumerate(fnet.steps) if s.kind == "vehicle" and s.link)
    with pytest.raises(ReplayError):
        replay(fnet, [receive])


def test_two_receives_of_one_message_waiting_at_once_leave_it_undecided() -> None:
    both = """
            PARALLEL { Receive(guide, fix, timeout = 10 s) }
            AND { Receive(guide, fix, timeout = 10 s) }"""
    statuses = {r.status for r in verify_fleet(fleet(uuv=both), "explicit").results}
    assert "holds" not in statuses and "undecided" in statuses


def test_a_message_is_not_ignored_while_a_receive_waits_for_it() -> None:
    fnet = product(fleet())
    ss = explore(fnet.net)
    ignore = next(t for t, s in enumerate(fnet.steps)
                  if s.kind == "ignore" and s.link and s.link.message == "release")
    # a run where release is in flight while uuv waits for it: ignore is not enabled there
    path = shortest_path_to(fnet, ss, ignore)
    players = replay(fnet, path)
    waiting = players["uuv"].rules.waiting["guide.release"]
    assert not any(players["uuv"].enabled(u) for u in waiting)
    receive = next(t for t, s in enumerate(fnet.steps) if s.kind == "vehicle" and s.link
                   and s.link.message == "release")
    with pytest.raises(ReplayError):
        replay(fnet, shortest_path_to(fnet, ss, receive) + [ignore])


def shortest_path_to(fnet: object, ss: StateSpace, t: int) -> list[int]:
    """The BFS path to the nearest marking from which ``t`` fires."""
    arcs = np.flatnonzero(ss.transition == t)
    row = int(ss.src[arcs].min())
    assert ss.parent is not None and ss.parent_transition is not None
    path = []
    while row > 0:
        path.append(int(ss.parent_transition[row]))
        row = int(ss.parent[row])
    return path[::-1]


def test_a_loop_that_only_a_message_ends_is_a_lasso_that_replays() -> None:
    # the guide may end without sending; the vehicle circles until it hears it
    circles = """
            PARALLEL { WHILE { Wait(1 s) } DO { Wait(1 s) } } OR { Receive(guide, release) };
            Surface()"""
    f = fleet(ASV_MAY_NOT_SEND, circles, lossy=False, every=False)
    verdict = verify_fleet(f, "explicit")
    r = next(r for r in verdict.results if r.name == "fleet-can-end")
    assert r.status == "fails" and r.cycle, r.message
    assert r.message.startswith("the fleet can go round for ever: uuv goes round")
    cycle = verdict.lines(r.cycle)
    assert all(x.startswith("uuv ") for x in cycle)
    assert any("Wait(1 s)" in x for x in cycle)
    prefix = verdict.lines(r.counterexample or [])
    assert any(x.startswith("asv ") and "Surface()" in x for x in prefix)
    players = replay(verdict.fleet, (r.counterexample or []) + r.cycle * 3)
    assert players["uuv"].rules.end_status(players["uuv"].marking) is None
    # no end can be reached from the loop: some run never ends
    term = next(r for r in verdict.results if r.name == "fleet-terminates")
    assert term.status == "fails" and term.cycle == r.cycle
