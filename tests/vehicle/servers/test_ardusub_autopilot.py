"""vehicle/servers/ardusub_autopilot.py on the simulated stack, with no link: what arming, a
mode and a device's command do to the stack's behaviours, read from what each registered class
declares (``drives``, ``switches``), never from a list of names.

The behaviours here are registered for one test (and taken out again): ``Sink``, a motion
behaviour that no file of the tree names, and ``Flash``, a second one that switches the camera.
"""

from __future__ import annotations

from collections.abc import Iterator

import pytest
from pymavlink.dialects.v20 import ardupilotmega as mav

from aal.messages import ActionMessage
from behaviours import registry
from behaviours.base import Behaviour, Perception, Response
from vehicle.control.stack import IctineuStack
from vehicle.servers import ardusub

ACCEPTED = int(mav.MAV_RESULT_ACCEPTED)
ARM_DISARM = int(mav.MAV_CMD_COMPONENT_ARM_DISARM)


class Sink(Behaviour):
    """Heave down at 0.2 m/s, over every other behaviour (a priority above Surface's)."""

    name = "Sink"
    drives = ("z",)
    events = ("sunk",)
    priority = 50

    def on_update(self, p: Perception) -> Response:
        return Response({"z": 0.2})


class Flash(Behaviour):
    """A second behaviour that switches the camera."""

    name = "Flash"
    switches = "camera"


@pytest.fixture
def new_behaviours() -> Iterator[None]:
    """Sink and Flash registered for the test only."""
    registry.register(Sink)
    registry.register(Flash)
    try:
        yield
    finally:
        registry.unregister("Sink")
        registry.unregister("Flash")


def enable(stack: IctineuStack, name: str) -> None:
    """What a mission's action does: enable ``name`` on the stack now."""
    stack.on_action(ActionMessage(1, stack.t, "test", "test", "enable", name, {}), stack.t)


def vehicle() -> ardusub.ArduSubVehicle:
    """An ArduSub-like vehicle, never run: its constructor opens no link."""
    return ardusub.ArduSubVehicle("udpout:127.0.0.1:14550", speed=10.0, seed=1)


def test_a_disarm_stops_a_motion_behaviour_no_list_names(new_behaviours: None) -> None:
    v = vehicle()
    stack = v.stack
    assert isinstance(stack.behaviours["Sink"], Sink)  # the stack runs one of each registered
    assert v.command(ARM_DISARM, [1, 0, 0, 0]) == ACCEPTED  # MANUAL: the pilot's Velocity
    enable(stack, "Sink")
    z0 = stack.robot.state.z
    stack.due(stack.t + 2.0)
    # the coordinator ranks it by its priority: z is Sink's, the rest the pilot's
    assert stack.coordinator.last_owner == {"x": "Velocity", "y": "Velocity", "z": "Sink",
                                            "yaw": "Velocity"}
    assert stack.robot.state.z > z0 + 0.05  # and it moves the vehicle down
    assert v.command(ARM_DISARM, [0, 0, 0, 0]) == ACCEPTED
    assert not stack.behaviours["Sink"].active  # disarmed, nothing moves
    assert [n for n, b in stack.behaviours.items() if b.active and b.drives] == []


def test_a_change_of_mode_stops_it_too(new_behaviours: None) -> None:
    v = vehicle()
    assert v.command(ARM_DISARM, [1, 0, 0, 0]) == ACCEPTED
    enable(v.stack, "Sink")
    assert "Sink" in v.moving() and "Velocity" in v.moving()
    assert v.set_mode(ardusub.MODES["SURFACE"]) == ACCEPTED
    on = sorted(n for n, b in v.stack.behaviours.items() if b.active)
    assert on == ["Surface"]  # only what SURFACE does


def test_the_camera_s_commands_switch_every_behaviour_that_switches_it(
        new_behaviours: None) -> None:
    v = vehicle()
    camera = v.stack.sensors.camera
    assert v.command(int(mav.MAV_CMD_IMAGE_START_CAPTURE), [0, 0, 0, 0]) == ACCEPTED
    assert v.stack.behaviours["StartCamera"].active and v.stack.behaviours["Flash"].active
    assert camera.on and not v.stack.behaviours["StartLogs"].active
    assert v.command(int(mav.MAV_CMD_IMAGE_STOP_CAPTURE), [0, 0, 0, 0]) == ACCEPTED
    assert not v.stack.behaviours["Flash"].active and not camera.on
    assert v.command(int(mav.MAV_CMD_LOGGING_START), [0, 0, 0, 0]) == ACCEPTED
    assert [n for n, b in v.stack.behaviours.items() if b.active] == ["StartLogs"]


def test_without_the_test_s_behaviours_the_stack_has_the_shipped_ones() -> None:
    assert "Sink" not in vehicle().stack.behaviours  # the fixture took it out again
