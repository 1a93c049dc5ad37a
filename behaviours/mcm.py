"""The behaviours of paper 003's mine countermeasures: the ASV's and the UUV's, in the one
behaviour model (behaviours/base.py), declared in ``missions/asv.tasks`` and
``missions/uuv.tasks``.

ASV (navigates in {E}, good navigation): :class:`KeepStation` goes to the point ``distance``
short of the mine on the line from where it started and holds there facing the mine;
:class:`Reacquire` waits until the multibeam has re-found the mine and set the frame {T};
:class:`DetectUUV` waits for the sonar's first detection of the UUV (``acquired``);
:class:`TrackUUV` watches them: ``landed`` when they stay still for ``still`` seconds after
the UUV has gone 5 m, ``lost`` after ``patience`` seconds without one.

UUV (navigates in {T}, the mine at its origin): :class:`KeepDepth` (2 m until acquired,
§2); :class:`FollowLine` follows the line from where it is enabled to above the mine on its
navigator's estimate (the ASV's fixes), descending to ``height`` above the mine: ``near``
within ``distance`` of it; :class:`Home` homes on the camera to a point short of the mine,
facing it: ``over`` there, ``lost`` when the camera has not seen it for ``patience``
seconds; :class:`Land` descends to the bottom holding that point: ``landed``;
:class:`Snapshot` takes the verifying picture: ``taken`` if the mine is in it, ``missed``
otherwise; :class:`Ascend` surfaces (the Ictineu's Surface, renamed).

They are not in the Ictineu's registry (behaviours/registry.py): each stack runs its own
(vehicle/control/asv_stack.py, uuv_stack.py) and declares them from the classes
(mission/mcm_vehicles.py); tests/behaviours/test_mcm.py checks the libraries against them.

What they read beyond :class:`Perception` is in :class:`McmPerception`, filled by the stacks
(vehicle/control/asv_stack.py, vehicle/control/uuv_stack.py).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from behaviours.base import Behaviour, Perception, Response, clamp, wrap
from behaviours.motion import Surface


@dataclass(frozen=True)
class McmPerception(Perception):
    """What the mine countermeasure behaviours perceive besides the vehicle's own estimate.

    ASV: ``mine`` where it believes the mine is ({E}, m; the survey's map, then the
    reacquired position), ``reacquired`` once the sonar has set {T}, ``start`` where it
    started ({E}), ``uuv_track`` the sonar's recent detections of the UUV (t, x, y in {T}).
    UUV: ``sighted_at`` when the camera last saw the mine (s), ``fix_at`` when the last fix
    was heard (s), ``fixes`` how many have been fused, ``mine_depth`` the mine's depth (the
    release message carries it; None before)."""

    mine: tuple[float, float] | None = None
    reacquired: bool = False
    start: tuple[float, float] = (0.0, 0.0)
    uuv_track: tuple[tuple[float, float, float], ...] = ()
    sighted_at: float = -math.inf
    fix_at: float = -math.inf
    fixes: int = 0
    mine_depth: float | None = None  # m, the mine's top in {T} (sent with 'release')


def as_mcm(p: Perception) -> McmPerception:
    """The perception as a mine countermeasure one (a plain one: nothing perceived beyond)."""
    return p if isinstance(p, McmPerception) else McmPerception(p.t, p.x, p.y, p.z, p.psi)


def below(p: Perception, height: float, otherwise: float) -> float:
    """The depth (m) ``height`` m above the mine's top; ``otherwise`` when it is not known."""
    depth = as_mcm(p).mine_depth
    return otherwise if depth is None else max(depth - height, 0.0)


def steer(heading_error: float, gain: float = 0.8, limit: float = 0.4) -> float:
    """A yaw-rate demand (rad/s) that turns the heading error to zero."""
    return clamp(gain * wrap(heading_error), limit)


# -- the ASV ------------------------------------------------------------------------------------
class KeepStation(Behaviour):
    """Go to the station ``distance`` m short of the mine (on the line from the start) and
    hold it, facing the mine. Latched: no event."""

    name = "KeepStation"
    drives = ("x", "yaw")
    parameters = ("distance",)

    def station(self, p: McmPerception) -> tuple[float, float] | None:
        if p.mine is None:
            return None
        mx, my = p.mine
        sx, sy = p.start
        span = math.hypot(mx - sx, my - sy) or 1.0
        d = min(self.param("distance", 15.0), span)
        return mx - (mx - sx) / span * d, my - (my - sy) / span * d

    def on_update(self, p: Perception) -> Response:
        q = as_mcm(p)
        here = self.station(q)
        if here is None or q.mine is None:
            return Response({"x": 0.0, "yaw": 0.0})
        dx, dy = here[0] - q.x, here[1] - q.y
        gap = math.hypot(dx, dy)
        facing = math.atan2(q.mine[1] - q.y, q.mine[0] - q.x)
        if gap > 1.5:  # transit: head for the station
            heading = math.atan2(dy, dx)
            along = clamp(0.4 * gap, 1.0) * max(math.cos(wrap(heading - q.psi)), 0.0)
            return Response({"x": along, "yaw": steer(heading - q.psi)})
        along = clamp(0.3 * (dx * math.cos(q.psi) + dy * math.sin(q.psi)), 0.3)
        return Response({"x": along, "yaw": steer(facing - q.psi)})


