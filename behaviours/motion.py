"""The behaviours that move the vehicle: GoTo, WallInspection, AchieveHeadDist, Surface.

Each drives the degrees of freedom AAL.md gives it and raises its events. Gains and speed
limits are plausible values for a slow inspection AUV (Ictineu surveys at about 0.1 m/s over
the wall, paper 002 §7); they are constructor arguments so that a user can tune them.
"""

from __future__ import annotations

import math
from typing import Any

from .base import Behaviour, Perception, Response, clamp, wrap


class GoTo(Behaviour):
    """Go to (x, y, z, yaw) in the world frame; 'reached' within the tolerance."""

    name = "GoTo"
    drives = ("x", "y", "z", "yaw")
    events = ("reached", "failed")

    def __init__(self, speed: float = 0.4, gain: float = 0.5, yaw_gain: float = 0.4) -> None:
        super().__init__()
        self.speed, self.gain, self.yaw_gain = speed, gain, yaw_gain

    def on_update(self, p: Perception) -> Response:
        tx, ty, tz = (self.param(k, getattr(p, k)) for k in ("x", "y", "z"))
        tyaw = math.radians(self.param("yaw", math.degrees(p.psi)))
        ex, ey, ez = tx - p.x, ty - p.y, tz - p.z
        eyaw = wrap(tyaw - p.psi)
        c, s = math.cos(p.psi), math.sin(p.psi)
        # world error into the body frame
        eu, ev = c * ex + s * ey, -s * ex + c * ey
        horizontal = math.hypot(eu, ev)
        scale = min(1.0, self.speed / (self.gain * horizontal)) if horizontal > 1e-9 else 1.0
        if math.sqrt(ex * ex + ey * ey + ez * ez) < self.param("tolerance", 0.5) and \
                abs(eyaw) < math.radians(5):
            self.raise_event("reached")
        return Response({"x": self.gain * eu * scale, "y": self.gain * ev * scale,
                         "z": clamp(self.gain * ez, self.speed), "yaw": clamp(
                             self.yaw_gain * eyaw, 0.3)})


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
    """Follow a path of (y, z) waypoints in front of the wall, moving in sway and heave."""

    name = "WallInspection"
    drives = ("y", "z")
    events = ("done", "failed")

    def __init__(self, speed: float = 0.12, tolerance: float = 0.15) -> None:
        super().__init__()
        self.speed, self.tolerance = speed, tolerance
        self.index = 0

    def on_initialise(self, t: float) -> None:
        self.index = 0
        try:
            self.path = wall_path(self.params.get("path"))
        except ValueError as exc:
            self.path = []
            self.raise_event("failed", reason=str(exc))

    def on_update(self, p: Perception) -> Response:
        if not self.path:
            return Response()
        while self.index < len(self.path):
            wy, wz = self.path[self.index]
            if math.hypot(wy - p.y, wz - p.z) > self.tolerance:
                break
            self.index += 1
        if self.index >= len(self.path):
            self.raise_event("done", waypoints=len(self.path))
            return Response({"y": 0.0, "z": 0.0})
        wy, wz = self.path[self.index]
        ey, ez = wy - p.y, wz - p.z
        d = math.hypot(ey, ez)
        k = self.speed / max(d, self.speed)  # full speed far away, slow down on arrival
        # sway along the wall: world y expressed in the body frame (facing the wall, ~ +v)
        return Response({"y": k * ey * math.cos(p.psi), "z": k * ez})


class AchieveHeadDist(Behaviour):
    """Hold a heading relative to the wall and a distance from it (surge and yaw), with the
    wall tracker's estimates; 'achieved' once both are within bounds for a while, 'lost' when
    the wall is not tracked for too long."""

    name = "AchieveHeadDist"
    drives = ("x", "yaw")
    events = ("achieved", "lost")

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
        heading = math.radians(self.param("heading", 0.0))
        distance = self.param("distance", 1.5)
        e_dist = p.wall_distance - distance
        if p.wall_normal is not None:
            # steer on the compass towards the wall's (static) orientation: smoother than the
            # sonar's relative heading, which it equals once the tracker has converged
            e_head = wrap(p.wall_normal + heading - p.psi)
        else:
            e_head = wrap(heading - p.wall_heading)
        if abs(e_dist) < 0.1 and abs(e_head) < math.radians(2):
            self.good_since = p.t if self.good_since is None else self.good_since
            if p.t - self.good_since >= self.settle:
                self.raise_event("achieved")
        else:
            self.good_since = None
        return Response({"x": clamp(self.gain * e_dist, self.speed),
                         "yaw": clamp(self.yaw_gain * e_head, 0.3)})


class Surface(Behaviour):
    """Rise to the surface; 'surfaced' near it."""

    name = "Surface"
    drives = ("z",)
    events = ("surfaced",)

    def __init__(self, speed: float = 0.3, depth: float = 0.2) -> None:
        super().__init__()
        self.speed, self.depth = speed, depth

    def on_update(self, p: Perception) -> Response:
        if p.z <= self.depth:
            self.raise_event("surfaced")
        return Response({"z": -self.speed})
