"""The behaviours that move the vehicle: GoTo, WallInspection, AchieveHeadDist, Surface.

Each drives the degrees of freedom docs/AAL.md gives it and raises its events. Gains and speed
limits are plausible values for a slow inspection AUV (Ictineu surveys at about 0.1 m/s over
the wall, paper 002 §7); they are constructor arguments so that a user can tune them.

Each has both control laws (behaviours/base.py): velocity demands (``on_update``: the simulated
Ictineu's controller) and position setpoints (``on_setpoints``: an autopilot that holds
positions, ArduSub in GUIDED, run by the MAVLink adapter, docs/MAVLINK.md). The position laws:

- GoTo: its target as the setpoint; ``reached`` within the tolerance and 5 deg of the yaw.
- WallInspection (ArduSub has none): walks its (y, z) waypoints with a look-ahead point on each
  leg, so that the autopilot's position controller moves at a survey pace.
- AchieveHeadDist (ArduSub has none): holds the vehicle at the distance from the wall's foot
  (``Perception.wall_point``: ArduSub's DISTANCE_SENSOR), turned to the heading.
- Surface: the autopilot's own surfacing does the work (ArduSub's SURFACE mode); no setpoint.
"""

from __future__ import annotations

import math
from typing import Any

from behaviours.base import Behaviour, Perception, Response, clamp, path_left, wrap

LOOKAHEAD = 0.3  # m ahead on a WallInspection leg (position law): a survey pace


class Reach:
    """Whether a target can still be reached, for the behaviours that move the vehicle to one:
    a reason when it cannot, else None. Outside the working area (``Perception.area``); deeper
    than the floor seen by the DVL (depth plus altitude) less ``clearance``; or no progress of
    ``progress`` m (yaw counted as 1 m/rad) for ``patience`` s, whatever stopped the vehicle,
    named from what the sensors show (the wall tracker's distance, the DVL's altitude)."""

    def __init__(self, t: float, clearance: float, patience: float, progress: float) -> None:
        self.clearance, self.patience, self.progress = clearance, patience, progress
        self.floor: float | None = None  # m, the floor's depth under the vehicle (DVL)
        self.best = math.inf  # the smallest remaining error so far
        self.best_at = t

    def check(self, p: Perception, tx: float, ty: float, tz: float,
              error: float) -> str | None:
        if p.area is not None:
            x0, x1, y0, y1 = p.area
            if not (x0 <= tx <= x1 and y0 <= ty <= y1):
                return (f"the target ({tx:g}, {ty:g}) is outside the working area "
                        f"(x {x0:g}..{x1:g} m, y {y0:g}..{y1:g} m)")
        if p.altitude is not None:
            self.floor = p.z + p.altitude
        if self.floor is not None and tz > self.floor - self.clearance:
            return (f"the target depth {tz:g} m is beyond the floor at {self.floor:.1f} m "
                    f"(the vehicle's centre stays {self.clearance:g} m above it)")
        if error < self.best - self.progress:
            self.best, self.best_at = error, p.t
            return None
        if p.t - self.best_at < self.patience:
            return None
        stopped = f"no progress for {self.patience:g} s, {error:.1f} m short of the target"
        if p.wall_distance is not None and p.wall_distance < self.clearance + 0.3:
            if p.wall_normal is not None:
                n = (math.cos(p.wall_normal), math.sin(p.wall_normal))
                beyond = (tx - p.x) * n[0] + (ty - p.y) * n[1] - p.wall_distance
                if beyond > -self.clearance:
                    return (f"the target is inside the wall ({beyond:.1f} m beyond it): "
                            f"stopped at the wall, {stopped}")
            return f"stopped at the wall ({p.wall_distance:.2f} m from it): {stopped}"
        if p.altitude is None or p.altitude < self.clearance + 0.3:
            return f"stopped at the floor: {stopped}"
        return f"stopped: {stopped}"


