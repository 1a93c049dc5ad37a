"""mcl/compiler.py on its own: a checked mission -> its Petri net, one template per construct.

The shape of each template (places and transitions it adds, as a function of its number of
items or branches) is written here from the diagrams in mcl/templates/*.py, and checked
construct by construct, then on random missions (Hypothesis) as the sum over their blocks.
Then what the player needs on the transitions: actions with values in base units, events,
timers (a per-call timeout replaces the declared fail timeout), parameters left to run time,
and the latches' state machines.
"""

from __future__ import annotations

from collections import Counter

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from diagnostics import Source
from mcl import ast, tasklib
from mcl.checker import check_mission
from mcl.compiler import compile_mission
from mcl.parser import parse
from petri.net import (
    ABORT,
    ABORTED,
    BEGIN,
    END_FAIL,
    END_OK,
    FAIL,
    LATCH_OFF,
    LATCH_ON,
    OK,
    RUN,
    Action,
    Net,
)
from tests import strategies as S

GENERIC = tasklib.load(["generic"])  # A() .. D() wait for Probe.ok / Probe.fail; Now() does not
ICTINEU = tasklib.load()


def _net(text: str, library: tasklib.Library = GENERIC) -> Net:
    source = Source("m.mcl", text)
    return compile_mission(check_mission(parse(source), library, source))


def _body(body: str) -> Net:
    return _net(f"MISSION {{ {body} }}")


# -- the shape of each template --------------------------------------------------------------
MISSION_SHAPE = (5, 7)  # begin, ok, fail, running, stopping; start, ok, fail, abort, 3 to absorb


def shape(block: ast.Block) -> tuple[int, int]:
    """(places, transitions) that the template of ``block`` itself adds (not its children)."""
    match block:
        case ast.Call(name=name):
            return (5, 1) if name == "Now" else (6, 4)  # + run; start, ok, fail, abort
        case ast.Sequence(items=items):
            n = len(items)  # a run and a stop place per item; after ok|fail, abort, absorb
            return 5 + 2 * n, 1 + 6 * n
        case ast.TryCatchDo():
            return 15, 31
        case ast.ParallelAnd(branches=bs):
            n = len(bs)
            return 9 + 3 * n, 6 + 7 * n
        case ast.ParallelOr(branches=bs):
            n = len(bs)
            return 9 + 2 * n, 7 + 5 * n
        case ast.IfThenElse(else_=other):
            return (9, 13) if other is None else (11, 19)
        case ast.WhileDo():
            return 9, 13
    raise TypeError(block)


KIND = {ast.Call: "task", ast.Sequence: "SEQ", ast.TryCatchDo: "TRY", ast.ParallelAnd: "AND",
        ast.ParallelOr: "OR", ast.IfThenElse: "IF", ast.WhileDo: "WHILE"}


@pytest.mark.parametrize("body,kind,places,transitions", [
    ("A()", "task", 6, 4),
    ("Now()", "task", 5, 1),
    ("A(); B()", "SEQ", 9, 13),
    ("A(); B(); C()", "SEQ", 11, 19),
    ("TRY { A() } CATCH { B() } DO { C() }", "TRY", 15, 31),
    ("PARALLEL { A() } AND { B() }", "AND", 15, 20),
    ("PARALLEL { A() } AND { B() } AND { C() }", "AND", 18, 27),
    ("PARALLEL { A() } OR { B() }", "OR", 13, 17),
    ("PARALLEL { A() } OR { B() } OR { C() }", "OR", 15, 22),
    ("IF { A() } THEN { B() } ELSE { C() }", "IF", 11, 19),
    ("IF { A() } THEN { B() }", "IF", 9, 13),
    ("WHILE { A() } DO { B() }", "WHILE", 9, 13),
])
def test_each_construct_adds_its_places_and_transitions(body: str, kind: str, places: int,
                                                        transitions: int) -> None:
    net = _body(body)
    own_places = Counter(p.origin.kind for p in net.places if p.origin)
    own_transitions = Counter(t.origin.kind for t in net.transitions if t.origin)
    assert (own_places[kind], own_transitions[kind]) == (places, transitions)
    assert (own_places["MISSION"], own_transitions["MISSION"]) == MISSION_SHAPE
    m = parse(Source("m.mcl", f"MISSION {{ {body} }}"))
    assert shape(m.body) == (places, transitions)  # the formula agrees with the table


