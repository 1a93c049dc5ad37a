"""petri/verification/properties.py on its own: ``verify`` and each property it decides.

For every property, a tiny mission (or, for what the compiler never produces, a hand-made
net) on which it holds and one on which it fails, with the counterexample's first and last
firings. Every counterexample is replayed with the firing rule (petri/semantics.py): each
step must be enabled, and it must reach the marking the verdict names; a lasso's loop must
come back to where it started. Then the verdict as a whole: ok / failed / undecided, a cut
exploration, and the JSON the commands print.
"""

from __future__ import annotations

import json

import pytest

from diagnostics import Source
from mcl import tasklib
from mcl.api import compile_source
from petri.net import BEGIN, END_FAIL, END_OK, RUN, Action, Net
from petri.semantics import Semantics
from petri.verification.properties import Result, Verdict, verify

GENERIC = tasklib.load(["generic"])  # core timers, A() .. D(), Now(), Lamp(enable|disable)
# Behaviours that share a degree of freedom, a watcher, a latch: what the properties are about.
LIBRARY = tasklib.load_sources([
    Source("core.tasks", "task Wait(duration: duration) { timeout: duration -> ok; }\n"),
    Source("lib.tasks", """
behaviour B0 drives x events ok;
behaviour B1 drives x events ok;
behaviour W events ok;
task T0() { start: enable B0; ok: B0.ok; stop: disable B0; }
task T1() { start: enable B1; ok: B1.ok; stop: disable B1; }
task Watch() { start: enable W; ok: W.ok; stop: disable W; }
task L(enable) { start: enable B0; latch: B0; }
task L(disable) { start: disable B0; unlatch: B0; }
""")])

PROPERTIES = ["one-safe", "proper-completion", "no-deadlock", "terminates", "can-end",
              "no-zeno", "instant-loop", "behaviours-off-at-end", "behaviour-single-owner", "dof-exclusive",
              "no-disable-while-held", "stop-safe", "actions-match-behaviours",
              "no-dead-transitions"]
WARNINGS = {"instant-loop", "no-dead-transitions"}  # the properties of severity "warning"


def _mission(body: str, library: tasklib.Library = GENERIC) -> Net:
    return compile_source(Source("m.mcl", f"MISSION {{\n  {body}\n}}\n"), library=library).net


def _results(net: Net, **kw: int) -> dict[str, Result]:
    return {r.name: r for r in verify(net, **kw).results}


def _names(net: Net, steps: list[int] | None) -> list[str]:
    assert steps is not None
    return [net.transitions[t].name for t in steps]


def _replay(net: Net, steps: list[int], marking: list[int] | None = None) -> list[int]:
    rules = Semantics(net)
    marking = rules.initial() if marking is None else list(marking)
    for i, t in enumerate(steps):
        assert rules.enabled(marking, t), f"step {i + 1} ({net.transitions[t].name}) disabled"
        rules.fire(marking, t)
    return marking


def _check_counterexample(net: Net, verdict: Verdict, r: Result) -> list[int]:
    """Replay ``r``'s counterexample (and loop): it reaches the marking the verdict names."""
    assert r.counterexample is not None and r.witness is not None
    reached = _replay(net, r.counterexample)
    assert net.describe_marking(dict(enumerate(reached))) == verdict.witness_text(r.witness)
    if r.cycle is not None:
        assert r.cycle and _replay(net, r.cycle, reached) == reached
    return reached


def _failing(net: Net, name: str) -> tuple[Result, list[str]]:
    verdict = verify(net)
    r = next(x for x in verdict.results if x.name == name)
    assert r.status == "fails" and verdict.failed and not verdict.ok
    _check_counterexample(net, verdict, r)
    return r, _names(net, r.counterexample)


