"""vehicle_adapters/mavlink/guided.py on its own, no link: the adapter runs one of each
registered behaviour that has a position law (``Behaviour.on_setpoints``), merges their
setpoints with the one coordinator and sends SET_POSITION_TARGET_LOCAL_NED.

``Hover`` is registered for a test (and taken out again): a behaviour with a position law that
no file of vehicle_adapters/ names; ``Drift`` one without (velocities only), which the adapter
does not offer.
"""

from __future__ import annotations

from collections.abc import Iterator

import pytest

from behaviours import registry
from behaviours.base import Behaviour, Perception, Response
from vehicle_adapters.mavlink.commands import COMMANDS
from vehicle_adapters.mavlink.guided import SETPOINT_REFRESH, Guided
from vehicle_adapters.mavlink.link import MavlinkVehicle


class Hover(Behaviour):
    """Hold a depth: heave velocities on the simulated vehicle, the depth as a setpoint on an
    autopilot that holds positions; 'there' within 0.2 m."""

    name = "Hover"
    drives = ("z",)
    events = ("there",)
    parameters = ("depth",)
    priority = 50

    def on_update(self, p: Perception) -> Response:
        return Response({"z": 0.5 * (self.param("depth", p.z) - p.z)})

    def on_setpoints(self, p: Perception) -> Response:
        depth = self.param("depth", p.z)
        if abs(depth - p.z) < 0.2:
            self.raise_event("there")
        return Response(setpoints={"z": depth})


class Drift(Behaviour):
    """Velocities only: no position law."""

    name = "Drift"
    drives = ("x",)

    def on_update(self, p: Perception) -> Response:
        return Response({"x": 0.1})


@pytest.fixture
def new_behaviours() -> Iterator[None]:
    registry.register(Hover)
    registry.register(Drift)
    try:
        yield
    finally:
        registry.unregister("Hover")
        registry.unregister("Drift")


def at(t: float, x: float = -5.0, y: float = 0.0, z: float = 1.0) -> Perception:
    return Perception(t, x, y, z, 0.0)


def test_the_shipped_behaviours_with_a_position_law() -> None:
    assert list(Guided().behaviours) == ["Surface", "AchieveHeadDist", "WallInspection", "GoTo",
                                         "Alarms"]  # by priority
    assert sorted({name for name, _ in COMMANDS}) == ["StartCamera", "StartLogs"]


def test_a_registered_behaviour_with_a_position_law_runs_over_mavlink(
        new_behaviours: None) -> None:
    guided = Guided()
    assert "Hover" in guided.behaviours and "Drift" not in guided.behaviours
    assert guided.act("Hover", "enable", {"depth": 3.0}, at(0.0), guided=True) == ""
    events, setpoint = guided.tick(at(0.1))
    assert events == [] and setpoint is not None
    # the depth is Hover's; x, y and yaw hold where the vehicle is
    assert (setpoint.x, setpoint.y, setpoint.z, setpoint.yaw) == (-5.0, 0.0, 3.0, 0.0)
    assert guided.coordinator.last_owner == {"z": "Hover"}
    events, setpoint = guided.tick(at(0.1 + SETPOINT_REFRESH, z=2.9))
    assert events == [("Hover", "there", {})] and setpoint is not None
    assert guided.act("Hover", "enable", {"depth": 1.0}, at(5.0), guided=False) == "GUIDED"


def test_the_adapter_declares_what_it_runs(new_behaviours: None) -> None:
    said = MavlinkVehicle("udpin:127.0.0.1:14550").declaration().text  # no link opened
    assert "behaviour Hover drives z events there;" in said
    assert "task Hover(depth: number)" in said
    assert "Drift" not in said and "KeepAltitude" not in said
    assert "behaviour StartCamera;" in said and "behaviour GoTo drives x, y, z, yaw" in said
