"""mcl/templates/if_then_else.py: ``IF {C} THEN {A} [ELSE {B}]``, arc by arc.

The condition is a block: ok chooses THEN, fail chooses ELSE (without ELSE the block fails);
the chosen branch's status is the block's. An abort stops whichever of the three runs.
"""

from __future__ import annotations

import pytest

from petri.verification.properties import verify
from tests.mcl.templates.nets import absorbed, arcs, compiled, names

IF = "IF@2:3"
COND, THEN, ELSE = "A@2:8", "B@2:21", "C@2:34"


def test_the_condition_chooses_the_branch() -> None:
    net = compiled("IF { A() } THEN { B() } ELSE { C() }")
    assert arcs(net, f"{IF}.start") == ([f"{IF}.begin"], [f"{COND}.begin", f"{IF}.if"])
    assert arcs(net, f"{IF}.cond_ok") == ([f"{COND}.ok", f"{IF}.if"],
                                         [f"{THEN}.begin", f"{IF}.then"])
    assert arcs(net, f"{IF}.cond_fail") == ([f"{COND}.fail", f"{IF}.if"],
                                           [f"{ELSE}.begin", f"{IF}.else"])


@pytest.mark.parametrize("status", ["ok", "fail"])
def test_the_chosen_branch_gives_its_status(status: str) -> None:
    net = compiled("IF { A() } THEN { B() } ELSE { C() }")
    assert arcs(net, f"{IF}.then_{status}") == ([f"{THEN}.{status}", f"{IF}.then"],
                                                [f"{IF}.{status}"])
    assert arcs(net, f"{IF}.else_{status}") == ([f"{ELSE}.{status}", f"{IF}.else"],
                                                [f"{IF}.{status}"])


def test_without_else_a_failed_condition_fails_the_block() -> None:
    net = compiled("IF { A() } THEN { B() }")
    assert arcs(net, f"{IF}.cond_fail") == ([f"{COND}.fail", f"{IF}.if"], [f"{IF}.fail"])
    assert not names(net, f"{IF}.else") and not names(net, f"{IF}.abort_else")


def test_an_abort_stops_whichever_part_runs() -> None:
    net = compiled("IF { A() } THEN { B() } ELSE { C() }")
    for role, child in (("if", COND), ("then", THEN), ("else", ELSE)):
        assert arcs(net, f"{IF}.abort_{role}") == ([f"{IF}.abort", f"{IF}.{role}"],
                                                  [f"{child}.abort", f"{IF}.stop_{role}"])
        assert absorbed(net, f"{IF}.stop_{role}", child, f"{IF}.stop_{role}") == [f"{IF}.aborted"]


@pytest.mark.parametrize("body", ["IF { A() } THEN { B() } ELSE { C() }",
                                  "IF { A() } THEN { Lamp(enable); B(); Lamp(disable) }"])
def test_the_if_alone_verifies(body: str) -> None:
    assert verify(compiled(body)).ok