# -- each property on a mission where it holds ---------------------------------------------
def test_every_property_holds_on_a_plain_task_and_is_reported_in_order() -> None:
    verdict = verify(_mission("A()"))
    assert [r.name for r in verdict.results] == PROPERTIES
    assert all(r.status == "holds" and r.counterexample is None for r in verdict.results)
    assert verdict.ok and not verdict.failed and not verdict.undecided
    assert verdict.dead_transitions == []
    assert {r.severity for r in verdict.results if r.name not in WARNINGS} == {"error"}
    assert verdict.markings == 12  # begin, running, A begin/run/ok/fail, abort paths, ends


@pytest.mark.parametrize("body,library", [
    ("Lamp(enable); A(); Lamp(disable)", GENERIC),  # behaviours-off-at-end
    ("WHILE { A() } DO { Wait(1 s) }", GENERIC),  # can-end, no-zeno: the condition can fail
    ("PARALLEL { Watch() } AND { Watch() }", LIBRARY),  # a watcher may be shared
    ("T0(); T1()", LIBRARY),  # two behaviours on x, one after the other
    ("L(enable); Wait(1 s); L(disable)", LIBRARY),  # an unlatch with no task holding B0
])
def test_every_error_property_holds_on_a_sound_mission(body: str,
                                                       library: tasklib.Library) -> None:
    verdict = verify(_mission(body, library))
    expected = {name: "holds" for name in PROPERTIES if name not in WARNINGS}
    if "WHILE" in body:  # a plain net's graph rule: a reachable cycle is a run for ever
        expected["terminates"] = "fails"
    assert {r.name: r.status for r in verdict.results if r.severity == "error"} == expected
    assert verdict.ok == ("WHILE" not in body)


# -- each property on a mission where it fails ---------------------------------------------
def test_behaviours_off_at_end_fails_on_a_latch_left_on() -> None:
    net = _mission("Lamp(enable)")
    r, steps = _failing(net, "behaviours-off-at-end")
    assert r.message == "the mission can end with Lamp still on"
    assert steps == ["MISSION.start", "Lamp@2:3.from.Lamp.off", "MISSION.ok"]


def test_can_end_fails_on_a_loop_whose_condition_never_fails_with_a_lasso() -> None:
    net = _mission("WHILE { Now() } DO { Wait(1 s) }")
    r, steps = _failing(net, "can-end")
    assert "the WHILE at line 2 cannot end: its condition `Now()` can never fail" in r.message
    assert steps == ["MISSION.start", "WHILE@2:3.start"]
    loop = _names(net, r.cycle)
    assert (loop[0], loop[-1]) == ("Now@2:11.do", "WHILE@2:3.body_ok")
    assert _results(net)["no-zeno"].holds  # each round waits 1 s


def test_no_zeno_fails_on_a_loop_that_takes_no_time() -> None:
    net = _mission("WHILE { Now() } DO { Wait(0 s) }")
    r, steps = _failing(net, "no-zeno")
    assert r.message.startswith("the WHILE at line 2 can go round without time passing")
    assert steps == ["MISSION.start", "WHILE@2:3.start"]
    assert "Wait@2:24.timeout" in _names(net, r.cycle)


def test_instant_loop_warns_of_a_loop_that_events_close_at_once() -> None:
    net = _mission("WHILE { A() } DO { B() }")
    verdict = verify(net)
    r = next(x for x in verdict.results if x.name == "instant-loop")
    assert (r.status, r.severity) == ("fails", "warning")
    assert r.message.startswith("the WHILE at line 2 can go round with no mission time "
                                "passing: a lap can be closed by Probe.ok alone")
    assert "Probe.ok" in [net.transitions[t].event for t in r.cycle or []]
    assert _results(net)["no-zeno"].holds  # events are not instant to no-zeno
    # a lap that waits 1 s takes time, however fast the events come
    assert _results(_mission("WHILE { A() } DO { B(); Wait(1 s) }"))["instant-loop"].holds


