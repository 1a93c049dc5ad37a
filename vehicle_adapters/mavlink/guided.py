"""The behaviours the adapter runs on ArduSub's GUIDED mode, merged by the one coordinator.

The adapter runs one of each registered behaviour that has a position law
(``Behaviour.on_setpoints``, behaviours/base.py: the shared classes of behaviours/motion.py and
behaviours/sensing.py, and any registered since with one): a new behaviour with a position law
runs over MAVLink with no file of this package edited. Each position of the vehicle
(LOCAL_POSITION_NED) ticks the enabled ones' position laws with what they perceive
(vehicle_adapters/mavlink/telemetry.py); the coordinator
(behaviours/coordinator.py) gives each degree of freedom to the highest-priority one that asks
for it, and a free one holds its last value. The merged target goes out as a
SET_POSITION_TARGET_LOCAL_NED (position and yaw) when it moves (at most every
``SETPOINT_PERIOD`` vehicle s) and every ``SETPOINT_REFRESH`` vehicle s anyway (UDP). While
Surface is on, ArduSub's SURFACE mode drives and no setpoint is sent.
"""

from __future__ import annotations

import math
from typing import Any

from pymavlink.dialects.v20 import ardupilotmega as mavlink

from aal.mavlink import VEHICLE_SYSID
from behaviours import registry
from behaviours.base import DOFS, Behaviour, Perception, Response
from behaviours.coordinator import Coordinator

from vehicle_adapters.mavlink.commands import VEHICLE_COMPID

SURFACING = "Surface"  # the behaviour ArduSub has as a mode of its own, SURFACE
POSITION_AND_YAW = 0b1001_1111_1000  # type_mask: ignore velocity, acceleration, yaw rate
SETPOINT_PERIOD = 0.5  # vehicle s between setpoints while a target moves
SETPOINT_REFRESH = 2.0  # vehicle s: a constant target is sent again this often (UDP)

Event = tuple[str, str, dict[str, Any]]  # (behaviour, event, data)


class Guided:
    """The adapter's behaviours (one of each registered with a position law, by name), their
    coordinator, and the last setpoint. Not thread-safe: the adapter calls it with its lock
    held."""

    def __init__(self) -> None:
        offered = registry.with_position_law()
        self.behaviours: dict[str, Behaviour] = {  # ticked in order of priority
            cls.name: cls() for cls in sorted(offered, key=lambda c: -c.priority)}
        self.coordinator = Coordinator()
        self.hold: dict[str, float] = {}  # the last setpoint, per degree of freedom
        self.setpoint_at = -math.inf  # vehicle time of the last setpoint

    @property
    def surfacing(self) -> bool:
        """ArduSub's SURFACE mode is on the mission's behalf (its Surface behaviour enabled)."""
        surface = self.behaviours.get(SURFACING)
        return surface is not None and surface.active

    def on(self) -> list[str]:
        """The behaviours enabled, by name."""
        return sorted(n for n, b in self.behaviours.items() if b.active)

    def act(self, name: str, kind: str, params: dict[str, Any], p: Perception,
            guided: bool) -> str:
        """Enable, disable or configure a behaviour at ``p``; the mode ArduSub must switch to
        for it ('SURFACE', 'GUIDED'; '' to stay), given whether it is in GUIDED."""
        b = self.behaviours[name]
        was_surfacing = self.surfacing
        if kind == "enable":
            b.initialise(params, p.t)
        elif kind == "disable":
            b.terminate(p.t)
        else:
            b.configure(params, p.t)
        if self.surfacing and not was_surfacing:
            return "SURFACE"
        if was_surfacing and not self.surfacing:
            self.hold = here(p)  # back under the adapter's setpoints, from where it is now
            return "GUIDED"
        if kind == "enable" and b.drives and not self.surfacing and not guided:
            return "GUIDED"  # e.g. after the vehicle's own failsafe
        return ""

    def resend(self) -> None:
        """The next tick sends its setpoint, changed or not (a behaviour was enabled)."""
        self.setpoint_at = -math.inf

    def events(self, name: str) -> list[Event]:
        """The events a behaviour has raised and not yet said."""
        return [(name, event, data) for event, data in self.behaviours[name].take_events()]

    def tick(self, p: Perception) -> tuple[list[Event], Any]:
        """Update the enabled behaviours: their events, in priority order, and the
        SET_POSITION_TARGET_LOCAL_NED to send (None: none now)."""
        on = [b for b in self.behaviours.values() if b.active]
        responses: dict[str, Response] = {b.name: b.update_setpoints(p) for b in on}
        events = [e for b in on for e in self.events(b.name)]
        self.coordinator.merge(responses)
        if self.surfacing or not any(b.drives for b in on):
            return events, None
        target, hold = self.coordinator.last_setpoints, here(p)
        full = {dof: target.get(dof, self.hold.get(dof, hold[dof])) for dof in DOFS}
        changed = any(abs(full[d] - self.hold.get(d, math.inf)) > 0.01 for d in full)
        since = p.t - self.setpoint_at
        if not ((changed and since >= SETPOINT_PERIOD) or since >= SETPOINT_REFRESH):
            return events, None
        self.hold, self.setpoint_at = full, p.t
        return events, setpoint(full, p.t)


def here(p: Perception) -> dict[str, float]:
    """Where the vehicle is, per degree of freedom (x, y, z m world NED; yaw rad)."""
    return {"x": p.x, "y": p.y, "z": p.z, "yaw": p.psi}


def setpoint(target: dict[str, float], t: float) -> Any:
    """A SET_POSITION_TARGET_LOCAL_NED holding ``target`` (vehicle time ``t``)."""
    return mavlink.MAVLink_set_position_target_local_ned_message(
        int(t * 1000) & 0xFFFFFFFF, VEHICLE_SYSID, VEHICLE_COMPID,
        mavlink.MAV_FRAME_LOCAL_NED, POSITION_AND_YAW, target["x"], target["y"],
        target["z"], 0, 0, 0, 0, 0, 0, target["yaw"], 0)
