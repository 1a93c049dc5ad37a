"""Each template verified on its own (docs/DESIGN.md §5), and mutations of templates caught.

The children are generic blocks (tests.support.GENERIC_TASKS): A(), B(), C(), D() may end
ok, end fail, or be aborted at any moment; Now() ends at once (so any abort reaching it is a
late one); Lamp(enable) latches a behaviour that an abort must switch off. The mission root
may itself be aborted at any moment (Mission.abort), so every abort path of every template
is explored.
"""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager
from typing import Any

import pytest

from mcl import tasklib
from mcl.api import Compiled, compile_source
from diagnostics import Source
from mcl.templates import common
from petri.verification.properties import Verdict, verify
from tests.support import GENERIC_TASKS

LIBRARY = tasklib.load_sources([Source("generic.tasks", GENERIC_TASKS)])

TEMPLATES = {
    "task": "A()",
    "task-at-once": "Now()",
    "sequence": "A(); B(); C()",
    "try-catch-do": "TRY { A() } CATCH { B() } DO { C() }",
    "try-catch-do-at-once": "TRY { Now() } CATCH { B() } DO { Now() }",
    "parallel-and": "PARALLEL { A() } AND { B() } AND { C() }",
    "parallel-and-at-once": "PARALLEL { Now() } AND { B() }",
    "parallel-or": "PARALLEL { A() } OR { B() } OR { C() }",
    "parallel-or-at-once": "PARALLEL { Now() } OR { B() }",
    "if-then-else": "IF { A() } THEN { B() } ELSE { C() }",
    "if-then": "IF { A() } THEN { B() }",
    "while-do": "WHILE { A() } DO { B() }",
    "latched-in-sequence": "Lamp(enable); A(); Lamp(disable)",
    "latched-in-try": "TRY { Lamp(enable); A(); Lamp(disable) } CATCH { B() } DO { C() }",
    "latched-in-parallel-or": "PARALLEL { Lamp(enable); A(); Lamp(disable) } OR { B() }",
    "latched-in-parallel-and": "PARALLEL { Lamp(enable); A(); Lamp(disable) } AND { B() }",
    "latched-in-while": "WHILE { A() } DO { Lamp(enable); B(); Lamp(disable) }",
    "latched-in-if": "IF { Lamp(enable); A() } THEN { Lamp(disable) } ELSE { Lamp(disable) }",
}
STRUCTURAL = ("one-safe", "no-deadlock", "can-end", "proper-completion",
              "behaviours-off-at-end", "dof-exclusive", "actions-match-behaviours")


def compile_text(body: str) -> Compiled:
    return compile_source(Source("t.mcl", f"MISSION {{ {body} }}"), library=LIBRARY)


def holds(verdict: Verdict) -> dict[str, bool]:
    return {r.name: r.holds for r in verdict.results}


@pytest.mark.parametrize("body", TEMPLATES.values(), ids=TEMPLATES.keys())
def test_template_is_sound_on_its_own(body: str) -> None:
    verdict = verify(compile_text(body).net)
    failed = [r for r in verdict.results if r.name in STRUCTURAL and not r.holds]
    assert not failed, [(r.name, r.message) for r in failed]
    # a WHILE of generic children can go round for ever (a plain net's graph rule): only a
    # mission's timeouts bound it; every other template has no loop, so every run ends
    looping = "WHILE" in body
    assert [r.name for r in verdict.results if r.severity == "error" and not r.holds] == (
        ["terminates"] if looping else [])


def test_every_outcome_of_a_try_is_reachable() -> None:
    """Through the generic children, the TRY can end ok, fail, and be aborted: no template
    transition of the TRY itself is dead."""
    compiled = compile_text("TRY { A() } CATCH { B() } DO { C() }")
    verdict = verify(compiled.net)
    try_transitions = [i for i, t in enumerate(compiled.net.transitions)
                       if t.name.startswith("TRY@")]
    assert len(try_transitions) > 20
    assert not set(verdict.dead_transitions) & set(try_transitions), [
        compiled.net.transitions[i].name for i in verdict.dead_transitions]


# -- mutations: break a template, the verifier must notice, with a counterexample ---------
@contextmanager
def patched(obj: Any, name: str, replacement: Any) -> Iterator[None]:
    original = getattr(obj, name)
    setattr(obj, name, replacement)
    try:
        yield
    finally:
        setattr(obj, name, original)


def failing(verdict: Verdict) -> dict[str, Any]:
    return {r.name: r for r in verdict.results if not r.holds and r.severity == "error"}