def test_behaviour_single_owner_fails_on_one_behaviour_held_by_two_tasks() -> None:
    net = _mission("PARALLEL { T0() } AND { T0() }", LIBRARY)
    r, steps = _failing(net, "behaviour-single-owner")
    assert r.message.startswith("B0 can be held on by two tasks at once")
    assert (steps[0], steps[-1]) == ("MISSION.start", "T0@2:27.start")
    assert _results(net)["dof-exclusive"].holds  # one behaviour: not two on one dof


def test_dof_exclusive_fails_on_two_behaviours_driving_one_degree_of_freedom() -> None:
    net = _mission("PARALLEL { T0() } AND { T1() }", LIBRARY)
    r, steps = _failing(net, "dof-exclusive")
    assert r.message == "two behaviours can drive x (B0 and B1) at once"
    assert steps == ["MISSION.start", "AND@2:3.start", "T0@2:14.start", "T1@2:27.start"]


def test_no_disable_while_held_fails_on_an_unlatch_under_a_running_task() -> None:
    net = _mission("PARALLEL { T0() } AND { Wait(1 s); L(disable) }", LIBRARY)
    r, steps = _failing(net, "no-disable-while-held")
    assert r.message.startswith("m.mcl:2:38 L(disable): disables B0 while another task")
    assert (steps[0], steps[-1]) == ("MISSION.start", "L@2:38.from.B0.off")
    assert "T0@2:14.start" in steps  # the holder was started on the way


def _hand_made(kind: str) -> Net:
    """begin -> start -> run -> finish -> end, spoilt in one way (what MCL never compiles)."""
    net = Net(kind)
    begin = net.add_place("begin", role=BEGIN)
    end = net.add_place("end", role=END_OK)
    failed = net.add_place("failed", role=END_FAIL)
    run = net.add_place("run", () if kind == "two tokens" else ("B",), role=RUN)
    on, off = (Action("enable", "B"),), (Action("disable", "B"),)
    if kind == "two tokens":
        net.add_transition("start", [begin], [run, run])
        net.add_transition("finish", {run: 2}, [end])
    elif kind == "left behind":
        junk = net.add_place("junk")
        net.add_transition("start", [begin], [run], actions=on)
        net.add_transition("finish", [run], [end, junk], actions=off)
    elif kind == "stuck":
        net.add_transition("start", [begin], [run], actions=on)
    elif kind == "stop stuck":
        stopped = net.add_place("stopped")
        net.add_transition("start", [begin], [run], actions=on)
        net.add_transition("finish", [run], [end], actions=off)
        net.add_transition("abort", [run], [stopped], event="Mission.abort", actions=off)
    else:  # actions that do not match: kind is "no enable", "no disable" or "stray enable"
        start = {"no enable": (), "stray enable": on + (Action("enable", "C"),)}.get(kind, on)
        net.add_transition("start", [begin], [run], actions=start)
        net.add_transition("finish", [run], [end], actions=() if kind == "no disable" else off)
    net.initial = {begin: 1}
    net.finals = [{end: 1}, {failed: 1}]
    return net


@pytest.mark.parametrize("kind,name,message,steps", [
    ("two tokens", "one-safe", "a place can hold two tokens", ["start"]),
    ("left behind", "proper-completion", "the mission can end with tokens left behind",
     ["start", "finish"]),
    ("stuck", "no-deadlock", "the mission can get stuck", ["start"]),
    ("stop stuck", "stop-safe", "after an external stop the mission can fail to end",
     ["start", "abort"]),
])
def test_what_the_compiler_never_makes_fails_its_property(kind: str, name: str, message: str,
                                                          steps: list[str]) -> None:
    net = _hand_made(kind)
    r, found = _failing(net, name)
    assert (r.message, found) == (message, steps)


def test_a_net_without_an_external_stop_is_trivially_stop_safe() -> None:
    r = _results(_hand_made("stuck"))["stop-safe"]
    assert r.holds and r.message == "the mission has no external stop to check"


