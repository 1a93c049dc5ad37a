"""behaviours/base.py on its own: the lifecycle every behaviour shares and the unit helpers.

A minimal behaviour written here (not one of the vehicle's) goes through ``initialise``,
``update``, ``configure`` and ``terminate``; events are raised once per enable and taken once;
parameters are read with defaults; the declaration a task library writes comes from the class.
"""

from __future__ import annotations

import dataclasses
import math

import pytest
from hypothesis import given
from hypothesis import strategies as st

from behaviours.base import (
    DOFS,
    Behaviour,
    Perception,
    Response,
    clamp,
    from_degrees,
    to_degrees,
    wrap,
)


class Probe(Behaviour):
    """Asks for a surge speed ``speed`` and says ``near`` once closer than 1 m to x = 0."""

    name = "Probe"
    drives = ("x",)
    events = ("near", "far")
    parameters = ("speed",)

    def on_initialise(self, t: float) -> None:
        self.started = t

    def on_update(self, p: Perception) -> Response:
        if abs(p.x) < 1.0:
            self.raise_event("near", x=p.x)
        return Response({"x": self.param("speed", 0.5)})


def at(x: float, t: float = 0.0) -> Perception:
    return Perception(t, x, 0.0, 0.0, 0.0)


def test_the_lifecycle_enable_tick_disable() -> None:
    b = Probe()
    assert not b.active and b.update(at(0.0)) == Response()  # inactive: answers nothing
    b.initialise({"speed": 0.2}, 3.0)
    assert b.active and b.started == 3.0 and b.params == {"speed": 0.2}
    assert b.update(at(5.0)).demands == {"x": 0.2}
    b.configure({"speed": 0.3}, 4.0)
    assert b.update(at(5.0)).demands == {"x": 0.3}
    b.terminate(5.0)
    assert not b.active and b.update(at(0.0)).demands == {}
    assert b.take_events() == []  # nothing raised while it was far, nor once disabled


def test_an_event_is_raised_once_per_enable_and_taken_once() -> None:
    b = Probe()
    b.initialise({}, 0.0)
    for t in range(3):
        b.update(at(0.5, t))
    assert b.take_events() == [("near", {"x": 0.5})]
    assert b.take_events() == []
    b.update(at(0.1))
    assert b.take_events() == []  # said once already
    b.initialise({}, 10.0)  # enabled again: may say it again
    b.update(at(0.2))
    assert b.take_events() == [("near", {"x": 0.2})]


def test_initialise_takes_a_copy_of_the_parameters() -> None:
    params = {"speed": 1.0}
    b = Probe()
    b.initialise(params, 0.0)
    params["speed"] = 9.0
    assert b.param("speed", 0.0) == 1.0


@pytest.mark.parametrize("params,expected", [
    ({}, 0.5), ({"speed": 2}, 2.0), ({"speed": "fast"}, 0.5), ({"speed": None}, 0.5),
])
def test_param_falls_back_to_its_default_when_not_a_number(params: dict[str, object],
                                                           expected: float) -> None:
    b = Probe()
    b.initialise(params, 0.0)
    assert b.param("speed", 0.5) == expected


def test_angle_parameters_come_in_degrees_and_are_used_in_radians() -> None:
    b = Probe()
    b.initialise({"yaw": 90, "bad": "north"}, 0.0)
    assert b.angle("yaw", 0.0) == pytest.approx(math.pi / 2)
    assert b.angle("bad", 0.25) == 0.25 and b.angle("missing", -1.0) == -1.0


def test_the_statement_a_task_library_writes() -> None:
    assert Probe.statement() == "behaviour Probe drives x events near, far;\n"

    class Quiet(Behaviour):
        name = "Quiet"

    assert Quiet.statement() == "behaviour Quiet;\n"


def test_perceptions_are_frozen_and_responses_start_empty() -> None:
    p = at(1.0)
    with pytest.raises(dataclasses.FrozenInstanceError):
        p.x = 2.0  # type: ignore[misc]
    assert (p.wall_distance, p.altitude, p.leak, p.line) == (None, None, False, None)
    a, b = Response(), Response()
    a.demands["x"] = 1.0
    assert b.demands == {} and b.setpoints == {}  # no shared default
    assert DOFS == ("x", "y", "z", "yaw")


# -- units, angles and limits -------------------------------------------------------------
@pytest.mark.parametrize("angle,wrapped", [
    (0.0, 0.0), (math.pi, math.pi), (-math.pi, math.pi), (3 * math.pi / 2, -math.pi / 2),
    (2 * math.pi, 0.0), (-5 * math.pi / 2, -math.pi / 2),
])
def test_wrap_gives_an_angle_in_minus_pi_exclusive_to_pi(angle: float, wrapped: float) -> None:
    assert wrap(angle) == pytest.approx(wrapped)


@given(st.floats(-1e6, 1e6, allow_nan=False))
def test_wrap_keeps_the_direction(angle: float) -> None:
    w = wrap(angle)
    assert -math.pi < w <= math.pi
    assert math.cos(w) == pytest.approx(math.cos(angle), abs=1e-6)
    assert math.sin(w) == pytest.approx(math.sin(angle), abs=1e-6)


def test_degrees_and_radians() -> None:
    assert from_degrees(180) == pytest.approx(math.pi)
    assert to_degrees(math.pi / 2) == pytest.approx(90.0)
    assert to_degrees(from_degrees(-37.5)) == pytest.approx(-37.5)


@pytest.mark.parametrize("value,limit,expected", [
    (0.3, 0.5, 0.3), (0.7, 0.5, 0.5), (-0.7, 0.5, -0.5), (-0.5, 0.5, -0.5),
])
def test_clamp(value: float, limit: float, expected: float) -> None:
    assert clamp(value, limit) == expected
