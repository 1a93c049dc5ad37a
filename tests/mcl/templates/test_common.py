"""mcl/templates/common.py: what every template shares.

A latch's states and the subset the latch analysis allows; unique names for blocks at the same
place; the five interface places of a block with their roles; absorbing an abort (the child took
it, or had already ended); and the cleanup chain an aborted block runs to switch off, one
behaviour after the other, the latches switched on inside it.
"""

from __future__ import annotations

from diagnostics import Source, Span
from mcl import tasklib
from mcl.api import compile_source
from mcl.checker import check_mission
from mcl.parser import parse
from mcl.templates.common import Context, Latch
from petri.net import ABORT, ABORTED, BEGIN, FAIL, OK, Action, Net, Origin
from tests.harness import LIBRARY  # Light and Cam latch; A() .. D() wait for events
from tests.mcl.templates.nets import arcs


def _context() -> Context:
    source = Source("m.mcl", "MISSION { A() }")
    checked = check_mission(parse(source), tasklib.load(["generic"]), source)
    return Context(Net("n"), checked)


def test_a_latch_s_states_are_off_then_each_call_site() -> None:
    latch = Latch("Lamp", off=0, sites={101: 4, 102: 7}, by_site={"2:3": 4, "5:9": 7})
    assert latch.states() == [0, 4, 7]
    assert latch.among(None) == [0, 4, 7]  # no analysis: any state
    assert latch.among(frozenset({("Lamp", "off")})) == [0]
    assert latch.among(frozenset({("Lamp", "5:9"), ("Lamp", "off"), ("Cam", "1:1")})) == [0, 7]
    assert latch.among(frozenset({("Lamp", "9:9")})) == [0, 4, 7]  # unknown: assume any


def test_names_of_blocks_at_the_same_place_are_made_unique() -> None:
    ctx = _context()
    span = Span("m.mcl", 3, 5)
    assert [ctx.prefix("SEQ", span) for _ in range(3)] == ["SEQ@3:5", "SEQ@3:5#2", "SEQ@3:5#3"]
    assert ctx.prefix("TRY", span) == "TRY@3:5"


def test_an_interface_is_five_places_with_their_roles() -> None:
    ctx = _context()
    origin = ctx.origin(Span("m.mcl", 2, 3), "A()", "task")
    assert origin == Origin("m.mcl", 2, 3, "A()", "task")
    io = ctx.interface("A@2:3", origin)
    places = ctx.net.places
    assert [(places[i].name, places[i].role) for i in
            (io.begin, io.abort, io.ok, io.fail, io.aborted)] == [
        ("A@2:3.begin", BEGIN), ("A@2:3.abort", ABORT), ("A@2:3.ok", OK),
        ("A@2:3.fail", FAIL), ("A@2:3.aborted", ABORTED)]
    assert all(p.origin == origin for p in places)


def test_absorb_takes_the_abort_whether_the_child_took_it_or_had_ended() -> None:
    ctx = _context()
    origin = ctx.origin(Span("m.mcl", 1, 1), "X", "SEQ")
    child = ctx.interface("C", origin)
    waiting, done = ctx.place("wait"), ctx.place("done")
    ctx.absorb(child, waiting, [done], "P", origin)
    net = ctx.net
    assert [t.name for t in net.transitions] == ["P.stopped", "P.late_ok", "P.late_fail"]
    assert arcs(net, "P.stopped") == (["C.aborted", "wait"], ["done"])
    assert arcs(net, "P.late_ok") == (["C.abort", "C.ok", "wait"], ["done"])
    assert arcs(net, "P.late_fail") == (["C.abort", "C.fail", "wait"], ["done"])


def test_an_aborted_block_switches_its_latches_off_one_after_the_other() -> None:
    net = compile_source(Source("m.mcl", "MISSION {\n  Light(enable); Cam(enable); A(); "
                                "Cam(disable); Light(disable)\n}\n"), library=LIBRARY).net
    s = "SEQ@1:9"
    # Cam first (sorted by name), then Light; each either on from its call, or off already
    assert arcs(net, f"{s}.off.Cam.on@2:18") == (["Cam.on@2:18", f"{s}.cleanup"],
                                                 ["Cam.off", f"{s}.cleanup1"])
    assert arcs(net, f"{s}.keep.Cam.off") == (["Cam.off", f"{s}.cleanup"],
                                              ["Cam.off", f"{s}.cleanup1"])
    assert arcs(net, f"{s}.off.Light.on@2:3") == (["Light.on@2:3", f"{s}.cleanup1"],
                                                  ["Light.off", f"{s}.aborted"])
    assert arcs(net, f"{s}.keep.Light.off") == (["Light.off", f"{s}.cleanup1"],
                                                ["Light.off", f"{s}.aborted"])
    by_name = {t.name: t for t in net.transitions}
    assert by_name[f"{s}.off.Cam.on@2:18"].actions == (Action("disable", "Cam"),)
    assert by_name[f"{s}.keep.Cam.off"].actions == ()
    # the mission's own cleanup ends in its fail place
    assert arcs(net, "MISSION.off.Light.on@2:3")[1] == ["Light.off", "MISSION.fail"]


def test_a_block_without_latches_inside_reports_aborted_directly() -> None:
    net = compile_source(Source("m.mcl", "MISSION {\n  Light(enable); PARALLEL { A() } OR "
                                "{ B() }; Light(disable)\n}\n"), library=LIBRARY).net
    assert arcs(net, "OR@2:18.abort_joined")[1] == ["OR@2:18.aborted"]
    assert not [p for p in net.places if p.name.startswith("OR@2:18.cleanup")]
