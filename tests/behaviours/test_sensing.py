"""behaviours/sensing.py on its own: the behaviours that drive nothing.

StartCamera and StartLogs only are on or off; Alarms raises ``leak``, ``overtemperature`` and
``overpressure`` (each once per enable) when a reading passes its threshold: strictly above
50 deg C and 1.5 bar unless the action gives ``max_temperature`` / ``max_pressure``.
"""

from __future__ import annotations

from typing import Any

import pytest

from behaviours.base import Perception
from behaviours.sensing import Alarms, StartCamera, StartLogs


def at(t: float = 0.0, **kw: Any) -> Perception:
    return Perception(t, 0.0, 0.0, 1.0, 0.0, **kw)


@pytest.mark.parametrize("cls", [StartCamera, StartLogs])
def test_on_off_behaviours_declare_nothing_but_their_name(cls: type[StartCamera]) -> None:
    assert (cls.drives, cls.events, cls.parameters) == ((), (), ())
    b = cls()
    b.initialise({}, 0.0)
    assert b.active and b.update(at(leak=True)).demands == {} and b.take_events() == []


@pytest.mark.parametrize("reading,event", [
    ({"temperature": 50.0}, None), ({"temperature": 50.1}, "overtemperature"),
    ({"pressure": 1.5}, None), ({"pressure": 1.6}, "overpressure"),
    ({"leak": True}, "leak"),
])
def test_the_default_thresholds_are_exceeded_strictly(reading: dict[str, Any],
                                                      event: str | None) -> None:
    b = Alarms()
    b.initialise({}, 0.0)
    assert b.update(at(**reading)).demands == {}
    assert [name for name, _ in b.take_events()] == ([event] if event else [])


def test_thresholds_from_the_action_and_readings_in_the_event() -> None:
    b = Alarms()
    b.initialise({"max_temperature": 30, "max_pressure": 2.0}, 0.0)
    b.update(at(temperature=35.0, pressure=1.8))
    assert b.take_events() == [("overtemperature", {"temperature": 35.0})]
    b.update(at(0.1, temperature=36.0, pressure=2.5))
    assert b.take_events() == [("overpressure", {"pressure": 2.5})]  # each said once
    b.initialise({}, 1.0)
    b.update(at(1.0, temperature=60.0))
    assert b.take_events() == [("overtemperature", {"temperature": 60.0})]  # enabled again
