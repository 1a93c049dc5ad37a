"""mcl/templates/parallel_or.py: ``PARALLEL {B1} OR {B2} [OR ...]``, arc by arc.

Every branch starts; the first to end wins: the others are stopped, and once all are stopped
the block ends as the winner ended. An abort during the race stops every branch; an abort
while the losers are being stopped waits for them; either way the block reports aborted.
"""

from __future__ import annotations

import pytest

from petri.verification.properties import verify
from tests.mcl.templates.nets import absorbed, arcs, compiled, names

OR = "OR@2:3"
BRANCHES = ["A@2:14", "B@2:25"]


def test_every_branch_starts() -> None:
    assert arcs(compiled("PARALLEL { A() } OR { B() }"), f"{OR}.start") == (
        [f"{OR}.begin"], ["A@2:14.begin", "B@2:25.begin", f"{OR}.race"])


@pytest.mark.parametrize("status", ["ok", "fail"])
def test_the_first_branch_to_end_stops_the_others_and_gives_its_status(status: str) -> None:
    net = compiled("PARALLEL { A() } OR { B() }")
    for i, (me, other) in enumerate([(0, 1), (1, 0)], start=1):
        assert arcs(net, f"{OR}.first{i}_{status}") == (
            [f"{BRANCHES[me]}.{status}", f"{OR}.race"],
            sorted([f"{BRANCHES[other]}.abort", f"{OR}.stop{other + 1}", f"{OR}.stopped{i}",
                    f"{OR}.won_{status}"]))
        assert absorbed(net, f"{OR}.stop{i}", BRANCHES[me], f"{OR}.stop{i}") == [
            f"{OR}.stopped{i}"]
    assert arcs(net, f"{OR}.end_{status}") == (
        [f"{OR}.stopped1", f"{OR}.stopped2", f"{OR}.won_{status}"], [f"{OR}.{status}"])


def test_an_abort_stops_every_branch_or_waits_for_those_being_stopped() -> None:
    net = compiled("PARALLEL { A() } OR { B() }")
    assert arcs(net, f"{OR}.abort") == (
        [f"{OR}.abort", f"{OR}.race"],
        sorted(["A@2:14.abort", "B@2:25.abort", f"{OR}.aborting", f"{OR}.stop1", f"{OR}.stop2"]))
    for status in ("ok", "fail"):
        assert arcs(net, f"{OR}.abort_won_{status}") == (
            [f"{OR}.abort", f"{OR}.won_{status}"], [f"{OR}.aborting"])
    assert arcs(net, f"{OR}.abort_joined") == (
        [f"{OR}.aborting", f"{OR}.stopped1", f"{OR}.stopped2"], [f"{OR}.aborted"])


def test_three_branches_each_stop_the_two_others() -> None:
    net = compiled("PARALLEL { A() } OR { B() } OR { C() }")
    assert len(names(net, f"{OR}.first")) == 6
    _, outputs = arcs(net, f"{OR}.first2_ok")
    assert outputs == sorted(["A@2:14.abort", "C@2:36.abort", f"{OR}.stop1", f"{OR}.stop3",
                              f"{OR}.stopped2", f"{OR}.won_ok"])


def test_the_or_alone_verifies_with_a_timer_branch() -> None:
    assert verify(compiled("PARALLEL { A(); B() } OR { Wait(1 s) } OR { Lamp(enable); "
                           "C(); Lamp(disable) }")).ok
