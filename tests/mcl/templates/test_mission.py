"""mcl/templates/mission.py: the root the player starts and may stop from outside.

The mission starts its body and ends as the body ends; the event ``Mission.abort`` (the
operator, or a Link.lost no block catches) aborts the body, waits for it, switches every
latch off, and ends fail — or, with ``ON STOP``, runs the stop handler, which a second stop
halts.
"""

from __future__ import annotations

from diagnostics import Source
from mcl.api import compile_source
from mcl.templates.mission import ABORT_EVENT, HALT, STOP_FAIL, STOP_OK, STOP_START
from petri.net import BEGIN, END_FAIL, END_OK, STOP_HANDLER, Net
from petri.semantics import MISSION_ABORT
from petri.verification.properties import verify
from tests.mcl.templates.nets import GENERIC, absorbed, arcs, compiled, names


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


# -- ON STOP: the stop handler (issue 21) ------------------------------------------------------
def with_handler(body: str, handler: str) -> Net:
    """``compiled`` with ``ON STOP { handler }``: the handler's block starts at 3:13."""
    text = f"MISSION {{\n  {body}\n}} ON STOP {{ {handler} }}\n"
    return compile_source(Source("m.mcl", text), library=GENERIC).net


def test_with_a_handler_the_stop_runs_it_once_the_body_has_stopped() -> None:
    net = with_handler("Lamp(enable); A(); Lamp(disable)", "B()")
    # the body's abort, its latches off, then (not MISSION.fail) the stopped place
    assert absorbed(net, "MISSION.stop", "SEQ@1:9", "MISSION.stopping") == ["MISSION.cleanup"]
    assert arcs(net, "MISSION.off.Lamp.on@2:3") == (["Lamp.on@2:3", "MISSION.cleanup"],
                                                    ["Lamp.off", "MISSION.stopped"])
    assert arcs(net, STOP_START) == (["MISSION.stopped"], ["B@3:13.begin",
                                                           "MISSION.stop_handler"])
    assert arcs(net, STOP_OK) == (["B@3:13.ok", "MISSION.stop_handler"], ["MISSION.fail"])
    assert arcs(net, STOP_FAIL) == (["B@3:13.fail", "MISSION.stop_handler"], ["MISSION.fail"])
    roles = {p.name: p.role for p in net.places}
    assert roles["MISSION.stop_handler"] == STOP_HANDLER


def test_a_second_stop_halts_the_handler() -> None:
    net = with_handler("A()", "B()")
    aborts = [t.name for t in net.transitions if t.event == ABORT_EVENT]
    assert aborts == ["MISSION.abort", HALT]
    assert arcs(net, HALT) == (["MISSION.stop_handler"], ["B@3:13.abort", "MISSION.halting"])
    assert absorbed(net, HALT, "B@3:13", "MISSION.halting") == ["MISSION.fail"]


def test_with_a_handler_every_property_holds_and_the_stop_is_safe() -> None:
    verdict = verify(with_handler("Lamp(enable); PARALLEL { A() } AND { B() }; Lamp(disable)",
                                  "C(); D()"))
    statuses = {r.name: r.status for r in verdict.results}
    assert statuses["stop-safe"] == "holds" and statuses["behaviours-off-at-end"] == "holds"
    assert verdict.ok, [r for r in verdict.results if not r.holds]


def test_a_mission_without_a_handler_compiles_as_before() -> None:
    net = compiled("A()")
    assert not [p for p in net.places if p.role == STOP_HANDLER]
    assert not names(net, "MISSION.on_stop") and not names(net, HALT)
