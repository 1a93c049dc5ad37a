"""How the player reports to its observers (petri/execution/reporting.py), on its own: a step
holds its records until it ends, a call that observers break runs to its end and then raises
their first error, once, and a call's own error wins over theirs. The player's use of it is
tests/petri/execution/test_player.py's (an observer on a full disk)."""

from __future__ import annotations

import pytest

from petri.execution.reporting import Record, Reporting, whole


class Speaker:
    """A tiny reporter: each call emits records inside a step, or fails on request."""

    def __init__(self) -> None:
        self.heard: list[tuple[str, str]] = []  # (observer, kind), in the order told
        self.reporting = Reporting([lambda r: self.heard.append(("first", r.kind)),
                                    lambda r: self.heard.append(("second", r.kind))])
        self.done: list[str] = []

    @whole
    def say(self, *kinds: str) -> int:
        with self.reporting.step():
            for kind in kinds:
                self.reporting.emit(Record(0.0, kind, {}))
                self.done.append(kind)
        return len(kinds)

    @whole
    def say_twice(self) -> None:
        self.say("inner")  # a call inside a call: errors wait for the outer one
        self.done.append("after the inner call")
        self.say("outer")

    @whole
    def fail(self) -> None:
        self.reporting.emit(Record(0.0, "note", {}))
        raise ValueError("the call's own error")


def test_a_step_tells_its_records_at_its_end_in_order_to_every_observer() -> None:
    s = Speaker()
    with s.reporting.step():
        s.reporting.emit(Record(0.0, "fire", {}))
        s.reporting.emit(Record(0.0, "action", {}))
        assert s.heard == []  # nothing told inside the step
    assert s.heard == [("first", "fire"), ("second", "fire"),
                       ("first", "action"), ("second", "action")]
    s.reporting.emit(Record(1.0, "note", {}))  # outside a step: at once
    assert s.heard[-2:] == [("first", "note"), ("second", "note")]


def test_an_observer_error_waits_for_the_end_of_the_outermost_call() -> None:
    s = Speaker()
    broken: list[str] = []

    def observer(record: Record) -> None:
        broken.append(record.kind)
        raise OSError(28, f"full disk at {record.kind}")

    s.reporting.observers.insert(0, observer)
    with pytest.raises(OSError, match="full disk at inner"):  # the first error, once
        s.say_twice()
    assert s.done == ["inner", "after the inner call", "outer"]  # the call ran to its end
    assert broken == ["inner", "outer"]
    assert ("second", "outer") in s.heard  # the other observers heard everything
    s.reporting.observers.remove(observer)
    assert s.say("again") == 1  # nothing left over from the failed call


def test_outside_a_call_an_observer_error_raises_at_once() -> None:
    s = Speaker()

    def observer(record: Record) -> None:
        raise RuntimeError("broken observer")

    s.reporting.observers.append(observer)
    with pytest.raises(RuntimeError, match="broken observer"):
        s.reporting.emit(Record(0.0, "note", {}))
    assert s.heard == [("first", "note"), ("second", "note")]


def test_a_calls_own_error_is_the_one_reported() -> None:
    s = Speaker()

    def observer(record: Record) -> None:
        raise RuntimeError("observer")

    s.reporting.observers.append(observer)
    with pytest.raises(ValueError, match="own error"):
        s.fail()
    s.reporting.observers.remove(observer)
    s.say("next")  # the observer's error was dropped with the call, not kept for later
    assert s.reporting.failure is None and s.reporting.calls == 0
