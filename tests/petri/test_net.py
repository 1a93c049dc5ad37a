"""petri/net.py on its own: building a place/transition net and the views of it.

A tiny hand-made net (no MCL): places with roles, transitions with weighted arcs given as a
list (repeats add up) or as a dict, and what the verifier and the player read back: effects,
the initial vector, markings in words, the JSON description, the trigger place of each
transition, and action parameters resolved at run time.
"""

from __future__ import annotations

import json

import numpy as np
import pytest

from petri.net import (
    BEGIN,
    INNER,
    OK,
    RUN,
    Action,
    Net,
    Origin,
    Transition,
    resolve,
    triggers,
)


def _net() -> Net:
    """begin -> (start) -> run ×2 -> (finish, weight 2) -> ok; run -> (timeout) -> ok."""
    net = Net("tiny", dofs={"GoTo": ("x", "y")})
    begin = net.add_place("begin", role=BEGIN)
    run = net.add_place("run", ("GoTo",), Origin("m.mcl", 3, 5, "GoTo(p)", "task"), RUN)
    ok = net.add_place("ok", role=OK)
    net.add_transition("start", [begin], [run, run],
                       actions=(Action("enable", "GoTo", (("x", 1.0),)),), label="start")
    net.add_transition("finish", {run: 2}, [ok], event="GoTo.reached",
                       actions=(Action("disable", "GoTo"),))
    net.add_transition("timeout", [run], [ok], timer=2.5)
    net.initial = {begin: 1}
    net.finals = [{ok: 1}]
    return net


def test_places_are_numbered_in_order_and_found_by_name_and_role() -> None:
    net = _net()
    assert [p.name for p in net.places] == ["begin", "run", "ok"]
    assert [net.place(n) for n in ("begin", "run", "ok")] == [0, 1, 2]
    assert net.places_with(RUN) == [1] and net.places_with(BEGIN, OK) == [0, 2]
    assert net.places[0].role == BEGIN and net.add_place("x") == 3
    assert net.places[3].role == INNER and net.places[3].behaviours == ()
    with pytest.raises(KeyError):
        net.place("nowhere")


def test_a_place_name_is_used_once() -> None:
    net = _net()
    with pytest.raises(ValueError, match="duplicate place name 'run'"):
        net.add_place("run")


def test_arcs_from_lists_count_repeats_and_from_dicts_keep_weights() -> None:
    net = Net("arcs")
    a, b, c = (net.add_place(n) for n in "abc")
    assert net.add_transition("t0", [b, a], [c]) == 0
    net.add_transition("t1", [a, a, b], {c: 3, a: 0})
    net.add_transition("t2", [], [a])
    t0, t1, t2 = net.transitions
    assert t0.inputs == ((a, 1), (b, 1))  # sorted by place
    assert t1.inputs == ((a, 2), (b, 1)) and t1.outputs == ((c, 3),)  # weight 0: no arc
    assert (t2.inputs, t2.outputs) == ((), ((a, 1),))
    assert net.arc_count() == 2 + 1 + 2 + 1 + 0 + 1


def test_effect_is_the_non_zero_change_of_a_firing() -> None:
    net = _net()
    run, ok = net.place("run"), net.place("ok")
    assert net.effect(0) == {0: -1, run: 2}
    assert net.effect(1) == {run: -2, ok: 1}
    loop = Net("loop")
    p = loop.add_place("p")
    loop.add_transition("self", [p], [p])
    assert loop.effect(0) == {}


def test_a_transition_without_event_or_timer_is_immediate() -> None:
    start, finish, timeout = _net().transitions
    assert start.immediate and not finish.immediate and not timeout.immediate
    assert Transition("t", (), (), timer="maxTime").immediate is False


def test_initial_vector_and_markings_in_words() -> None:
    net = _net()
    vector = net.initial_vector()
    assert vector.dtype == np.int64 and vector.tolist() == [1, 0, 0]
    assert net.describe_marking({0: 1}) == "{begin}"
    assert net.describe_marking({1: 2, 2: 1}) == "{run×2, ok}"
    assert net.describe_marking(np.array([0, 2, 1])) == "{run×2, ok}"
    assert net.describe_marking({}) == "{}"


def test_to_dict_describes_the_whole_net_as_json() -> None:
    d = _net().to_dict()
    assert json.loads(json.dumps(d)) == d
    assert d["name"] == "tiny" and d["dofs"] == {"GoTo": ["x", "y"]}
    assert d["places"][1] == {"name": "run", "behaviours": ["GoTo"], "role": RUN, "origin": {
        "file": "m.mcl", "line": 3, "col": 5, "text": "GoTo(p)", "kind": "task"}}
    start, finish, timeout = d["transitions"]
    assert start["inputs"] == {"begin": 1} and start["outputs"] == {"run": 2}
    assert start["actions"] == [{"kind": "enable", "behaviour": "GoTo", "params": {"x": 1.0}}]
    assert (finish["inputs"], finish["event"], finish["timer"]) == (
        {"run": 2}, "GoTo.reached", None)
    assert timeout["timer"] == 2.5 and timeout["origin"] is None
    assert d["initial"] == {"begin": 1} and d["finals"] == [{"ok": 1}]


def test_an_action_reads_as_it_is_sent() -> None:
    assert str(Action("disable", "GoTo")) == "disable GoTo"
    assert str(Action("enable", "GoTo", (("x", 1.5), ("mode", "fast")))) == (
        "enable GoTo(x=1.5, mode=fast)")
    long = str(Action("configure", "Path", (("path", list(range(30))),)))
    value = long.removeprefix("configure Path(path=").removesuffix(")")
    assert len(value) == 40 and value.endswith("...")


def test_origin_where_is_file_line_col() -> None:
    assert Origin("dam.mcl", 12, 7).where() == "dam.mcl:12:7"


@pytest.mark.parametrize("value,params,expected", [
    (3.0, {}, 3.0),  # a literal as it is
    ([1, 2], {"p": 9}, [1, 2]),
    ({"param": "d"}, {"d": 2.5}, 2.5),
    ({"param": "d"}, {}, None),  # no value there
    ({"param": "p", "field": "z"}, {"p": [1.0, 2.0, 3.0, 90.0]}, 3.0),
    ({"param": "p", "field": "yaw"}, {"p": [1.0, 2.0]}, None),  # a point without yaw
    ({"param": "p", "field": "x"}, {"p": 5.0}, None),  # not a point
    ({"key": "not a parameter"}, {}, {"key": "not a parameter"}),
])
def test_resolve_an_action_parameter(value: object, params: dict[str, object],
                                     expected: object) -> None:
    assert resolve(value, params) == expected


def test_triggers_pick_the_input_read_by_the_fewest_transitions() -> None:
    net = Net("latch")
    off, a, b = (net.add_place(n) for n in ("off", "a", "b"))
    net.add_transition("ta", [off, a], [off])
    net.add_transition("tb", [off, b], [off])
    net.add_transition("tc", [b, off], [off])
    net.add_transition("source", [], [a])
    # readers: off 3, a 1, b 2
    assert triggers(net) == [a, b, b, -1]
    net.add_transition("tab", [a, b], [off])  # readers: off 3, a 2, b 3: a tie goes to off
    assert triggers(net) == [a, off, off, -1, a]
