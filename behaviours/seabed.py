"""The behaviours of seabed inspection: KeepAltitude, FollowPipeline, FollowCable, SearchLine.

They read what the vehicle's seabed vision sees in :attr:`Perception.line` (a :class:`LineView`,
filled by the stack from the downward camera and the running tracker: Foresti's EKF on the
pipe's edges for FollowPipeline, Wirth's Condensation filter on the cable's borders for
FollowCable) and the DVL's altitude. To a mission they are behaviours like any other
(``missions/seabed.tasks`` declares them; :func:`statements` is the vehicle's own declaration).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from behaviours.base import Behaviour, Perception, Response, clamp, path_left, wrap


@dataclass(frozen=True)
class LineView:
    """The line (pipeline or cable) as the running tracker sees it, in the vehicle's terms.

    ``offset``: m, where the line passes beside the vehicle (+ starboard); ``angle``: rad, the
    line's direction relative to the vehicle's heading (+ to starboard). ``tracked``: this
    frame had a measurement (or the filter is confident); ``unseen_for``: s since the last one.
    ``last_point``/``last_direction``: the line where it was last seen (navigator frame), for a
    search. ``tracker``: which one ran ("pipeline", "cable", "search")."""

    tracker: str
    tracked: bool
    offset: float = 0.0
    angle: float = 0.0
    unseen_for: float = 0.0
    last_point: tuple[float, float] | None = None
    last_direction: float | None = None


class KeepAltitude(Behaviour):
    """Hold an altitude above the seabed (the DVL's), in heave, until disabled; 'lost' when
    there is no bottom lock for ``patience`` s."""

    name = "KeepAltitude"
    drives = ("z",)
    events = ("lost",)
    parameters = ("altitude",)

    def __init__(self, gain: float = 0.5, speed: float = 0.3, patience: float = 5.0) -> None:
        super().__init__()
        self.gain, self.speed, self.patience = gain, speed, patience

    def on_initialise(self, t: float) -> None:
        self.locked_at = t
        self.floor: float | None = None

    def on_update(self, p: Perception) -> Response:
        target = self.param("altitude", 2.0)
        if p.altitude is not None:
            self.locked_at = p.t
            self.floor = p.z + p.altitude
        elif p.t - self.locked_at > self.patience:
            self.raise_event("lost", reason=f"no bottom lock for {self.patience:g} s")
        if self.floor is None:
            return Response({"z": 0.0})
        # from the floor's depth (steady between DVL pings) and the navigator's depth
        error = (p.z + target) - self.floor
        return Response({"z": clamp(-self.gain * error, self.speed)})


class _Follower(Behaviour):
    """What both line followers share: 'ended' after ``length`` m along the line (from the
    enable), 'lost' when the line has been out of sight for ``patience`` s."""

    events = ("ended", "lost")
    parameters = ("speed", "length")

    def __init__(self, patience: float = 10.0) -> None:
        super().__init__()
        self.patience = patience

    def on_initialise(self, t: float) -> None:
        self.followed = 0.0
        self.last_t = t
        self.done = False

    def on_update(self, p: Perception) -> Response:
        dt, self.last_t = max(0.0, p.t - self.last_t), p.t
        if self.done:
            return Response({d: 0.0 for d in self.drives})
        line = p.line if isinstance(p.line, LineView) else None
        self.followed += max(0.0, p.u) * dt
        if self.followed >= self.param("length", 50.0):
            self.done = True
            self.raise_event("ended", followed=round(self.followed, 1))
            return Response({d: 0.0 for d in self.drives})
        if line is None or line.unseen_for > self.patience:
            self.done = True
            self.raise_event("lost", reason=f"the {self.tracker} out of sight for "
                             f"{self.patience:g} s", followed=round(self.followed, 1))
            return Response({d: 0.0 for d in self.drives})
        return self.steer(p, line)

    def steer(self, p: Perception, line: LineView) -> Response:
        return Response()


class FollowPipeline(_Follower):
    """Follow the pipeline under the camera (Foresti's EKF, paper 000): surge at ``speed``,
    sway onto the pipe's axis, yaw along it."""

    name = "FollowPipeline"
    drives = ("x", "y", "yaw")
    tracker = "pipeline"

    def steer(self, p: Perception, line: LineView) -> Response:
        speed = self.param("speed", 0.5)  # on the EKF's prediction alone too (§V-D)
        return Response({"x": speed * max(0.3, math.cos(line.angle)),
                         "y": clamp(0.6 * line.offset, 0.3),
                         "yaw": clamp(0.8 * wrap(line.angle), 0.3)})


class FollowCable(_Follower):
    """Follow the cable (Wirth's Condensation tracker, paper 004) turning and surging only, as
    the thesis's vehicle does: steer towards a point of the cable a look-ahead in front."""

    name = "FollowCable"
    drives = ("x", "yaw")
    tracker = "cable"

    def steer(self, p: Perception, line: LineView) -> Response:
        speed = self.param("speed", 0.3)
        lookahead = max(1.0, 4.0 * speed)
        aim = wrap(line.angle + math.atan2(line.offset, lookahead))
        return Response({"x": speed * max(0.3, math.cos(aim)),
                         "yaw": clamp(0.8 * aim, 0.3)})


class SearchLine(Behaviour):
    """Sweep across the line where it was last seen: zigzag legs ``width`` m wide advancing
    along its last direction; 'found' when the detector has it in view in 3 frames running,
    'exhausted' when the legs are done (or nothing was ever seen to search from)."""

    name = "SearchLine"
    drives = ("x", "y", "yaw")
    events = ("found", "exhausted")
    parameters = ("width",)
    tracker = "search"  # the feature extraction alone, for the line last followed

    def __init__(self, legs: int = 4, advance: float = 2.0, speed: float = 0.4,
                 patience: float = 20.0) -> None:
        super().__init__()
        self.legs, self.advance, self.speed = legs, advance, speed
        self.patience = patience  # s without progress to a waypoint (a bank): skip it

    def on_initialise(self, t: float) -> None:
        self.waypoints: list[tuple[float, float]] = []
        self.index = 0
        self.done = False

    def progress_report(self) -> dict[str, float | int] | None:
        """The leg's waypoint it heads for (k of n) and the length of search still to go (m)."""
        if not self.waypoints or self.seen is None or self.done:
            return None
        k = min(self.index, len(self.waypoints) - 1)
        return {"waypoint": k + 1, "of": len(self.waypoints), "to_go": round(path_left(
            self.waypoints, self.index, (self.seen.x, self.seen.y)), 1)}

    def _plan(self, p: Perception, line: LineView | None) -> None:
        width = self.param("width", 10.0)
        if line is not None and line.last_point is not None and line.last_direction is not None:
            (x0, y0), h = line.last_point, line.last_direction
        else:
            x0, y0, h = p.x, p.y, p.psi
        c, s = math.cos(h), math.sin(h)
        for k in range(self.legs + 1):
            along = self.advance * k
            side = (width / 2) * (1 if k % 2 == 0 else -1)
            wx, wy = x0 + along * c - side * s, y0 + along * s + side * c
            if p.area is not None:  # inside the working area, clear of its banks
                ax0, ax1, ay0, ay1 = p.area
                wx, wy = min(max(wx, ax0 + 1.0), ax1 - 1.0), min(max(wy, ay0 + 1.0), ay1 - 1.0)
            self.waypoints.append((wx, wy))
        self.heading = h
        self.best, self.best_at = math.inf, p.t

    def on_update(self, p: Perception) -> Response:
        line = p.line if isinstance(p.line, LineView) else None
        if self.done:
            return Response({"x": 0.0, "y": 0.0, "yaw": 0.0})
        if not self.waypoints:
            self._plan(p, line)
        if line is not None and line.tracked:  # the vision's: in 3 frames running
            self.done = True
            self.raise_event("found", leg=self.index)
            return Response({"x": 0.0, "y": 0.0, "yaw": 0.0})
        wx, wy = self.waypoints[self.index]
        ex, ey = wx - p.x, wy - p.y
        if math.hypot(ex, ey) < self.best - 0.1:
            self.best, self.best_at = math.hypot(ex, ey), p.t
        if math.hypot(ex, ey) < 0.5 or p.t - self.best_at > self.patience:
            self.index += 1
            self.best, self.best_at = math.inf, p.t
            if self.index >= len(self.waypoints):
                self.done = True
                self.raise_event("exhausted", legs=self.legs)
                return Response({"x": 0.0, "y": 0.0, "yaw": 0.0})
            wx, wy = self.waypoints[self.index]
            ex, ey = wx - p.x, wy - p.y
        c, s = math.cos(p.psi), math.sin(p.psi)
        eu, ev = c * ex + s * ey, -s * ex + c * ey
        d = math.hypot(eu, ev)
        k = self.speed / max(d, self.speed)
        return Response({"x": k * eu, "y": k * ev,
                         "yaw": clamp(0.5 * wrap(self.heading - p.psi), 0.3)})


SEABED: tuple[type[Behaviour], ...] = (KeepAltitude, FollowPipeline, FollowCable, SearchLine)


def statements() -> str:
    """The seabed behaviours as task-library statements (``behaviour B drives ... events
    ...;``, :meth:`Behaviour.statement`): what ``missions/seabed.tasks`` says, and what the
    simulated vehicle declares of them (behaviours/capabilities.py, from the registry)."""
    return "".join(cls.statement() for cls in SEABED)
