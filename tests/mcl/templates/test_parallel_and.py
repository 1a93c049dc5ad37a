"""mcl/templates/parallel_and.py: ``PARALLEL {B1} AND {B2} [AND ...]``, arc by arc.

Every branch starts and the block waits for all: ok if all ended ok, fail if one failed
(``all_ok`` turns into ``some_fail`` at the first failure). ``calm`` is taken by an abort, which
stops every branch still running and reports aborted once all are done.
"""

from __future__ import annotations

from petri.verification.properties import verify
from tests.mcl.templates.nets import absorbed, arcs, compiled, names

P = "AND@2:3"
BRANCHES = ["A@2:14", "B@2:26"]


def test_every_branch_starts_with_all_ok_and_calm() -> None:
    assert arcs(compiled("PARALLEL { A() } AND { B() }"), f"{P}.start") == (
        [f"{P}.begin"], sorted(["A@2:14.begin", "B@2:26.begin", f"{P}.all_ok", f"{P}.calm",
                                f"{P}.run1", f"{P}.run2"]))


def test_a_branch_ends_into_done_and_a_failure_marks_some_fail() -> None:
    net = compiled("PARALLEL { A() } AND { B() }")
    for i, child in enumerate(BRANCHES, start=1):
        assert arcs(net, f"{P}.branch{i}_ok") == (
            sorted([f"{child}.ok", f"{P}.run{i}"]), [f"{P}.done{i}"])
        for status in ("all_ok", "some_fail"):  # whichever it was, it is some_fail after
            assert arcs(net, f"{P}.branch{i}_fail.{P}.{status}") == (
                sorted([f"{child}.fail", f"{P}.run{i}", f"{P}.{status}"]),
                [f"{P}.done{i}", f"{P}.some_fail"])


def test_the_join_waits_for_every_branch() -> None:
    net = compiled("PARALLEL { A() } AND { B() }")
    done = [f"{P}.done1", f"{P}.done2"]
    assert arcs(net, f"{P}.join_ok") == (sorted(done + [f"{P}.all_ok", f"{P}.calm"]),
                                         [f"{P}.ok"])
    assert arcs(net, f"{P}.join_fail") == (sorted(done + [f"{P}.some_fail", f"{P}.calm"]),
                                           [f"{P}.fail"])


def test_an_abort_stops_each_running_branch_and_joins() -> None:
    net = compiled("PARALLEL { A() } AND { B() }")
    assert arcs(net, f"{P}.abort") == ([f"{P}.abort", f"{P}.calm"], [f"{P}.aborting"])
    for i, child in enumerate(BRANCHES, start=1):
        assert arcs(net, f"{P}.abort{i}") == (  # aborting stays marked for the others
            [f"{P}.aborting", f"{P}.run{i}"],
            sorted([f"{child}.abort", f"{P}.aborting", f"{P}.stop{i}"]))
        assert absorbed(net, f"{P}.stop{i}", child, f"{P}.stop{i}") == [f"{P}.done{i}"]
    for status in ("all_ok", "some_fail"):
        assert arcs(net, f"{P}.abort_joined.{P}.{status}") == (
            sorted([f"{P}.aborting", f"{P}.done1", f"{P}.done2", f"{P}.{status}"]),
            [f"{P}.aborted"])


def test_three_branches() -> None:
    net = compiled("PARALLEL { A() } AND { B() } AND { C() }")
    assert names(net, f"{P}.branch3") == [f"{P}.branch3_ok", f"{P}.branch3_fail.{P}.all_ok",
                                          f"{P}.branch3_fail.{P}.some_fail"]
    assert f"{P}.done3" in arcs(net, f"{P}.join_ok")[0]


def test_the_and_alone_verifies_with_a_latch_in_a_branch() -> None:
    assert verify(compiled("PARALLEL { A() } AND { Lamp(enable); B(); Lamp(disable) }")).ok
