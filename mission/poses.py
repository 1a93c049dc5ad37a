"""The vehicle's pose in its run log, and the scene it moved in, so that a log alone shows
where the vehicle went (``mcl view``, ``mcl export``).

A simulated vehicle keeps its true track as it goes: the Ictineu's survey
(vehicle/world/survey.py, 5 poses a second) or paper 003's stacks (``McmStack.track``, 10 a
second). :func:`track_of` finds it (``mcl run`` and a fleet's run pass it to
:func:`mission.run_mission`); a :class:`PoseLog` hands the run log one pose every
:data:`POSE_EVERY` seconds of mission time, each just before the first record at or after its
time, so that the log's time never goes back (petri/execution/runlog.py's ``pose`` record:
``t``, ``x``, ``y``, ``z``, ``yaw``, in the simulation's frame, m and rad). :func:`scene_of`
says what the vehicle moved in, for its log's header (``scene``): the dam wall as a line on
the plan, or paper 003's mine and the clutter around it.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from typing import Any

from mission.vehicle import Vehicle

POSE_EVERY = 1.0  # s of mission time between two poses in the run log
WALL_POINTS = 9  # points of the dam wall's line on the plan

Pose = tuple[float, float, float, float, float]  # t (the vehicle's clock), x, y, z, yaw
Track = Callable[[], Sequence[Pose]]  # the vehicle's poses so far, oldest first


def track_of(vehicle: Vehicle) -> Track | None:
    """The true track a simulated vehicle keeps (None: it keeps none)."""
    survey = getattr(vehicle.stack, "survey", None)
    if survey is not None:
        return lambda: SurveyPoses(survey)
    poses = getattr(vehicle.modem, "track", None)
    if isinstance(poses, list):
        return lambda: poses
    return None


class SurveyPoses(Sequence[Pose]):
    """The survey's true positions and headings (two lists kept side by side) as poses."""

    def __init__(self, survey: Any) -> None:
        self.truth, self.headings = survey.truth, survey.headings

    def __len__(self) -> int:
        return min(len(self.truth), len(self.headings))

    def __getitem__(self, i: Any) -> Any:
        if isinstance(i, slice):
            return [self[j] for j in range(*i.indices(len(self)))]
        t, x, y, z = self.truth[i]
        return (float(t), float(x), float(y), float(z), float(self.headings[i][0]))


class PoseLog:
    """The poses a run log has still to take: one every :data:`POSE_EVERY` s of mission
    time (``origin()``: the vehicle's clock at the mission's start, None before it)."""

    def __init__(self, track: Track, origin: Callable[[], float | None],
                 every: float = POSE_EVERY) -> None:
        self.track, self.origin, self.every = track, origin, every
        self.seen = 0  # the poses of the track looked at so far
        self.due = 0.0  # the mission time of the next pose to log

    def until(self, t: float) -> list[dict[str, float]]:
        """The poses to log before a record at mission time ``t``: those up to ``t`` not yet
        looked at, one every :attr:`every` s (a pose's fields, rounded as a log rounds)."""
        origin = self.origin()
        if origin is None:
            return []
        poses = self.track()
        out = []
        while self.seen < len(poses):
            vt, x, y, z, yaw = poses[self.seen]
            at = float(vt) - origin
            if at > t + 1e-9:
                break
            self.seen += 1
            if at >= self.due - 1e-9 and at >= 0.0 and all(
                    math.isfinite(v) for v in (at, x, y, z, yaw)):
                out.append({"t": round(at, 6), "x": round(float(x), 3),
                            "y": round(float(y), 3), "z": round(float(z), 3),
                            "yaw": round(float(yaw), 4)})
                self.due = at + self.every
        return out


def scene_of(vehicle: Vehicle) -> dict[str, Any] | None:
    """What a simulated vehicle moved in, as its log's header says it (None: not known):
    ``lines`` (name -> [[x, y], ...] on the plan) and ``points`` (name -> [[x, y], ...]),
    in the frame of its poses, m."""
    env = getattr(vehicle.stack, "env", None)
    if env is not None and hasattr(env, "wall_x") and hasattr(env, "area"):
        _, _, y0, y1 = (float(v) for v in env.area)
        ys = [y0 + (y1 - y0) * i / (WALL_POINTS - 1) for i in range(WALL_POINTS)]
        return {"lines": {"dam wall": [[round(float(env.wall_x(y)), 3), round(y, 3)]
                                       for y in ys]}, "points": {}}
    world = getattr(vehicle.modem, "world", None)
    scene = getattr(world, "scene", None)
    target = getattr(scene, "target", None)
    if target is None:
        return None
    return {"lines": {}, "points": {
        "mine": [[round(float(target[0]), 3), round(float(target[1]), 3)]],
        "clutter": [[round(float(x), 3), round(float(y), 3)]
                    for x, y in getattr(scene, "clutter", ())]}}


def is_scene(value: Any) -> bool:
    """Is ``value`` a scene as :func:`scene_of` writes it (a log's header: mcl replay)?"""
    if not isinstance(value, dict) or set(value) != {"lines", "points"}:
        return False
    return all(isinstance(named, dict) and all(
        isinstance(name, str) and isinstance(points, list) and all(
            isinstance(p, list) and len(p) == 2 and all(
                isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)
                for v in p) for p in points)
        for name, points in named.items()) for named in value.values())
