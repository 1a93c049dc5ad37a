"""The behaviours ArduSub does not have, run by the MAVLink adapter on top of guided setpoints
(AAL.md), and the thin ones it maps onto ArduSub's own (GoTo on a position target, Surface on
the SURFACE mode, Alarms on STATUSTEXT and the internal barometer).

Each is enabled with the action's params, updated with the vehicle's last telemetry
(:class:`Telemetry`, the local NED frame = the mission's world frame) and answers the setpoint
components it drives; the adapter merges them by :data:`PRIORITY`, as the vehicle's
coordinator does (vehicle/coordinator.py), and sends the events they raise (once per enable).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

from behaviours.base import wrap
from behaviours.motion import wall_path

SURFACE_DEPTH = 0.2  # m: Surface.surfaced at or above this depth
LOOKAHEAD = 0.3  # m ahead on a WallInspection leg: the vehicle follows at a survey pace
WAYPOINT_TOLERANCE = 0.15  # m: a WallInspection waypoint is passed this close
WALL_PATIENCE = 10.0  # vehicle s without the wall before AchieveHeadDist.lost
SETTLE = 3.0  # vehicle s within bounds before AchieveHeadDist.achieved


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


class Behaviour:
    """A behaviour as the adapter runs it: enabled with the action's params, updated with the
    telemetry, answering the setpoint components it drives and raising its events."""

    drives: tuple[str, ...] = ()

    def __init__(self, name: str) -> None:
        self.name = name
        self.active = False
        self.params: dict[str, Any] = {}
        self.raised: set[str] = set()
        self.events: list[tuple[str, dict[str, Any]]] = []

    def enable(self, params: dict[str, Any], tel: Telemetry) -> None:
        self.active, self.params, self.raised = True, dict(params), set()
        self.start(tel)

    def start(self, tel: Telemetry) -> None:
        pass

    def update(self, tel: Telemetry) -> dict[str, float]:
        return {}

    def raise_event(self, name: str, **data: Any) -> None:
        if name not in self.raised:  # once per enable, as on the vehicle stack
            self.raised.add(name)
            self.events.append((name, data))

    def param(self, key: str, default: float) -> float:
        value = self.params.get(key, default)
        return float(value) if isinstance(value, (int, float)) else default


class GoTo(Behaviour):
    drives = ("x", "y", "z", "yaw")

    def update(self, tel: Telemetry) -> dict[str, float]:
        target = {k: self.param(k, getattr(tel, k)) for k in ("x", "y", "z")}
        if "yaw" in self.params:
            target["yaw"] = math.radians(self.param("yaw", 0.0))
        error = math.dist((target["x"], target["y"], target["z"]), (tel.x, tel.y, tel.z))
        yaw_ok = abs(wrap(target.get("yaw", tel.yaw) - tel.yaw)) < math.radians(5)
        if error < self.param("tolerance", 0.5) and yaw_ok:
            self.raise_event("reached")
        return target


class WallInspection(Behaviour):
    drives = ("y", "z")

    def start(self, tel: Telemetry) -> None:
        self.index = 0
        self.leg_start = (tel.y, tel.z)
        try:
            self.path = wall_path(self.params.get("path"))
        except ValueError as exc:
            self.path = []
            self.raise_event("failed", reason=str(exc))

    def update(self, tel: Telemetry) -> dict[str, float]:
        if not self.path:
            return {}
        while self.index < len(self.path) and \
                math.dist(self.path[self.index], (tel.y, tel.z)) <= WAYPOINT_TOLERANCE:
            self.leg_start = self.path[self.index]
            self.index += 1
        if self.index >= len(self.path):
            self.raise_event("done", waypoints=len(self.path))
            y, z = self.path[-1]
            return {"y": y, "z": z}
        y, z = lookahead(self.leg_start, self.path[self.index], (tel.y, tel.z))
        return {"y": y, "z": z}


def lookahead(a: tuple[float, float], b: tuple[float, float], p: tuple[float, float]
              ) -> tuple[float, float]:
    """The point LOOKAHEAD beyond p's projection on the leg a -> b, not past b."""
    dy, dz = b[0] - a[0], b[1] - a[1]
    length = math.hypot(dy, dz)
    if length < 1e-9 or math.dist(p, b) <= LOOKAHEAD:
        return b
    s = ((p[0] - a[0]) * dy + (p[1] - a[1]) * dz) / length
    s = min(length, max(0.0, s) + LOOKAHEAD)
    return a[0] + dy * s / length, a[1] + dz * s / length


class AchieveHeadDist(Behaviour):
    drives = ("x", "yaw")

    def start(self, tel: Telemetry) -> None:
        self.good_since: float | None = None
        self.since = tel.t

    def update(self, tel: Telemetry) -> dict[str, float]:
        seen = max(self.since, tel.wall_seen_at)
        if tel.wall_distance is None or tel.wall_point is None:
            self.good_since = None
            if tel.t - seen > WALL_PATIENCE:
                self.raise_event("lost", reason="wall not tracked")
            return {}
        heading, distance = math.radians(self.param("heading", 0.0)), self.param("distance", 1.5)
        normal = tel.yaw + tel.wall_bearing  # world direction of the wall's normal
        e_head = wrap(tel.wall_bearing + heading)
        if abs(tel.wall_distance - distance) < 0.1 and abs(e_head) < math.radians(2):
            self.good_since = tel.t if self.good_since is None else self.good_since
            if tel.t - self.good_since >= SETTLE:
                self.raise_event("achieved")
        else:
            self.good_since = None
        return {"x": tel.wall_point[0] - distance * math.cos(normal), "yaw": normal + heading}


class Surface(Behaviour):
    drives = ("z",)

    def update(self, tel: Telemetry) -> dict[str, float]:
        if tel.z <= SURFACE_DEPTH:
            self.raise_event("surfaced")
        return {}


class Alarms(Behaviour):
    def update(self, tel: Telemetry) -> dict[str, float]:
        for alarm in sorted(tel.alarms):
            self.raise_event(alarm)
        if tel.temperature is not None and tel.temperature > self.param("max_temperature", 50):
            self.raise_event("overtemperature", temperature=tel.temperature)
        if tel.pressure is not None and tel.pressure > self.param("max_pressure", 1.5):
            self.raise_event("overpressure", pressure=tel.pressure)
        return {}


PRIORITY = ("Surface", "AchieveHeadDist", "WallInspection", "GoTo")  # as vehicle/coordinator