@pytest.mark.parametrize("kind,problem", [
    ("no enable", "transition start switches B on without an enable action"),
    ("no disable", "transition finish switches B off without a disable action"),
    ("stray enable", "transition start enables C but no place records it on"),
])
def test_actions_match_behaviours_is_a_static_check_of_each_transition(kind: str,
                                                                      problem: str) -> None:
    results = _results(_hand_made(kind))
    r = results["actions-match-behaviours"]
    assert r.status == "fails" and r.message.startswith(problem)
    assert r.counterexample is None and r.method == "static check of every transition"
    assert all(x.holds for n, x in results.items() if n != "actions-match-behaviours")


def test_dead_transitions_are_a_warning_that_names_tasks_that_never_start() -> None:
    net = _mission("IF { Now() } THEN { B() } ELSE { C() }")  # Now() never fails
    verdict = verify(net)
    r = next(x for x in verdict.results if x.name == "no-dead-transitions")
    assert r.status == "fails" and r.severity == "warning"
    assert r.message.startswith(f"{len(verdict.dead_transitions)} of {len(net.transitions)} "
                                "transitions never fire")
    assert verdict.ok and not verdict.failed  # a warning does not fail the verdict
    assert r.message.endswith("; tasks that can never start: C() (line 2)")
    dead = {net.transitions[t].name for t in verdict.dead_transitions}
    assert {"IF@2:3.cond_fail", "C@2:36.start"} <= dead
    assert "B@2:23.start" in {t.name for t in net.transitions} - dead


# -- the verdict ---------------------------------------------------------------------------
def test_a_cut_exploration_leaves_what_it_cannot_establish_undecided() -> None:
    net = _mission("WHILE { A() } DO { B() }")
    verdict = verify(net, max_markings=5)
    assert verdict.undecided and not verdict.ok and not verdict.failed
    statuses = {r.name: r.status for r in verdict.results}
    assert statuses["one-safe"] == "undecided"
    assert statuses["actions-match-behaviours"] == "holds"  # static: no exploration needed
    r = next(x for x in verdict.results if x.name == "can-end")
    assert r.message.startswith("undecided: the exploration stopped (more than 5 markings)")
    whole = verify(net)  # the whole graph: all but terminates holds (the graph rule: a loop)
    assert [r.name for r in whole.results if not r.holds and r.name not in WARNINGS] == [
        "terminates"]


def test_a_violation_seen_before_the_cut_is_still_a_violation() -> None:
    net = _hand_made("two tokens")
    verdict = verify(net, max_markings=2)
    r = next(x for x in verdict.results if x.name == "one-safe")
    assert r.status == "fails" and verdict.failed and not verdict.undecided


def test_to_json_gives_each_property_with_its_steps_in_the_missions_words() -> None:
    net = _mission("Lamp(enable)")
    report = verify(net).to_json()
    assert json.loads(json.dumps(report)) == report
    assert report["verified"] is False and report["undecided"] is False
    assert report["reachable_markings"] == verify(net).markings
    assert [p["property"] for p in report["properties"]] == PROPERTIES
    off = next(p for p in report["properties"] if p["property"] == "behaviours-off-at-end")
    assert (off["status"], off["holds"], off["severity"]) == ("fails", False, "error")
    assert off["marking"] == "{Lamp.on@2:3, MISSION.ok}"
    first, lamp, last = off["counterexample"]
    assert lamp == {"transition": "Lamp@2:3.from.Lamp.off", "label": "start and end",
                    "event": None, "timer": None, "actions": ["enable Lamp"],
                    "file": "m.mcl", "line": 2, "col": 3, "construct": "Lamp(enable)"}
    assert (first["transition"], last["transition"]) == ("MISSION.start", "MISSION.ok")
    assert set(report["dead_transitions"]) == {
        net.transitions[t].name for t in verify(net).dead_transitions}
