"""The in-process AAL adapter (vehicle_adapters/inprocess.py): malformed events from the stack
are dropped and counted while the mission goes on; invalid actions are dropped instead of
being passed on to the stack. The harness and ListStack are in tests/harness.py.
"""

from __future__ import annotations

from typing import Any

from aal.messages import ActionMessage
from tests.harness import ListStack, Raw, T, ev, run_with
from vehicle_adapters.inprocess import InProcess


# -- malformed messages ----------------------------------------------------------------------
MALFORMED = [
    "{not json",
    "[1, 2, 3]",
    '{"v": 2, "seq": 0, "t": 1.0, "source": "Alpha", "name": "ok", "data": {}}',
    '{"seq": 0, "t": 1.0, "source": "Alpha", "name": "ok", "data": {}}',
    '{"v": 1, "t": 1.0, "source": "Alpha", "name": "ok", "data": {}}',
    '{"v": 1, "seq": "0", "t": 1.0, "source": "Alpha", "name": "ok", "data": {}}',
    '{"v": 1, "seq": true, "t": 1.0, "source": "Alpha", "name": "ok", "data": {}}',
    '{"v": 1, "seq": 0, "t": "now", "source": "Alpha", "name": "ok", "data": {}}',
    '{"v": 1, "seq": 0, "t": NaN, "source": "Alpha", "name": "ok", "data": {}}',
    '{"v": 1, "seq": -1, "t": 1.0, "source": "Alpha", "name": "ok", "data": {}}',
    '{"v": 1, "seq": 0, "t": 1.0, "source": "Al pha", "name": "ok", "data": {}}',
    '{"v": 1, "seq": 0, "t": 1.0, "source": "Alpha", "name": "ok", "data": []}',
    '{"v": 1, "seq": 0, "t": 1.0, "source": "Alpha", "data": {}}',
]


def test_in_process_drops_malformed_events_and_the_mission_goes_on() -> None:
    # Every malformed message claims to be Alpha.ok; none may end A; the valid one at t=9
    # does. Nothing crashes.
    messages: list[tuple[float, Any]] = [(1 + i * 0.5, Raw(text))
                                         for i, text in enumerate(MALFORMED)]
    messages.append((9, ev(0, 9, "Alpha.ok")))
    h, outcome, vehicle = run_with("A()", messages)
    assert vehicle.dropped == len(MALFORMED)
    assert h.trace() == T("+Alpha", "Alpha.ok>", "-Alpha", "=ok")
    assert outcome.status == "ok" and outcome.time == 9
    h.assert_finished("ok")


def test_in_process_drops_an_invalid_action_instead_of_passing_it_on() -> None:
    stack = ListStack([])
    vehicle = InProcess(stack)
    vehicle.send(ActionMessage(0, 0.0, "m", "A@1:1", "explode", "Alpha", {}))
    vehicle.send(ActionMessage(1, float("nan"), "m", "A@1:1", "enable", "Alpha", {}))
    assert vehicle.dropped == 2 and stack.actions == []
    vehicle.send(ActionMessage(2, 0.0, "m", "A@1:1", "enable", "Alpha", {"x": [1, 2]}))
    assert vehicle.dropped == 2 and len(stack.actions) == 1

