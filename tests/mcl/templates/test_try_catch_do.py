"""mcl/templates/try_catch_do.py: ``TRY {T} CATCH {C} DO {D}``, arc by arc.

T and C race. T ends first: C is stopped and the block ends as T ended. C ends first: T is
stopped, then D runs and decides. An abort stops whatever runs (both racers, or the one being
stopped, or D), waits, and reports aborted.
"""

from __future__ import annotations

import pytest

from petri.verification.properties import verify
from tests.mcl.templates.nets import absorbed, arcs, compiled

BODY = "TRY { A() } CATCH { B() } DO { C() }"
T, TRY, CATCH, DO = "TRY@2:3", "A@2:9", "B@2:23", "C@2:34"


def test_try_and_catch_start_together() -> None:
    assert arcs(compiled(BODY), f"{T}.start") == (
        [f"{T}.begin"], [f"{TRY}.begin", f"{CATCH}.begin", f"{T}.race"])


@pytest.mark.parametrize("status", ["ok", "fail"])
def test_try_ending_first_stops_catch_and_ends_with_its_status(status: str) -> None:
    net = compiled(BODY)
    assert arcs(net, f"{T}.try_{status}") == (
        [f"{TRY}.{status}", f"{T}.race"], [f"{CATCH}.abort", f"{T}.stop_catch_{status}"])
    waiting = f"{T}.stop_catch_{status}"
    assert absorbed(net, waiting, CATCH, waiting) == [f"{T}.{status}"]


@pytest.mark.parametrize("status", ["ok", "fail"])
def test_catch_ending_first_stops_try_then_do_decides(status: str) -> None:
    net = compiled(BODY)
    assert arcs(net, f"{T}.catch_{status}") == (
        [f"{CATCH}.{status}", f"{T}.race"], [f"{TRY}.abort", f"{T}.stop_try"])
    assert absorbed(net, f"{T}.stop_try", TRY, f"{T}.stop_try") == [f"{DO}.begin", f"{T}.do"]
    assert arcs(net, f"{T}.do_{status}") == ([f"{DO}.{status}", f"{T}.do"], [f"{T}.{status}"])


def test_an_abort_during_the_race_stops_both_and_joins() -> None:
    net = compiled(BODY)
    assert arcs(net, f"{T}.abort_race") == (
        [f"{T}.abort", f"{T}.race"],
        [f"{TRY}.abort", f"{CATCH}.abort", f"{T}.abort_catch", f"{T}.abort_try"])
    assert absorbed(net, f"{T}.abort_try", TRY, f"{T}.abort_try") == [f"{T}.abort_try_done"]
    assert absorbed(net, f"{T}.abort_catch", CATCH, f"{T}.abort_catch") == [
        f"{T}.abort_catch_done"]
    assert arcs(net, f"{T}.abort_joined") == (
        [f"{T}.abort_catch_done", f"{T}.abort_try_done"], [f"{T}.aborted"])


def test_an_abort_while_one_racer_is_being_stopped_waits_for_it_alone() -> None:
    net = compiled(BODY)
    for status in ("ok", "fail"):  # TRY has ended: only CATCH is left to wait for
        assert arcs(net, f"{T}.abort_stop_catch_{status}") == (
            [f"{T}.abort", f"{T}.stop_catch_{status}"],
            [f"{T}.abort_catch", f"{T}.abort_try_done"])
    assert arcs(net, f"{T}.abort_stop_try") == (  # CATCH has ended: only TRY is left
        [f"{T}.abort", f"{T}.stop_try"], [f"{T}.abort_catch_done", f"{T}.abort_try"])


def test_an_abort_during_do_stops_do() -> None:
    net = compiled(BODY)
    assert arcs(net, f"{T}.abort_do") == ([f"{T}.abort", f"{T}.do"],
                                          [f"{DO}.abort", f"{T}.abort_do"])
    assert absorbed(net, f"{T}.abort_do", DO, f"{T}.abort_do") == [f"{T}.aborted"]


def test_the_try_alone_verifies_with_a_latch_in_its_try_block() -> None:
    assert verify(compiled("TRY { Lamp(enable); A(); Lamp(disable) } CATCH { B() } "
                           "DO { C() }")).ok