class GoTo(Behaviour):
    """Go to (x, y, z, yaw) in the world frame; 'reached' within the tolerance.

    'failed', with a ``reason`` and the target and position in its data, when the target cannot
    be reached: it lies outside the working area the vehicle is given (``Perception.area``), or
    deeper than the floor seen by the DVL less ``clearance``; or, whatever stops the vehicle
    (the wall, the floor, a bank), when it makes no progress for ``patience`` s (see
    :class:`Reach`). After failing it demands nothing (the vehicle stays where it stopped)
    until it is disabled.
    """

    name = "GoTo"
    drives = ("x", "y", "z", "yaw")
    events = ("reached", "failed")
    parameters = ("x", "y", "z", "yaw", "tolerance")
    priority = 10  # a transit gives way to everything else

    def __init__(self, speed: float = 0.4, gain: float = 0.5, yaw_gain: float = 0.4,
                 clearance: float = 0.4, patience: float = 30.0, progress: float = 0.1) -> None:
        super().__init__()
        self.speed, self.gain, self.yaw_gain = speed, gain, yaw_gain
        self.clearance, self.patience, self.progress = clearance, patience, progress
        self.failed = False

    def on_initialise(self, t: float) -> None:
        self.failed = False
        self.reach = Reach(t, self.clearance, self.patience, self.progress)

    def on_update(self, p: Perception) -> Response:
        if self.failed:
            return Response({"x": 0.0, "y": 0.0, "z": 0.0, "yaw": 0.0})
        (tx, ty, tz, _), distance, eyaw = self.aim(p)
        ex, ey, ez = tx - p.x, ty - p.y, tz - p.z
        if self.reached(distance, eyaw):
            self.raise_event("reached")
        elif not any(n == "reached" for n, _ in self.raised):
            reason = self.reach.check(p, tx, ty, tz, distance + abs(eyaw))
            if reason is not None:
                self.failed = True
                self.raise_event("failed", reason=reason, target=[tx, ty, tz],
                                 position=[round(p.x, 2), round(p.y, 2), round(p.z, 2)])
                return Response({"x": 0.0, "y": 0.0, "z": 0.0, "yaw": 0.0})
        c, s = math.cos(p.psi), math.sin(p.psi)
        # world error into the body frame
        eu, ev = c * ex + s * ey, -s * ex + c * ey
        horizontal = math.hypot(eu, ev)
        scale = min(1.0, self.speed / (self.gain * horizontal)) if horizontal > 1e-9 else 1.0
        return Response({"x": self.gain * eu * scale, "y": self.gain * ev * scale,
                         "z": clamp(self.gain * ez, self.speed), "yaw": clamp(
                             self.yaw_gain * eyaw, 0.3)})


    def on_setpoints(self, p: Perception) -> Response:
        """The target (x, y, z, and yaw if given) as the autopilot's position setpoint."""
        (x, y, z, yaw), distance, eyaw = self.aim(p)
        if self.reached(distance, eyaw):
            self.raise_event("reached")
        target = {"x": x, "y": y, "z": z}
        if "yaw" in self.params:  # else the autopilot keeps its heading
            target["yaw"] = yaw
        return Response(setpoints=target)

    def progress_report(self) -> dict[str, float | int] | None:
        """The straight-line distance to the target (m)."""
        if self.seen is None:
            return None
        return {"to_go": round(self.aim(self.seen)[1], 1)}

    def aim(self, p: Perception) -> tuple[tuple[float, float, float, float], float, float]:
        """The target (x, y, z, yaw: what the action gives, the vehicle's own for the rest),
        the distance to it (m) and the yaw error (rad)."""
        tx, ty, tz = (self.param(k, getattr(p, k)) for k in ("x", "y", "z"))
        tyaw = self.angle("yaw", p.psi)
        ex, ey, ez = tx - p.x, ty - p.y, tz - p.z
        return (tx, ty, tz, tyaw), math.sqrt(ex * ex + ey * ey + ez * ez), wrap(tyaw - p.psi)

    def reached(self, distance: float, eyaw: float) -> bool:
        """Within the tolerance (m) and 5 degrees of the target."""
        return distance < self.param("tolerance", 0.5) and abs(eyaw) < math.radians(5)


