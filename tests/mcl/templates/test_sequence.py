"""mcl/templates/sequence.py: ``A1 ; A2 ; ... ; An``, arc by arc as its diagram draws it.

Each item starts when the one before it ends, whatever its status; the sequence ends with the
status of its last item; an abort stops the running item, waits for it, and reports aborted.
"""

from __future__ import annotations

from petri.verification.properties import verify
from tests.mcl.templates.nets import absorbed, arcs, compiled, names

S = "SEQ@1:9"  # the mission's braced block: a sequence of A() at 2:3 and B() at 2:8


def test_each_item_starts_when_the_one_before_ends_whatever_its_status() -> None:
    net = compiled("A(); B()")
    assert arcs(net, f"{S}.start") == ([f"{S}.begin"], ["A@2:3.begin", f"{S}.run1"])
    for status in ("ok", "fail"):
        assert arcs(net, f"{S}.after1.{status}") == (
            [f"A@2:3.{status}", f"{S}.run1"], ["B@2:8.begin", f"{S}.run2"])
        # the last item's status is the sequence's
        assert arcs(net, f"{S}.after2.{status}") == (
            [f"B@2:8.{status}", f"{S}.run2"], [f"{S}.{status}"])


def test_an_abort_stops_the_running_item_and_waits_for_it() -> None:
    net = compiled("A(); B()")
    for i, child in enumerate(["A@2:3", "B@2:8"], start=1):
        assert arcs(net, f"{S}.abort{i}") == (
            [f"{S}.abort", f"{S}.run{i}"], [f"{child}.abort", f"{S}.stop{i}"])
        assert absorbed(net, f"{S}.stop{i}", child, f"{S}.stop{i}") == [f"{S}.aborted"]


def test_three_items_make_three_steps() -> None:
    net = compiled("A(); B(); C()")
    assert names(net, f"{S}.after") == [f"{S}.after{i}.{s}" for i in (1, 2, 3)
                                        for s in ("ok", "fail")]
    assert arcs(net, f"{S}.after2.ok")[1] == ["C@2:13.begin", f"{S}.run3"]


def test_a_latch_switched_on_inside_is_switched_off_when_the_sequence_is_aborted() -> None:
    net = compiled("Lamp(enable); A(); Lamp(disable)")
    # every stopped item leads to the cleanup, which switches the lamp off if it is on
    assert absorbed(net, f"{S}.stop2", "A@2:17", f"{S}.stop2") == [f"{S}.cleanup"]
    assert arcs(net, f"{S}.off.Lamp.on@2:3") == (
        ["Lamp.on@2:3", f"{S}.cleanup"], ["Lamp.off", f"{S}.aborted"])
    assert arcs(net, f"{S}.keep.Lamp.off") == (
        ["Lamp.off", f"{S}.cleanup"], ["Lamp.off", f"{S}.aborted"])


def test_the_sequence_alone_verifies() -> None:
    assert verify(compiled("A(); Lamp(enable); B(); Lamp(disable); C()")).ok