def test_every_block_has_one_place_of_each_interface_role() -> None:
    net = _body("TRY { A(); Now() } CATCH { PARALLEL { B() } OR { C() } } DO { "
                "IF { A() } THEN { B() } ELSE { WHILE { C() } DO { D() } } }")
    blocks = Counter(p.name.rsplit(".", 1)[0] for p in net.places if p.role == BEGIN
                     and not p.name.startswith("MISSION"))
    assert len(blocks) == 13  # TRY, SEQ, A, Now, OR, B, C, IF, A, B, WHILE, C, D
    for block in blocks:
        roles = [p.role for p in net.places if p.name.rsplit(".", 1)[0] == block
                 and p.role in (BEGIN, ABORT, OK, FAIL, ABORTED)]
        assert sorted(roles) == sorted([BEGIN, ABORT, OK, FAIL, ABORTED]), block
    runs = [p.name for p in net.places if p.role == RUN]
    assert len(runs) == 7  # the seven tasks that wait (not Now())


def test_the_mission_starts_marked_and_ends_in_ok_or_fail() -> None:
    net = _body("A()")
    index = {p.name: i for i, p in enumerate(net.places)}
    assert net.initial == {index["MISSION.begin"]: 1}
    assert net.finals == [{index["MISSION.ok"]: 1}, {index["MISSION.fail"]: 1}]
    assert [p.name for p in net.places if p.role in (END_OK, END_FAIL)] == [
        "MISSION.ok", "MISSION.fail"]
    assert [t.name for t in net.transitions if t.event == "Mission.abort"] == ["MISSION.abort"]
    assert net.name == "mission" and _net("MISSION dam { A() }").name == "dam"


def test_the_net_takes_the_degrees_of_freedom_of_the_library() -> None:
    assert _body("A()").dofs == {"Probe": (), "Lamp": ()}
    net = _net("MISSION { Surface() }", ICTINEU)
    assert net.dofs["GoTo"] == ("x", "y", "z", "yaw") and net.dofs["Surface"] == ("z",)


def test_names_and_origins_say_where_each_part_comes_from() -> None:
    net = _net("MISSION {\n  A();\n  TRY { B() } CATCH { C() } DO { D() }\n}\n")
    assert len({p.name for p in net.places}) == len(net.places)
    assert len({t.name for t in net.transitions}) == len(net.transitions)
    by_name = {t.name: t for t in net.transitions}
    assert by_name["A@2:3.start"].origin is not None
    assert by_name["A@2:3.start"].origin.where() == "m.mcl:2:3"
    assert by_name["A@2:3.start"].origin.text == "A()"
    assert by_name["TRY@3:3.start"].label == "start TRY and CATCH"
    try_origin = by_name["TRY@3:3.start"].origin
    assert try_origin is not None and (try_origin.line, try_origin.col, try_origin.kind) == (
        3, 3, "TRY")


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.builds(ast.Mission, st.none(), S.bodies(
    st.sampled_from([ast.Call("A", ()), ast.Call("B", ()), ast.Call("Now", ())]),
    max_depth=3, max_calls=8)))
def test_a_random_mission_is_the_sum_of_its_templates(mission: ast.Mission) -> None:
    source = Source("m.mcl", "")
    net = compile_mission(check_mission(mission, GENERIC, source))
    blocks = ast.walk(mission.body)
    places = sum(shape(b)[0] for b in blocks) + MISSION_SHAPE[0]
    transitions = sum(shape(b)[1] for b in blocks) + MISSION_SHAPE[1]
    assert (len(net.places), len(net.transitions)) == (places, transitions)
    kinds = Counter(KIND[type(b)] for b in blocks)
    assert Counter(p.role for p in net.places)[BEGIN] == sum(kinds.values()) + 1
    assert Counter(p.role for p in net.places)[RUN] == sum(
        1 for b in blocks if isinstance(b, ast.Call) and b.name != "Now")


# -- what the transitions carry ----------------------------------------------------------------
def _transitions(text: str) -> dict[str, tuple[list[Action], str | None, float | str | None]]:
    net = _net(text, ICTINEU)
    return {t.name: (list(t.actions), t.event, t.timer) for t in net.transitions}


def test_a_task_sends_its_start_and_stop_actions_in_base_units() -> None:
    ts = _transitions("MISSION {\n  GoTo((1 m, 20 cm, 3 m, 1 rad), tolerance = 1 km)\n}\n")
    goto = {k.removeprefix("GoTo@2:3."): v for k, v in ts.items() if k.startswith("GoTo@")}
    assert set(goto) == {"start", "ok.GoTo.reached", "fail.GoTo.failed", "timeout", "abort"}
    (start,), event, timer = goto["start"]
    assert (start.kind, start.behaviour, event, timer) == ("enable", "GoTo", None, None)
    params = dict(start.params)
    assert params.keys() == {"x", "y", "z", "yaw", "tolerance"}
    assert params["x"] == 1.0 and params["y"] == pytest.approx(0.2)
    assert params["yaw"] == pytest.approx(57.29577951308232)  # degrees
    assert params["tolerance"] == 1000.0
    stop = [Action("disable", "GoTo")]
    assert goto["ok.GoTo.reached"] == (stop, "GoTo.reached", None)
    assert goto["fail.GoTo.failed"] == (stop, "GoTo.failed", None)
    assert goto["timeout"] == (stop, None, 600.0)  # the library's 10 min -> fail
    assert goto["abort"] == (stop, None, None)


