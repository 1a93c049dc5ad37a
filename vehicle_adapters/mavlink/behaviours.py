"""ArduSub's control laws for the shared behaviours: the same classes (behaviours/motion.py,
behaviours/sensing.py: name, degrees of freedom, events, parameters, priority, lifecycle),
answering position ``setpoints`` that ArduSub holds in GUIDED instead of velocity demands.

- GoTo: its target as the setpoint; ``reached`` within the tolerance and 5 deg of the yaw.
- WallInspection (ArduSub has none): walks its (y, z) waypoints with a look-ahead point on each
  leg, so that ArduSub's position controller moves at a survey pace.
- AchieveHeadDist (ArduSub has none): holds the vehicle at the distance from the wall's foot
  (DISTANCE_SENSOR), turned to the heading.
- Surface: ArduSub's SURFACE mode does the work (the adapter switches to it); no setpoint.
- Alarms: the alarms ArduSub said in STATUSTEXT, then the internal barometer's readings.

They perceive an :class:`ArduSubPerception`: the shared :class:`Perception` (psi = ATTITUDE's
yaw, the local NED frame = the mission's world frame) and what the MAVLink telemetry adds.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from behaviours import motion, sensing
from behaviours.base import Behaviour, Perception, Response, wrap

LOOKAHEAD = 0.3  # m ahead on a WallInspection leg: the vehicle follows at a survey pace


@dataclass(frozen=True)
class ArduSubPerception(Perception):
    """The shared perception and what ArduSub's telemetry adds to it."""

    wall_point: tuple[float, float] | None = None  # (x, y) of the wall's foot, last seen
    wall_seen_at: float = -math.inf  # vehicle s of the last DISTANCE_SENSOR on the wall
    alarms: frozenset[str] = frozenset()  # latched from STATUSTEXT: "leak", ...


def perceived(p: Perception) -> ArduSubPerception:
    """``p`` as the MAVLink adapter perceives (it builds no other kind)."""
    if not isinstance(p, ArduSubPerception):
        raise TypeError("the MAVLink behaviours perceive an ArduSubPerception")
    return p


class GoTo(motion.GoTo):
    """The target (x, y, z, and yaw if given) as ArduSub's position setpoint."""

    def on_update(self, p: Perception) -> Response:
        (x, y, z, yaw), distance, eyaw = self.aim(p)
        if self.reached(distance, eyaw):
            self.raise_event("reached")
        target = {"x": x, "y": y, "z": z}
        if "yaw" in self.params:  # else ArduSub keeps its heading
            target["yaw"] = yaw
        return Response(setpoints=target)


class WallInspection(motion.WallInspection):
    """The (y, z) waypoints, each leg followed by a point ``LOOKAHEAD`` ahead of the vehicle."""

    def on_initialise(self, t: float) -> None:
        super().on_initialise(t)  # the path (or 'failed' saying what is wrong with it)
        self.leg_start: tuple[float, float] | None = None  # where the vehicle was enabled

    def on_update(self, p: Perception) -> Response:
        if not self.path:
            return Response()
        here = (p.y, p.z)
        if self.leg_start is None:
            self.leg_start = here
        while self.index < len(self.path) and \
                math.dist(self.path[self.index], here) <= self.tolerance:
            self.leg_start = self.path[self.index]
            self.index += 1
        if self.index >= len(self.path):
            self.raise_event("done", waypoints=len(self.path))
            y, z = self.path[-1]
        else:
            y, z = lookahead(self.leg_start, self.path[self.index], here)
        return Response(setpoints={"y": y, "z": z})


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


class AchieveHeadDist(motion.AchieveHeadDist):
    """The point ``distance`` off the wall's foot along its normal (x) and the heading from
    the normal (yaw); ``lost`` when the wall has not been seen for ``patience`` vehicle s."""

    def on_update(self, p: Perception) -> Response:
        a = perceived(p)
        if a.wall_distance is None or a.wall_point is None or a.wall_heading is None \
                or a.wall_normal is None:
            self.good_since = None  # time without the wall does not count as settled
            if a.t - max(self.seen_at, a.wall_seen_at) > self.patience:
                self.raise_event("lost", reason="wall not tracked")
            return Response()
        heading, distance = self.angle("heading", 0.0), self.param("distance", 1.5)
        self.settling(a.t, a.wall_distance - distance, wrap(heading - a.wall_heading))
        return Response(setpoints={"x": a.wall_point[0] - distance * math.cos(a.wall_normal),
                                   "yaw": a.wall_normal + heading})


class Surface(motion.Surface):
    """ArduSub's SURFACE mode rises (the adapter switches to it): ``surfaced`` near the top."""

    def on_update(self, p: Perception) -> Response:
        super().on_update(p)  # 'surfaced' at the shared depth; its velocity is not asked for
        return Response()


class Alarms(sensing.Alarms):
    """The alarms ArduSub latched from its STATUSTEXTs first, then the shared thresholds on the
    internal barometer (a reading not sent is NaN: no alarm)."""

    def on_update(self, p: Perception) -> Response:
        for alarm in sorted(perceived(p).alarms):
            self.raise_event(alarm)
        return super().on_update(p)


ALL: tuple[type[Behaviour], ...] = (Surface, AchieveHeadDist, WallInspection, GoTo, Alarms)
"""The behaviours the adapter runs itself (the others are commands or not mapped)."""