def test_mutation_dropping_late_abort_absorption_is_caught() -> None:
    """Without the transitions that absorb an abort arriving after the child ended, the
    abort token is left behind: the verifier reports it with a firing sequence."""
    original = common.Context.absorb

    def absorb_without_late(self: common.Context, child: common.Interface, waiting: int,
                            done: list[int], name: str, origin: Any) -> None:
        self.transition(f"{name}.stopped", [waiting, child.aborted], done, "stopped", origin)

    with patched(common.Context, "absorb", absorb_without_late):
        verdict = verify(compile_text("TRY { A() } CATCH { Now() } DO { B() }").net)
    assert common.Context.absorb is original
    bad = failing(verdict)
    assert "no-deadlock" in bad or "terminates" in bad, bad
    r = bad.get("no-deadlock") or bad["terminates"]
    assert r.counterexample, "a counterexample must be given"


def test_mutation_dropping_the_abort_arc_of_a_task_is_caught() -> None:
    """A task whose abort transition does not take the abort token leaves it behind."""
    original = common.Context.transition

    def transition(self: common.Context, name: str, inputs: list[int], outputs: list[int],
                   *args: Any, **kw: Any) -> int:
        if name.endswith(".abort") and name.startswith("A@"):
            inputs = inputs[:1]  # the run place only: the abort arc is gone
        return original(self, name, inputs, outputs, *args, **kw)

    with patched(common.Context, "transition", transition):
        verdict = verify(compile_text("PARALLEL { A() } OR { B() }").net)
    bad = failing(verdict)
    assert bad, "the broken template must be caught"
    assert any(r.counterexample for r in bad.values())


def test_mutation_forgetting_a_stop_action_is_caught() -> None:
    src = Source("lib.tasks", GENERIC_TASKS + """
        behaviour Arm drives x;
        task Grab() { start: enable Arm; ok: Probe.ok; stop: disable Arm; }""")
    library = tasklib.load_sources([src])
    compiled = compile_source(Source("t.mcl", "MISSION { PARALLEL { Grab() } OR { B() } }"),
                              library=library)
    net = compiled.net
    assert verify(net).ok
    # forget the stop action of the abort transition
    for i, t in enumerate(net.transitions):
        if t.name.startswith("Grab@") and t.name.endswith(".abort"):
            net.transitions[i] = type(t)(t.name, t.inputs, t.outputs, (), t.event, t.timer,
                                         t.origin, t.label)
    bad = failing(verify(net))
    assert "actions-match-behaviours" in bad
    assert "switches Arm off without a disable action" in bad["actions-match-behaviours"].message


def test_mutation_duplicating_a_token_is_caught() -> None:
    net = compile_text("A(); B()").net
    net.initial[net.place("MISSION.begin")] = 2
    bad = failing(verify(net))
    assert "one-safe" in bad
    assert bad["one-safe"].counterexample is not None


def test_a_latched_behaviour_left_on_is_reported() -> None:
    verdict = verify(compile_text("Lamp(enable); A()").net)
    bad = failing(verdict)
    assert "behaviours-off-at-end" in bad
    assert "Lamp" in bad["behaviours-off-at-end"].message
    assert bad["behaviours-off-at-end"].counterexample


def test_two_behaviours_on_the_same_degree_of_freedom_are_reported() -> None:
    compiled = compile_source(Source("t.mcl", "MISSION { PARALLEL { GoTo((0, 0, 1, 0)) } "
                                     "AND { Surface() } }"))
    bad = failing(verify(compiled.net))
    assert "dof-exclusive" in bad
    assert "z (GoTo and Surface)" in bad["dof-exclusive"].message
    steps = [compiled.net.transitions[t].name for t in bad["dof-exclusive"].counterexample]
    assert any(s.startswith("GoTo@") and s.endswith(".start") for s in steps)
    assert any(s.startswith("Surface@") and s.endswith(".start") for s in steps)


def test_an_abort_switches_a_latched_behaviour_off() -> None:
    """docs/DESIGN.md §6: without this rule the paper's mission would surface after an alarm with
    AchieveHeadDist still holding the wall distance."""
    compiled = compile_text("TRY { Lamp(enable); A(); Lamp(disable) } CATCH { B() } DO { C() }")
    net = compiled.net
    offs = [t for t in net.transitions if any(a.kind == "disable" and a.behaviour == "Lamp"
                                              for a in t.actions) and "cleanup" not in t.name
            and ".off." in t.name]
    assert offs, "an abort path must switch the lamp off"
    assert verify(net).ok
