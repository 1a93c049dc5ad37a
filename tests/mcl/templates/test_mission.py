"""mcl/templates/mission.py: the root the player starts and may stop from outside.

The mission starts its body and ends as the body ends; the event ``Mission.abort`` (the
operator, or a Link.lost no block catches) aborts the body, waits for it, switches every
latch off, and ends fail.
"""

from __future__ import annotations

from mcl.templates.mission import ABORT_EVENT
from petri.net import BEGIN, END_FAIL, END_OK
from petri.semantics import MISSION_ABORT
from petri.verification.properties import verify
from tests.mcl.templates.nets import absorbed, arcs, compiled


def test_the_mission_starts_its_body_and_ends_as_it_ends() -> None:
    net = compiled("A()")
    assert arcs(net, "MISSION.start") == (["MISSION.begin"], ["A@2:3.begin", "MISSION.running"])
    assert arcs(net, "MISSION.ok") == (["A@2:3.ok", "MISSION.running"], ["MISSION.ok"])
    assert arcs(net, "MISSION.fail") == (["A@2:3.fail", "MISSION.running"], ["MISSION.fail"])
    roles = {p.name: p.role for p in net.places if p.name.startswith("MISSION.")}
    assert (roles["MISSION.begin"], roles["MISSION.ok"], roles["MISSION.fail"]) == (
        BEGIN, END_OK, END_FAIL)


def test_the_external_stop_aborts_the_body_and_ends_fail() -> None:
    assert ABORT_EVENT == MISSION_ABORT == "Mission.abort"
    net = compiled("A()")
    aborts = [t for t in net.transitions if t.event == ABORT_EVENT]
    assert [t.name for t in aborts] == ["MISSION.abort"]
    assert arcs(net, "MISSION.abort") == (["MISSION.running"],
                                          ["A@2:3.abort", "MISSION.stopping"])
    assert absorbed(net, "MISSION.stop", "A@2:3", "MISSION.stopping") == ["MISSION.fail"]


def test_with_latches_the_stop_switches_them_off_before_failing() -> None:
    net = compiled("Lamp(enable); A(); Lamp(disable)")
    assert absorbed(net, "MISSION.stop", "SEQ@1:9", "MISSION.stopping") == ["MISSION.cleanup"]
    assert arcs(net, "MISSION.off.Lamp.on@2:3") == (["Lamp.on@2:3", "MISSION.cleanup"],
                                                    ["Lamp.off", "MISSION.fail"])


def test_the_mission_is_named_after_its_name_in_the_origin() -> None:
    net = compiled("A()")
    start = next(t for t in net.transitions if t.name == "MISSION.start")
    assert start.origin is not None
    assert (start.origin.text, start.origin.kind, start.origin.line) == ("MISSION", "MISSION", 1)


def test_the_stop_is_safe_from_every_marking() -> None:
    verdict = verify(compiled("Lamp(enable); PARALLEL { A() } AND { B() }; Lamp(disable)"))
    assert {r.name: r.status for r in verdict.results}["stop-safe"] == "holds"
    assert verdict.ok
