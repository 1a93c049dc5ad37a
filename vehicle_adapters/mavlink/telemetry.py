"""The vehicle's telemetry, decoded into what the behaviours perceive (docs/AAL.md,
docs/MAVLINK.md).

The adapter asks for the streams in :data:`RATES` (MAV_CMD_SET_MESSAGE_INTERVAL) and stops
those it does not use. :class:`Telemetry` keeps the last of each (the local NED frame = the
mission's world frame): LOCAL_POSITION_NED, ATTITUDE's yaw, DISTANCE_SENSOR's wall (distance
and the bearing of its normal, quaternion with MAV_SENSOR_ROTATION_CUSTOM), the alarms
ArduSub says in STATUSTEXT and the internal barometer (SCALED_PRESSURE).
:func:`perceive` turns it into the :class:`behaviours.base.Perception` the behaviours' position laws
read (with the wall's foot and the autopilot's alarms).
"""

from __future__ import annotations

import logging
import math
from collections import deque
from dataclasses import dataclass, field
from typing import Any

from pymavlink.dialects.v20 import ardupilotmega as mavlink

from behaviours.base import Perception, wrap

log = logging.getLogger(__name__)

# the telemetry the adapter asks for (Hz; the vehicle's clock says what a second is) and the
# streams it stops (None): what it does not use only loads the link, the vehicle and a router
RATES: dict[str, float | None] = {
    "LOCAL_POSITION_NED": 5.0, "ATTITUDE": 5.0, "DISTANCE_SENSOR": 5.0, "SYSTEM_TIME": 1.0,
    "SYS_STATUS": 1.0, "SCALED_PRESSURE": 1.0, "GLOBAL_POSITION_INT": None, "VFR_HUD": None,
    "SCALED_PRESSURE2": None, "BATTERY_STATUS": None}
ALARM_TEXTS = {"leak": "leak", "temperature": "overtemperature", "pressure": "overpressure"}
CUSTOM_ORIENTATION = 100  # MAV_SENSOR_ROTATION_CUSTOM: the quaternion gives the bearing


def intervals() -> list[tuple[int, float]]:
    """(message id, interval in us; -1: stop it) for each stream in :data:`RATES`."""
    return [(getattr(mavlink, f"MAVLINK_MSG_ID_{name}"), 1e6 / hz if hz else -1)
            for name, hz in RATES.items()]


@dataclass
class Telemetry:
    """What the vehicle last said about itself (local NED frame = the world frame)."""

    t: float = 0.0  # vehicle s of the last position
    x: float = 0.0
    y: float = 0.0
    z: float = 0.0
    yaw: float = 0.0  # rad
    positioned: bool = False  # a LOCAL_POSITION_NED has come
    wall_distance: float | None = None  # m, perpendicular; None: not tracked
    wall_bearing: float = 0.0  # rad, from the heading to the wall's normal
    wall_point: tuple[float, float] | None = None  # (x, y) of the wall's foot, last seen
    wall_seen_at: float = -math.inf
    alarms: set[str] = field(default_factory=set)  # latched: "leak", "overtemperature", ...
    temperature: float | None = None  # deg C inside (SCALED_PRESSURE), if sent
    pressure: float | None = None  # bar inside
    texts: deque[tuple[int, str]] = field(default_factory=lambda: deque(maxlen=100))
    # the last STATUSTEXTs, (severity, text)

    def decode(self, msg: Any) -> bool:
        """Take in one of the vehicle's messages; True when it is a new position (the
        behaviours' tick)."""
        kind: str = msg.get_type()
        handler = getattr(self, f"_on_{kind.lower()}", None)
        if handler is not None:
            handler(msg)
        return kind == "LOCAL_POSITION_NED"

    def critical_text(self) -> str:
        """The last thing the vehicle said at CRITICAL or worse ('' if nothing)."""
        return next((text for severity, text in reversed(self.texts)
                     if severity <= mavlink.MAV_SEVERITY_CRITICAL), "")

    def _on_attitude(self, msg: Any) -> None:
        self.yaw = msg.yaw

    def _on_local_position_ned(self, msg: Any) -> None:
        self.t, self.x, self.y, self.z = msg.time_boot_ms / 1000, msg.x, msg.y, msg.z
        self.positioned = True

    def _on_distance_sensor(self, msg: Any) -> None:
        if not msg.min_distance <= msg.current_distance <= msg.max_distance:
            self.wall_distance = None  # MAVLink's "nothing detected": max_distance + 1
            return
        q = list(msg.quaternion)
        custom = msg.orientation == CUSTOM_ORIENTATION and any(q)
        bearing = 2 * math.atan2(q[3], q[0]) if custom else 0.0
        self.wall_distance, self.wall_bearing = msg.current_distance / 100.0, wrap(bearing)
        normal = self.yaw + self.wall_bearing
        self.wall_point = (self.x + self.wall_distance * math.cos(normal),
                           self.y + self.wall_distance * math.sin(normal))
        self.wall_seen_at = msg.time_boot_ms / 1000

    def _on_statustext(self, msg: Any) -> None:
        text = msg.text if isinstance(msg.text, str) else msg.text.decode("utf-8", "replace")
        self.texts.append((msg.severity, text))
        log.info("vehicle says: %s", text)
        if msg.severity <= mavlink.MAV_SEVERITY_CRITICAL:
            for word, alarm in ALARM_TEXTS.items():
                if word in text.lower():
                    self.alarms.add(alarm)

    def _on_scaled_pressure(self, msg: Any) -> None:  # the internal barometer (ArduSub)
        self.temperature, self.pressure = msg.temperature / 100, msg.press_abs / 1000


def perceive(tel: Telemetry) -> Perception:
    """What the behaviours perceive of the telemetry (psi = yaw; the wall's heading relative
    to its normal and the normal's world direction from DISTANCE_SENSOR's bearing; a
    barometer reading not sent is NaN)."""
    seen = tel.wall_distance is not None
    return Perception(
        t=tel.t, x=tel.x, y=tel.y, z=tel.z, psi=tel.yaw, wall_distance=tel.wall_distance,
        wall_heading=-tel.wall_bearing if seen else None,
        wall_normal=tel.yaw + tel.wall_bearing if seen else None,
        leak="leak" in tel.alarms,
        temperature=math.nan if tel.temperature is None else tel.temperature,
        pressure=math.nan if tel.pressure is None else tel.pressure,
        wall_point=tel.wall_point, wall_seen_at=tel.wall_seen_at,
        alarms=frozenset(tel.alarms))
