"""mcl/templates/task.py: a task call, arc by arc, with what each transition carries.

A task that waits: start -> run -> (ok event | fail event | timeout | abort), each ending
sending the stop actions. A task that ends at once: one transition begin -> ok with its start
actions; if it latches or unlatches, one per state its latch may be in. A per-call timeout
replaces a declared fail timeout, and comes before a declared ok timeout that stays.
"""

from __future__ import annotations

from diagnostics import Source
from mcl import tasklib
from mcl.api import compile_source
from petri.net import Action, Net
from tests.mcl.templates.nets import arcs, compiled, names

LIBRARY = tasklib.load_sources([Source("t.tasks", """
behaviour Arm drives x events done, broken;
task Reach(d: length) {
  start: enable Arm(d = d);
  ok: Arm.done;
  fail: Arm.broken;
  timeout: 5 s -> ok;
  stop: disable Arm;
}
""")])


def _library_net(body: str) -> Net:
    return compile_source(Source("m.mcl", f"MISSION {{\n  {body}\n}}\n"), library=LIBRARY).net


def _transition(net: Net, name: str) -> tuple[tuple[Action, ...], str | None, object]:
    t = next(t for t in net.transitions if t.name == name)
    return t.actions, t.event, t.timer


def test_a_task_that_waits() -> None:
    net = compiled("A()")
    assert names(net, "A@2:3.") == ["A@2:3.start", "A@2:3.ok.Probe.ok", "A@2:3.fail.Probe.fail",
                                    "A@2:3.abort"]
    assert arcs(net, "A@2:3.start") == (["A@2:3.begin"], ["A@2:3.run"])
    assert arcs(net, "A@2:3.ok.Probe.ok") == (["A@2:3.run"], ["A@2:3.ok"])
    assert arcs(net, "A@2:3.fail.Probe.fail") == (["A@2:3.run"], ["A@2:3.fail"])
    assert arcs(net, "A@2:3.abort") == (["A@2:3.abort", "A@2:3.run"], ["A@2:3.aborted"])
    assert _transition(net, "A@2:3.ok.Probe.ok")[1] == "Probe.ok"


def test_every_ending_sends_the_stop_actions_and_the_run_place_holds_the_behaviour() -> None:
    net = _library_net("Reach(2 m)")
    stop = (Action("disable", "Arm"),)
    assert _transition(net, "Reach@2:3.start") == (
        (Action("enable", "Arm", (("d", 2.0),)),), None, None)
    assert _transition(net, "Reach@2:3.ok.Arm.done") == (stop, "Arm.done", None)
    assert _transition(net, "Reach@2:3.fail.Arm.broken") == (stop, "Arm.broken", None)
    assert _transition(net, "Reach@2:3.timeout") == (stop, None, 5.0)
    assert arcs(net, "Reach@2:3.timeout")[1] == ["Reach@2:3.ok"]  # the declared ok timeout
    assert _transition(net, "Reach@2:3.abort") == (stop, None, None)
    run = next(p for p in net.places if p.name == "Reach@2:3.run")
    assert run.behaviours == ("Arm",)


def test_a_per_call_timeout_comes_first_and_an_ok_timeout_stays() -> None:
    net = _library_net("Reach(2 m, timeout = 2 s)")
    assert names(net, "Reach@2:3.timeout") == ["Reach@2:3.timeout", "Reach@2:3.timeout1"]
    assert _transition(net, "Reach@2:3.timeout")[2] == 2.0
    assert arcs(net, "Reach@2:3.timeout")[1] == ["Reach@2:3.fail"]
    assert _transition(net, "Reach@2:3.timeout1")[2] == 5.0
    assert arcs(net, "Reach@2:3.timeout1")[1] == ["Reach@2:3.ok"]


def test_a_task_that_ends_at_once() -> None:
    net = compiled("Now()")
    assert names(net, "Now@2:3.") == ["Now@2:3.do"]
    assert arcs(net, "Now@2:3.do") == (["Now@2:3.begin"], ["Now@2:3.ok"])
    assert not [p for p in net.places if p.name == "Now@2:3.run"]


def test_a_latching_task_moves_its_latch_from_each_state_it_may_be_in() -> None:
    net = compiled("Lamp(enable); WHILE { A() } DO { Lamp(enable) }; Lamp(disable)")
    on_first, on_loop = "Lamp.on@2:3", "Lamp.on@2:36"
    # the first call finds the lamp off; the one in the loop finds it on from either call
    assert names(net, "Lamp@2:3.") == ["Lamp@2:3.from.Lamp.off"]
    assert arcs(net, "Lamp@2:3.from.Lamp.off") == (["Lamp.off", "Lamp@2:3.begin"],
                                                   [on_first, "Lamp@2:3.ok"])
    assert names(net, "Lamp@2:36.") == [f"Lamp@2:36.from.{on_first}",
                                        f"Lamp@2:36.from.{on_loop}"]
    assert arcs(net, f"Lamp@2:36.from.{on_first}") == (
        sorted([on_first, "Lamp@2:36.begin"]), sorted([on_loop, "Lamp@2:36.ok"]))
    # Lamp(disable) switches it off from either "on" state, with the disable action
    offs = names(net, "Lamp@2:52.from.")
    assert offs == [f"Lamp@2:52.from.{on_first}", f"Lamp@2:52.from.{on_loop}"]
    assert all(_transition(net, t)[0] == (Action("disable", "Lamp"),) for t in offs)
    assert arcs(net, offs[1])[1] == ["Lamp.off", "Lamp@2:52.ok"]