class Reacquire(Behaviour):
    """Ends ``reacquired`` once the multibeam has re-found the mine and set the frame {T}."""

    name = "Reacquire"
    events = ("reacquired",)

    def on_update(self, p: Perception) -> Response:
        if as_mcm(p).reacquired:
            self.raise_event("reacquired")
        return Response()


class DetectUUV(Behaviour):
    """Waits for the sonar's first detection of the UUV since it was enabled: ``acquired``."""

    name = "DetectUUV"
    events = ("acquired",)

    def on_initialise(self, t: float) -> None:
        self.since = t

    def on_update(self, p: Perception) -> Response:
        if any(d[0] >= self.since for d in as_mcm(p).uuv_track):
            self.raise_event("acquired")
        return Response()

    since: float = 0.0


class TrackUUV(Behaviour):
    """Watches the sonar's detections of the UUV: ``landed`` when they have stayed within
    0.5 m for ``still`` s (eight or more, over most of it) once it has gone 5 m (it rests on
    the bottom, not waiting at 2 m under the ASV), ``lost`` after ``patience`` s without
    one."""

    name = "TrackUUV"
    events = ("landed", "lost")
    parameters = ("still", "patience")

    def on_update(self, p: Perception) -> Response:
        q = as_mcm(p)
        still, patience = self.param("still", 8.0), self.param("patience", 20.0)
        track = [d for d in q.uuv_track if d[0] >= self.since]
        if q.t - (track[-1][0] if track else self.since) > patience:
            self.raise_event("lost")
        if not track:
            return Response()
        recent = [d for d in track if d[0] >= q.t - still]
        travelled = math.hypot(track[-1][1] - track[0][1], track[-1][2] - track[0][2])
        spans = bool(recent) and recent[-1][0] - recent[0][0] >= 0.8 * still
        if spans and len(recent) >= 8 and travelled > 5.0:  # seen all along, not in glimpses
            xs, ys = sorted(d[1] for d in recent), sorted(d[2] for d in recent)
            mid = (xs[len(xs) // 2], ys[len(ys) // 2])  # the median: clutter does not move it
            if sum(math.hypot(d[1] - mid[0], d[2] - mid[1]) < 0.5 for d in recent) \
                    >= 0.8 * len(recent):
                self.raise_event("landed")
        return Response()

    def on_initialise(self, t: float) -> None:
        self.since = t

    since: float = 0.0


# -- the UUV ------------------------------------------------------------------------------------
class KeepDepth(Behaviour):
    """Hold a depth (m) until switched off: a latched behaviour, no event."""

    name = "KeepDepth"
    drives = ("z",)
    parameters = ("depth",)

    def on_update(self, p: Perception) -> Response:
        return Response({"z": clamp(0.5 * (self.param("depth", 2.0) - p.z), 0.3)})


class FollowLine(Behaviour):
    """Follow the line from where it is enabled to above the mine ({T}'s origin) at ``speed``
    (m/s), descending to ``height`` (m) above the mine's top by half way; ``near`` within
    ``distance`` (m) of the mine or past it, on the navigator's estimate (line-of-sight guidance, a 3 m
    look-ahead)."""

    name = "FollowLine"
    drives = ("x", "z", "yaw")
    events = ("near",)
    parameters = ("speed", "height", "distance")
    lookahead = 3.0

    def on_initialise(self, t: float) -> None:
        self.origin: tuple[float, float, float] | None = None

    def on_update(self, p: Perception) -> Response:
        if self.origin is None:
            self.origin = (p.x, p.y, p.z)
        ox, oy, oz = self.origin
        span = math.hypot(ox, oy) or 1.0
        ex, ey = -ox / span, -oy / span  # along the line, towards the mine
        along = (p.x - ox) * ex + (p.y - oy) * ey
        cross = -(p.x - ox) * ey + (p.y - oy) * ex  # + left of the line
        togo = math.hypot(p.x, p.y)
        if togo < self.param("distance", 2.0) or along >= span:  # there, or past it
            self.raise_event("near")
        heading = math.atan2(ey, ex) - math.atan2(cross, self.lookahead)
        share = clamp(along / span, 1.0) if along > 0 else 0.0
        depth = oz + (below(p, self.param("height", 1.5), oz) - oz) * min(1.0, share * 2.0)
        speed = self.param("speed", 0.5) * max(math.cos(wrap(heading - p.psi)), 0.2)
        return Response({"x": speed, "z": clamp(0.5 * (depth - p.z), 0.3),
                         "yaw": steer(heading - p.psi)})

    def progress_report(self) -> dict[str, float | int] | None:
        p = self.seen
        return {"to_go": round(math.hypot(p.x, p.y), 1)} if p is not None else None


class Home(Behaviour):
    """Home on the mine with the camera (its sightings set the navigator's position) to the
    point ``distance`` (m) short of it, facing it, ``height`` (m) above its top: ``over`` there
    (within 0.3 m, 15 deg, the mine seen in the last second), ``lost`` when the camera has not
    seen it for ``patience`` s."""

    name = "Home"
    drives = ("x", "z", "yaw")
    events = ("over", "lost")
    parameters = ("distance", "height", "patience")

    def on_initialise(self, t: float) -> None:
        self.enabled_at = t
        self.last_t, self.integral = t, 0.0

    def on_update(self, p: Perception) -> Response:
        q = as_mcm(p)
        if q.t - max(q.sighted_at, self.enabled_at) > self.param("patience", 8.0):
            self.raise_event("lost")
        span = math.hypot(q.x, q.y) or 1.0
        standoff = self.param("distance", 1.0)
        gx, gy = q.x / span * standoff, q.y / span * standoff  # the point short of the mine
        togo = math.hypot(gx - q.x, gy - q.y)
        facing = math.atan2(-q.y, -q.x)
        if togo < 0.3 and abs(wrap(facing - q.psi)) < math.radians(15.0) \
                and q.t - q.sighted_at < 1.0:
            self.raise_event("over")
        ahead = (gx - q.x) * math.cos(q.psi) + (gy - q.y) * math.sin(q.psi)
        # a PI on the distance ahead: the integral holds the point against a current
        self.integral = clamp(self.integral + 0.1 * ahead * (q.t - self.last_t), 0.3)
        self.last_t = q.t
        depth = below(q, self.param("height", 1.0), q.z)
        level = max(0.0, 1.0 - abs(depth - q.z))  # close in only once down at the height
        return Response({"x": clamp(0.5 * ahead + self.integral, 0.4) * level,
                         "z": clamp(0.5 * (depth - q.z), 0.3), "yaw": steer(facing - q.psi)})

    enabled_at: float = 0.0
    last_t: float = 0.0
    integral: float = 0.0


class Land(Behaviour):
    """Descend at 0.2 m/s onto the bottom, holding the point where it was enabled and facing
    the mine (a current would carry it off), until the depth stops growing for 2 s (it rests
    on the bottom): ``landed``."""

    name = "Land"
    drives = ("x", "z", "yaw")
    events = ("landed",)

    def on_initialise(self, t: float) -> None:
        self.depths: list[tuple[float, float]] = []
        self.point: tuple[float, float] | None = None

    def on_update(self, p: Perception) -> Response:
        if self.point is None:
            self.point = (p.x, p.y)
        self.depths.append((p.t, p.z))
        self.depths = [d for d in self.depths if d[0] >= p.t - 2.0]
        if len(self.depths) > 15 and p.t - self.depths[0][0] >= 1.9 \
                and p.z - self.depths[0][1] < 0.05:
            self.raise_event("landed")
        gx, gy = self.point
        ahead = (gx - p.x) * math.cos(p.psi) + (gy - p.y) * math.sin(p.psi)
        return Response({"x": clamp(0.6 * ahead, 0.3), "z": 0.2,
                         "yaw": steer(math.atan2(-p.y, -p.x) - p.psi)})


class Snapshot(Behaviour):
    """Take the picture that verifies the landing: ``taken`` if the camera sees the mine
    within ``wait`` s, ``missed`` otherwise."""

    name = "Snapshot"
    events = ("taken", "missed")
    parameters = ("wait",)

    def on_initialise(self, t: float) -> None:
        self.enabled_at = t

    def on_update(self, p: Perception) -> Response:
        q = as_mcm(p)
        if q.sighted_at >= self.enabled_at - 0.5:
            self.raise_event("taken")
        elif q.t - self.enabled_at > self.param("wait", 3.0):
            self.raise_event("missed")
        return Response()

    enabled_at: float = 0.0


class Ascend(Surface):
    """The UUV's surfacing: the Ictineu's :class:`Surface` (rise at 0.3 m/s, ``surfaced``
    within 0.2 m of the surface) under a name of the UUV's own library, so that the two
    libraries can be read together; no priority (a verified mission never overlaps it)."""

    name = "Ascend"
    drives = ("z",)
    events = ("surfaced",)
    priority = 0


ASV = (KeepStation, Reacquire, DetectUUV, TrackUUV)
UUV = (KeepDepth, FollowLine, Home, Land, Snapshot, Ascend)