def wall_path(value: Any) -> list[tuple[float, float]]:
    """WallInspection's ``path`` parameter as (y, z) waypoints; ValueError saying what is
    wrong (the behaviour raises ``failed`` with it)."""
    try:
        path = [(float(pt[0]), float(pt[1])) for pt in value or []]
    except (TypeError, ValueError, IndexError):
        raise ValueError("the path is not a list of (y, z) points") from None
    if not path:
        raise ValueError("empty path")
    return path


class WallInspection(Behaviour):
    """Follow a path of (y, z) waypoints in front of the wall, moving in sway and heave: the
    wall survey (its ``path`` is the run's plan)."""

    name = "WallInspection"
    drives = ("y", "z")
    events = ("done", "failed")
    parameters = ("path",)
    priority = 20  # the motion along the wall over a transit
    surveys = True

    def __init__(self, speed: float = 0.12, tolerance: float = 0.15, clearance: float = 0.4,
                 patience: float = 30.0, progress: float = 0.05) -> None:
        super().__init__()
        self.speed, self.tolerance = speed, tolerance
        self.clearance, self.patience, self.progress = clearance, patience, progress
        self.index = 0
        self.failed = False
        self.path: list[tuple[float, float]] = []

    def on_initialise(self, t: float) -> None:
        self.index = 0
        self.failed = False
        self.reach = Reach(t, self.clearance, self.patience, self.progress)
        self.leg_start: tuple[float, float] | None = None  # position law: where it was enabled
        try:
            self.path = wall_path(self.params.get("path"))
        except ValueError as exc:
            self.path = []
            self.raise_event("failed", reason=str(exc))

    def on_update(self, p: Perception) -> Response:
        if not self.path or self.failed:
            return Response({"y": 0.0, "z": 0.0} if self.failed else {})
        while self.index < len(self.path):
            wy, wz = self.path[self.index]
            if math.hypot(wy - p.y, wz - p.z) > self.tolerance:
                break
            self.index += 1
            self.reach.best, self.reach.best_at = math.inf, p.t  # progress to the next one
        if self.index >= len(self.path):
            self.raise_event("done", waypoints=len(self.path))
            return Response({"y": 0.0, "z": 0.0})
        wy, wz = self.path[self.index]
        ey, ez = wy - p.y, wz - p.z
        d = math.hypot(ey, ez)
        reason = self.reach.check(p, p.x, wy, wz, d)
        if reason is not None:
            self.failed = True
            self.raise_event("failed", reason=f"waypoint {self.index + 1}: {reason}",
                             waypoint=[wy, wz], position=[round(p.y, 2), round(p.z, 2)])
            return Response({"y": 0.0, "z": 0.0})
        k = self.speed / max(d, self.speed)  # full speed far away, slow down on arrival
        # sway along the wall: world y expressed in the body frame (facing the wall, ~ +v)
        return Response({"y": k * ey * math.cos(p.psi), "z": k * ez})

    def progress_report(self) -> dict[str, float | int] | None:
        """The waypoint it heads for (k of n) and the length of path still to go (m)."""
        if not self.path or self.seen is None:
            return None
        k = min(self.index, len(self.path) - 1)
        return {"waypoint": k + 1, "of": len(self.path),
                "to_go": round(path_left(self.path, self.index, (self.seen.y, self.seen.z)), 1)}

    def on_setpoints(self, p: Perception) -> Response:
        """The (y, z) waypoints, each leg followed by a point ``LOOKAHEAD`` ahead of the
        vehicle (the autopilot's position controller then moves at a survey pace)."""
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