def test_a_per_call_timeout_replaces_the_declared_fail_timeout() -> None:
    net = _net("MISSION {\n  GoTo((0, 0, 0, 0), timeout = 2 min)\n}\n", ICTINEU)
    timers = [(t.name, t.timer) for t in net.transitions if t.timer is not None]
    assert timers == [("GoTo@2:3.timeout", 120.0)]
    index = {p.name: i for i, p in enumerate(net.places)}
    timeout = next(t for t in net.transitions if t.name == "GoTo@2:3.timeout")
    assert timeout.outputs == ((index["GoTo@2:3.fail"], 1),)


def test_timers_of_wait_and_timeout_end_ok_and_fail() -> None:
    net = _net("MISSION {\n  Wait(1.5 min);\n  Timeout(500 ms)\n}\n", ICTINEU)
    index = {p.name: i for i, p in enumerate(net.places)}
    timers = {t.name: (t.timer, t.outputs) for t in net.transitions if t.timer is not None}
    assert timers == {"Wait@2:3.timeout": (90.0, ((index["Wait@2:3.ok"], 1),)),
                      "Timeout@3:3.timeout": (0.5, ((index["Timeout@3:3.fail"], 1),))}


def test_a_parameter_without_value_is_left_for_the_player_to_fill_in() -> None:
    ts = _transitions("PARAM p;\nPARAM t;\nMISSION {\n  GoTo(p);\n  Wait(t)\n}\n")
    (start,), _, _ = ts["GoTo@4:3.start"]
    assert dict(start.params) == {
        "x": {"param": "p", "field": "x"}, "y": {"param": "p", "field": "y"},
        "z": {"param": "p", "field": "z"}, "yaw": {"param": "p", "field": "yaw"},
        "tolerance": 0.5}
    assert ts["Wait@5:3.timeout"] == ([], None, "t")


def test_a_running_task_holds_the_behaviours_it_enables() -> None:
    net = _net("MISSION {\n  PARALLEL { GoTo((0, 0, 0, 0)) } OR { Alarms() }\n}\n", ICTINEU)
    held = {p.name: p.behaviours for p in net.places if p.role == RUN}
    assert held == {"GoTo@2:14.run": ("GoTo",), "Alarms@2:40.run": ("Alarms",)}


def test_a_latched_behaviour_gets_an_off_place_and_an_on_place_per_call_site() -> None:
    net = _body("Lamp(enable); A(); Lamp(disable)")
    index = {p.name: i for i, p in enumerate(net.places)}
    latch = [(p.name, p.role, p.behaviours) for p in net.places
             if p.role in (LATCH_OFF, LATCH_ON)]
    assert latch == [("Lamp.off", LATCH_OFF, ()), ("Lamp.on@1:11", LATCH_ON, ("Lamp",))]
    off, on = index["Lamp.off"], index["Lamp.on@1:11"]
    assert net.initial == {index["MISSION.begin"]: 1, off: 1}
    assert net.finals == [{index["MISSION.ok"]: 1, off: 1}, {index["MISSION.fail"]: 1, off: 1}]
    by_name = {t.name: t for t in net.transitions}
    switch_on = by_name["Lamp@1:11.from.Lamp.off"]
    assert switch_on.actions == (Action("enable", "Lamp"),)
    assert dict(switch_on.inputs).keys() == {off, index["Lamp@1:11.begin"]}
    assert dict(switch_on.outputs).keys() == {on, index["Lamp@1:11.ok"]}
    # the latch analysis knows only "on from 1:11" can hold when Lamp(disable) runs
    offs = [t for t in by_name if t.startswith("Lamp@1:30.from.")]
    assert offs == ["Lamp@1:30.from.Lamp.on@1:11"]
    assert by_name[offs[0]].actions == (Action("disable", "Lamp"),)
    # an abort switches it off on the way out (the mission's and the sequence's cleanup)
    cleanup = [t.name for t in net.transitions if Action("disable", "Lamp") in t.actions
               and ".off." in t.name]
    assert cleanup == ["SEQ@1:9.off.Lamp.on@1:11", "MISSION.off.Lamp.on@1:11"]