class AchieveHeadDist(Behaviour):
    """Hold a heading relative to the wall and a distance from it (surge and yaw), with the
    wall tracker's estimates; 'achieved' once both are within bounds for a while, 'lost' when
    the wall is not tracked for too long."""

    name = "AchieveHeadDist"
    drives = ("x", "yaw")
    events = ("achieved", "lost")
    parameters = ("heading", "distance")
    priority = 30  # wall keeping over the motion along the wall

    def __init__(self, gain: float = 0.4, yaw_gain: float = 0.4, speed: float = 0.3,
                 settle: float = 3.0, patience: float = 10.0) -> None:
        super().__init__()
        self.gain, self.yaw_gain, self.speed = gain, yaw_gain, speed
        self.settle, self.patience = settle, patience

    def on_initialise(self, t: float) -> None:
        self.good_since: float | None = None
        self.seen_at = t

    def on_update(self, p: Perception) -> Response:
        if p.wall_distance is None or p.wall_heading is None:
            self.good_since = None  # time without the wall does not count as settled
            if p.t - self.seen_at > self.patience:
                self.raise_event("lost", reason="wall not tracked")
            return Response({"x": 0.0, "yaw": 0.0})
        self.seen_at = p.t
        heading = self.angle("heading", 0.0)
        distance = self.param("distance", 1.5)
        e_dist = p.wall_distance - distance
        if p.wall_normal is not None:
            # steer on the compass towards the wall's (static) orientation: smoother than the
            # sonar's relative heading, which it equals once the tracker has converged
            e_head = wrap(p.wall_normal + heading - p.psi)
        else:
            e_head = wrap(heading - p.wall_heading)
        self.settling(p.t, e_dist, e_head)
        return Response({"x": clamp(self.gain * e_dist, self.speed),
                         "yaw": clamp(self.yaw_gain * e_head, 0.3)})

    def on_setpoints(self, p: Perception) -> Response:
        """The point ``distance`` off the wall's foot along its normal (x) and the heading from
        the normal (yaw); ``lost`` when the wall has not been seen for ``patience`` s."""
        if p.wall_distance is None or p.wall_point is None or p.wall_heading is None \
                or p.wall_normal is None:
            self.good_since = None  # time without the wall does not count as settled
            if p.t - max(self.seen_at, p.wall_seen_at) > self.patience:
                self.raise_event("lost", reason="wall not tracked")
            return Response()
        heading, distance = self.angle("heading", 0.0), self.param("distance", 1.5)
        self.settling(p.t, p.wall_distance - distance, wrap(heading - p.wall_heading))
        return Response(setpoints={"x": p.wall_point[0] - distance * math.cos(p.wall_normal),
                                   "yaw": p.wall_normal + heading})

    def settling(self, t: float, e_dist: float, e_head: float) -> None:
        """'achieved' once within 0.1 m and 2 degrees of the aim for ``settle`` s on end."""
        if abs(e_dist) < 0.1 and abs(e_head) < math.radians(2):
            self.good_since = t if self.good_since is None else self.good_since
            if t - self.good_since >= self.settle:
                self.raise_event("achieved")
        else:
            self.good_since = None


class Surface(Behaviour):
    """Rise to the surface; 'surfaced' near it."""

    name = "Surface"
    drives = ("z",)
    events = ("surfaced",)
    priority = 40  # surfacing wins over everything

    def __init__(self, speed: float = 0.3, depth: float = 0.2) -> None:
        super().__init__()
        self.speed, self.depth = speed, depth

    def on_update(self, p: Perception) -> Response:
        if p.z <= self.depth:
            self.raise_event("surfaced")
        return Response({"z": -self.speed})

    def on_setpoints(self, p: Perception) -> Response:
        """The autopilot's own surfacing rises (ArduSub's SURFACE mode, switched to by the
        MAVLink adapter): ``surfaced`` at the same depth, no setpoint."""
        self.on_update(p)
        return Response()
