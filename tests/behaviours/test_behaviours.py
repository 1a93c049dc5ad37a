"""The vehicle's behaviours (behaviours/), the coordinator and the velocity controller
(behaviours/coordinator.py, vehicle/control/controller.py), each on its own with hand-made perceptions.

Behaviours: the lifecycle (initialise / update / terminate, take_events), the events of docs/AAL.md
(each once per enable), the degrees of freedom each drives and its speed limits. Motion
behaviours are closed around a kinematic vehicle (the response taken as the body velocities
it gets), so that "walks its waypoints in order" is checked on a real sequence of perceptions.
Coordinator: a union of the responses, priorities on overlap, overlaps counted. Controller: a
1-DOF plant with the Ictineu's surge mass and damping (convergence, saturation, anti-windup).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import replace
from typing import Any

import numpy as np
import pytest

import behaviours as bh
from behaviours import (
    AchieveHeadDist,
    Alarms,
    Behaviour,
    GoTo,
    Perception,
    Response,
    StartCamera,
    StartLogs,
    Surface,
    WallInspection,
)
from mcl import tasklib
from vehicle.control.controller import DEFAULT_GAINS, VelocityController
from behaviours.coordinator import PRIORITY, Coordinator

DT = 0.1  # s between hand-made perceptions


def at(t: float = 0.0, x: float = 0.0, y: float = 0.0, z: float = 2.0, psi: float = 0.0,
       **kw: Any) -> Perception:
    return Perception(t, x, y, z, psi, **kw)


def step(p: Perception, r: Response, dt: float = DT) -> Perception:
    """A kinematic vehicle: it gets exactly the body velocities the behaviour asked for."""
    u, v = r.demands.get("x", 0.0), r.demands.get("y", 0.0)
    w, yaw_rate = r.demands.get("z", 0.0), r.demands.get("yaw", 0.0)
    c, s = math.cos(p.psi), math.sin(p.psi)
    return replace(p, t=p.t + dt, x=p.x + (c * u - s * v) * dt, y=p.y + (s * u + c * v) * dt,
                   z=p.z + w * dt, psi=bh.base.wrap(p.psi + yaw_rate * dt), u=u, v=v, w=w,
                   r=yaw_rate)


def closed_loop(b: Behaviour, p: Perception, seconds: float,
                until: Callable[[Behaviour], bool] | None = None
                ) -> tuple[Perception, list[tuple[float, str, dict[str, Any]]], list[Response]]:
    """Tick ``b`` on the kinematic vehicle; the events with their times, and the responses."""
    events: list[tuple[float, str, dict[str, Any]]] = []
    responses = []
    for _ in range(round(seconds / DT)):
        r = b.update(p)
        responses.append(r)
        events += [(p.t, name, data) for name, data in b.take_events()]
        if until is not None and until(b):
            break
        p = step(p, r)
    return p, events, responses


def names(events: list[tuple[float, str, dict[str, Any]]]) -> list[str]:
    return [n for _, n, _ in events]


# --- what docs/AAL.md and the task library declare --------------------------------------------
def test_drives_and_events_are_those_of_the_aal_table_and_the_task_library() -> None:
    aal = {"GoTo": (("x", "y", "z", "yaw"), ("reached", "failed")),
           "WallInspection": (("y", "z"), ("done", "failed")),
           "AchieveHeadDist": (("x", "yaw"), ("achieved", "lost")),
           "Surface": (("z",), ("surfaced",)),
           "StartCamera": ((), ()),
           "Alarms": ((), ("leak", "overtemperature", "overpressure")),
           "StartLogs": ((), ())}
    assert {cls.name: (cls.drives, cls.events) for cls in bh.ALL} == aal
    library = tasklib.load(None).behaviours  # the shipped Ictineu library that mclc verifies
    assert {n: (b.dofs, b.events) for n, b in library.items()} == aal


def test_a_behaviour_is_inactive_until_enabled_and_after_it_is_disabled() -> None:
    b = GoTo()
    assert not b.active
    b.initialise({"x": 1.0}, 0.0)
    assert b.active and b.params == {"x": 1.0}
    b.configure({"tolerance": 0.2}, 1.0)
    assert b.params == {"x": 1.0, "tolerance": 0.2} and b.active
    b.terminate(2.0)
    assert not b.active


def trigger_everything(t: float = 0.0) -> Perception:
    """A perception on which every behaviour, if enabled, would answer and raise events."""
    return at(t, x=0.0, y=0.0, z=0.1, wall_distance=1.5, wall_heading=0.0, wall_normal=0.0,
              leak=True, temperature=90.0, pressure=3.0)


PARAMS: dict[str, dict[str, Any]] = {
    "GoTo": {"x": 0.0, "y": 0.0, "z": 0.1, "yaw": 0.0},
    "WallInspection": {"path": [[0.0, 0.1], [2.0, 0.1]]},
    "AchieveHeadDist": {"heading": 0.0, "distance": 1.5},
}


@pytest.mark.parametrize("cls", bh.ALL, ids=lambda c: c.name)
def test_disabled_behaviours_answer_nothing(cls: type[Behaviour]) -> None:
    never = cls()
    for k in range(50):
        assert never.update(trigger_everything(k * DT)).demands == {}
    assert never.take_events() == []
    off = cls()
    off.initialise(PARAMS.get(cls.name, {}), 0.0)
    off.update(trigger_everything(0.0))
    off.take_events()
    off.terminate(0.1)
    for k in range(2, 100):  # long enough for settle times and patience to run out
        assert off.update(trigger_everything(k * DT)).demands == {}
        assert off.update(at(k * DT)).demands == {}
    assert off.take_events() == []


@pytest.mark.parametrize("cls", [StartCamera, StartLogs])
def test_the_on_off_behaviours_drive_nothing_and_raise_nothing(cls: type[Behaviour]) -> None:
    b = cls()
    b.initialise({}, 0.0)
    assert b.active
    for k in range(20):
        assert b.update(trigger_everything(k * DT)).demands == {}
    assert b.take_events() == []


def test_take_events_returns_each_event_once() -> None:
    b = Alarms()
    b.initialise({}, 0.0)
    b.update(at(0.0, leak=True))
    assert b.take_events() == [("leak", {})]
    assert b.take_events() == []
    b.update(at(0.1, leak=True, temperature=60.0))
    assert b.take_events() == [("overtemperature", {"temperature": 60.0})]


# --- GoTo -------------------------------------------------------------------------------------
def test_goto_reaches_its_target_and_says_reached_once() -> None:
    b = GoTo()
    b.initialise({"x": 3.0, "y": 4.0, "z": 5.0, "yaw": 90.0, "tolerance": 0.3}, 0.0)
    end, events, _ = closed_loop(b, at(0.0, 0.0, 0.0, 1.0, 0.0), 120.0)
    assert names(events) == ["reached"]
    t_reached = events[0][0]
    assert 10.0 < t_reached < 60.0  # 6.4 m at no more than 0.4 m/s, then slowing down
    assert math.dist((end.x, end.y, end.z), (3.0, 4.0, 5.0)) < 0.05
    assert end.psi == pytest.approx(math.pi / 2, abs=math.radians(1))


def test_goto_reached_means_within_tolerance_and_heading() -> None:
    def reached(p: Perception, tolerance: float = 0.5) -> bool:
        b = GoTo()
        b.initialise({"x": 1.0, "y": 0.0, "z": 2.0, "yaw": 0.0, "tolerance": tolerance}, 0.0)
        b.update(p)
        return b.take_events() == [("reached", {})]

    assert reached(at(x=0.51)) is True  # 0.49 m away
    assert reached(at(x=0.49)) is False  # 0.51 m away
    assert reached(at(x=1.0, z=2.29), tolerance=0.3) is True  # depth counts too
    assert reached(at(x=1.0, z=2.31), tolerance=0.3) is False
    assert reached(at(x=1.0, psi=math.radians(4.0))) is True
    assert reached(at(x=1.0, psi=math.radians(6.0))) is False  # right place, wrong heading
    assert reached(at(x=1.0, psi=math.radians(359.0) - 2 * math.pi)) is True  # wraps


def test_goto_says_reached_again_only_after_it_is_enabled_again() -> None:
    b = GoTo()
    target = {"x": 1.0, "y": 1.0, "z": 2.0, "yaw": 0.0}
    b.initialise(target, 0.0)
    events = []
    for k in range(30):  # sitting on the target: still one 'reached'
        b.update(at(k * DT, x=1.0, y=1.0))
        events += b.take_events()
    # leaving and coming back within the same enable: still one
    b.update(at(3.1, x=5.0, y=5.0))
    b.update(at(3.2, x=1.0, y=1.0))
    events += b.take_events()
    assert events == [("reached", {})]
    b.terminate(3.3)
    b.initialise(target, 3.4)
    b.update(at(3.5, x=1.0, y=1.0))
    assert b.take_events() == [("reached", {})]


def test_goto_drives_x_y_z_yaw_only_and_within_its_speed_limits() -> None:
    rng = np.random.default_rng(7)
    b = GoTo(speed=0.4, gain=0.5, yaw_gain=0.4)
    for _ in range(500):
        tx, ty, tz, tyaw = (float(v) for v in rng.uniform(-50, 50, 4))
        b.initialise({"x": tx, "y": ty, "z": abs(tz), "yaw": tyaw * 7, "tolerance": 0.5}, 0.0)
        x, y = (float(v) for v in rng.uniform(-50, 50, 2))
        p = at(0.0, x, y, float(rng.uniform(0, 30)), float(rng.uniform(-3.1, 3.1)))
        d = b.update(p).demands
        assert set(d) == {"x", "y", "z", "yaw"}
        assert math.hypot(d["x"], d["y"]) <= 0.4 + 1e-9
        assert abs(d["z"]) <= 0.4 + 1e-9
        assert abs(d["yaw"]) <= 0.3 + 1e-9
    # near the target the demand is proportional (it slows down), not bang-bang
    b.initialise({"x": 0.2, "y": 0.0, "z": 2.0, "yaw": 0.0}, 0.0)
    assert b.update(at()).demands["x"] == pytest.approx(0.5 * 0.2)


def test_goto_demands_are_in_the_body_frame() -> None:
    b = GoTo()
    b.initialise({"x": 10.0, "y": 0.0, "z": 2.0, "yaw": 90.0}, 0.0)
    d = b.update(at(psi=math.pi / 2)).demands  # facing +y: the target (+x) is to port
    assert d["x"] == pytest.approx(0.0, abs=1e-9)
    assert d["y"] == pytest.approx(-0.4)
    assert d["z"] == pytest.approx(0.0) and d["yaw"] == pytest.approx(0.0)


def test_goto_missing_coordinates_hold_the_current_ones() -> None:
    b = GoTo()
    b.initialise({"x": 4.0, "yaw": None}, 0.0)  # a 2-point target: no yaw
    d = b.update(at(x=1.0, y=-3.0, z=7.0, psi=0.7)).demands
    assert d["yaw"] == 0.0 and d["z"] == 0.0
    c, s = math.cos(0.7), math.sin(0.7)
    assert (d["x"], d["y"]) == pytest.approx((0.4 * c, -0.4 * s))  # straight at x = 4


# --- WallInspection ---------------------------------------------------------------------------
def test_goto_fails_at_once_on_a_target_outside_the_working_area() -> None:
    b = GoTo()
    b.initialise({"x": -200.0, "y": 0.0, "z": 5.0, "yaw": 0.0}, 0.0)
    end, events, _ = closed_loop(b, at(0.0, -6.0, 0.0, 1.0, area=(-60.0, 60.0, -60.0, 60.0)),
                                 20.0)
    assert names(events) == ["failed"]
    assert events[0][0] == 0.0 and "outside the working area" in events[0][2]["reason"]
    assert events[0][2]["target"] == [-200.0, 0.0, 5.0]
    assert math.dist((end.x, end.y, end.z), (-6.0, 0.0, 1.0)) < 1e-9  # it never moved


def test_goto_fails_on_a_target_beyond_the_floor_the_dvl_sees() -> None:
    b = GoTo()
    b.initialise({"x": -3.0, "y": 0.0, "z": 18.0, "yaw": 0.0}, 0.0)
    end, events, _ = closed_loop(b, at(0.0, -6.0, -2.0, 0.3, altitude=11.7), 20.0)
    assert names(events) == ["failed"]
    reason = events[0][2]["reason"]
    assert "beyond the floor at 12.0 m" in reason and "18 m" in reason
    assert math.dist((end.x, end.y, end.z), (-6.0, -2.0, 0.3)) < 1e-9
    # a target 0.5 m above the floor is fine: reached
    b.initialise({"x": -6.0, "y": -2.0, "z": 11.5, "yaw": 0.0, "tolerance": 0.3}, 0.0)
    _, events, _ = closed_loop(b, at(0.0, -6.0, -2.0, 0.3, altitude=11.7), 60.0)
    assert names(events) == ["reached"]


def test_goto_stopped_by_the_wall_fails_saying_the_target_is_inside_it() -> None:
    """The vehicle's hull stops 0.4 m from the wall (x = 0); the target is 2 m beyond it."""
    b = GoTo(patience=20.0)
    b.initialise({"x": 2.0, "y": 0.0, "z": 5.0, "yaw": 0.0}, 0.0)
    p = at(0.0, -5.0, 0.0, 5.0)
    events: list[tuple[float, str, dict[str, Any]]] = []
    for _ in range(round(120.0 / DT)):
        r = b.update(p)
        events += [(p.t, n, d) for n, d in b.take_events()]
        p = step(p, r)
        x = min(p.x, -0.4)  # the wall stops the vehicle
        p = replace(p, x=x, u=0.0 if x < p.x else p.u, wall_distance=-x, wall_heading=0.0,
                    wall_normal=0.0)
    assert names(events) == ["failed"]
    t, _, data = events[0]
    assert 20.0 + 4.6 / 0.4 - 1.0 < t < 20.0 + 4.6 / 0.4 + 5.0  # 4.6 m to the wall, 20 s
    assert "inside the wall (2.0 m beyond it)" in data["reason"]
    assert data["position"][0] == pytest.approx(-0.4)
    assert b.update(p).demands == {"x": 0.0, "y": 0.0, "z": 0.0, "yaw": 0.0}  # it lets go


def test_goto_moving_on_never_fails_for_want_of_progress() -> None:
    b = GoTo(patience=5.0)
    b.initialise({"x": 40.0, "y": 0.0, "z": 2.0, "yaw": 0.0, "tolerance": 0.3}, 0.0)
    _, events, _ = closed_loop(b, at(0.0, 0.0, 0.0, 2.0), 200.0)
    assert names(events) == ["reached"]


def test_wall_inspection_fails_on_a_waypoint_beyond_the_floor() -> None:
    b = WallInspection()
    b.initialise({"path": [[0.0, 3.0], [0.0, 18.0]]}, 0.0)
    end, events, _ = closed_loop(b, at(0.0, -1.5, 0.0, 2.0, altitude=10.0), 60.0)
    assert names(events) == ["failed"]
    assert events[0][2]["reason"].startswith("waypoint 2: the target depth 18 m is beyond")
    assert end.z == pytest.approx(3.0, abs=0.2)  # the first waypoint was walked


def wall_start(y: float, z: float) -> Perception:
    return at(0.0, x=-1.5, y=y, z=z, psi=0.0)  # facing the wall (x = 0) at 1.5 m


def test_wall_inspection_walks_its_waypoints_in_order_and_says_done() -> None:
    path = [(0.0, 1.0), (0.0, 3.0), (0.75, 3.0), (0.75, 1.0), (1.5, 1.0), (1.5, 3.0)]
    b = WallInspection()
    b.initialise({"path": [list(pt) for pt in path]}, 0.0)
    p = wall_start(-0.5, 1.5)
    visited = []
    events: list[tuple[float, str, dict[str, Any]]] = []
    for _ in range(round(300 / DT)):
        before = b.index
        r = b.update(p)
        visited += [path[i] for i in range(before, b.index)]
        events += [(p.t, n, d) for n, d in b.take_events()]
        assert set(r.demands) <= {"y", "z"}
        assert math.hypot(r.demands.get("y", 0.0), r.demands.get("z", 0.0)) <= 0.12 + 1e-9
        p = step(p, r)
    assert visited == path
    assert names(events) == ["done"] and events[0][2] == {"waypoints": len(path)}
    # 0.5 + 2 + 0.75 + 2 + 0.75 + 2 m (about 8 m) at 0.12 m/s, slowing on each arrival
    assert 60.0 < events[0][0] < 150.0
    assert math.hypot(p.y - 1.5, p.z - 3.0) <= 0.15
    assert b.update(p).demands == {"y": 0.0, "z": 0.0}  # done: holds still


def test_wall_inspection_does_not_skip_a_waypoint_it_passes_near_later() -> None:
    # (0, 2) is where the vehicle starts; it comes second: first go to (1, 2), then back
    b = WallInspection()
    b.initialise({"path": [[1.0, 2.0], [0.0, 2.0], [2.0, 2.0]]}, 0.0)
    p = wall_start(0.0, 2.0)
    first = b.update(p)
    assert first.demands["y"] > 0.0 and b.index == 0
    ys = []
    events: list[str] = []
    for _ in range(round(120 / DT)):
        r = b.update(p)
        events += [n for n, _ in b.take_events()]
        ys.append(p.y)
        p = step(p, r)
    y = np.array(ys)
    out = int(np.argmax(y > 0.85))  # went to (1, 2) first ...
    back = out + int(np.argmax(y[out:] < 0.15))  # ... came back to (0, 2) ...
    on = back + int(np.argmax(y[back:] > 1.85))  # ... and then went on to (2, 2)
    assert y[out] > 0.85 and y[back] < 0.15 and y[on] > 1.85 and 0 < out < back < on
    assert events == ["done"] and p.y > 1.85


def test_wall_inspection_sway_follows_the_heading() -> None:
    b = WallInspection()
    b.initialise({"path": [[5.0, 2.0]]}, 0.0)
    ahead = b.update(at(y=0.0, z=2.0, psi=0.0)).demands["y"]
    behind = b.update(at(y=0.0, z=2.0, psi=math.pi)).demands["y"]
    assert ahead == pytest.approx(0.12) and behind == pytest.approx(-0.12)


@pytest.mark.parametrize("params", [{"path": []}, {}, {"path": None}],
                         ids=["empty", "missing", "none"])
def test_wall_inspection_fails_on_an_empty_path(params: dict[str, Any]) -> None:
    b = WallInspection()
    b.initialise(params, 0.0)
    assert b.update(wall_start(0.0, 1.0)).demands == {}
    assert b.take_events() == [("failed", {"reason": "empty path"})]
    b.update(wall_start(0.0, 1.0))
    assert b.take_events() == []  # once


def test_wall_inspection_starts_again_from_the_first_waypoint_when_re_enabled() -> None:
    path = {"path": [[0.0, 1.0], [1.0, 1.0]]}
    b = WallInspection()
    b.initialise(path, 0.0)
    p, events, _ = closed_loop(b, wall_start(0.0, 1.0), 60.0)
    assert names(events) == ["done"]
    b.terminate(p.t)
    b.initialise(path, p.t)
    assert b.index == 0
    _, events, _ = closed_loop(b, replace(p, t=p.t + DT), 60.0)
    assert names(events) == ["done"]


@pytest.mark.parametrize("path", [[1, 2], [[1.0]], [["a", 2]]])
def test_wall_inspection_fails_rather_than_crashes_on_a_malformed_path(path: list[Any]) -> None:
    b = WallInspection()
    b.initialise({"path": path}, 0.0)
    b.update(wall_start(0.0, 1.0))
    assert [n for n, _ in b.take_events()] == ["failed"]


# --- AchieveHeadDist ---------------------------------------------------------------------------
def wall(t: float, distance: float = 1.5, relative: float = 0.0, normal: float | None = 0.0,
         psi: float | None = None) -> Perception:
    """The wall seen at ``distance`` and ``relative`` heading (rad); psi = normal + relative."""
    psi = (normal or 0.0) + relative if psi is None else psi
    return at(t, x=-distance, psi=psi, wall_distance=distance, wall_heading=relative,
              wall_normal=normal)


def run_ahd(perceptions: list[Perception], settle: float = 3.0, patience: float = 10.0,
            params: dict[str, Any] | None = None) -> list[tuple[float, str]]:
    b = AchieveHeadDist(settle=settle, patience=patience)
    b.initialise(params or {"heading": 0.0, "distance": 1.5}, perceptions[0].t)
    out = []
    for p in perceptions:
        b.update(p)
        out += [(p.t, n) for n, _ in b.take_events()]
    return out


def ts(seconds: float, start: float = 0.0) -> list[float]:
    return [start + k * DT for k in range(round(seconds / DT) + 1)]


def test_achieve_head_dist_says_achieved_only_after_the_settle_time() -> None:
    events = run_ahd([wall(t, 1.5 + 0.05, math.radians(1.0)) for t in ts(10.0)])
    assert len(events) == 1 and events[0][1] == "achieved"
    assert events[0][0] == pytest.approx(3.0)  # held since t = 0, settle 3 s
    events = run_ahd([wall(t) for t in ts(10.0, start=100.0)], settle=5.0)
    assert [n for _, n in events] == ["achieved"] and events[0][0] == pytest.approx(105.0)


def test_achieve_head_dist_restarts_the_settle_clock_when_an_error_grows() -> None:
    seq = [wall(t, 1.5 if abs(t - 2.0) > 1e-6 else 1.7) for t in ts(10.0)]
    events = run_ahd(seq)
    assert [n for _, n in events] == ["achieved"]
    assert events[0][0] == pytest.approx(5.1)  # good again from 2.1 s


@pytest.mark.parametrize("distance, relative_deg", [(1.62, 0.0), (1.38, 0.0), (1.5, 2.5),
                                                    (1.5, -2.5)])
def test_achieve_head_dist_is_not_achieved_outside_its_bounds(distance: float,
                                                              relative_deg: float) -> None:
    seq = [wall(t, distance, math.radians(relative_deg)) for t in ts(30.0)]
    assert run_ahd(seq) == []


def test_achieve_head_dist_heading_is_relative_to_the_wall() -> None:
    # compass on the tracker's wall normal: psi = normal + 20 deg for heading 20 deg
    normal = 0.4
    seq = [wall(t, 2.0, math.radians(20.0), normal=normal) for t in ts(5.0)]
    events = run_ahd(seq, params={"heading": 20.0, "distance": 2.0})
    assert [n for _, n in events] == ["achieved"] and events[0][0] == pytest.approx(3.0)
    # without the normal, on the sonar's relative heading
    seq = [wall(t, 2.0, math.radians(20.0), normal=None) for t in ts(5.0)]
    events = run_ahd(seq, params={"heading": 20.0, "distance": 2.0})
    assert [n for _, n in events] == ["achieved"] and events[0][0] == pytest.approx(3.0)
    seq = [wall(t, 2.0, 0.0, normal=None) for t in ts(5.0)]
    assert run_ahd(seq, params={"heading": 20.0, "distance": 2.0}) == []


def test_achieve_head_dist_says_lost_after_its_patience_without_the_wall() -> None:
    blind = [at(t, x=-1.5) for t in ts(30.0)]
    events = run_ahd(blind, patience=10.0)
    assert len(events) == 1 and events[0][1] == "lost"
    assert 10.0 < events[0][0] <= 10.0 + DT + 1e-9
    # seen until t = 5, then not: lost only once patience has run out after t = 5
    seq = [wall(t) if t <= 5.0 + 1e-9 else at(t, x=-1.5) for t in ts(30.0)]
    events = run_ahd(seq, settle=100.0, patience=10.0)
    assert [n for _, n in events] == ["lost"] and 15.0 < events[0][0] <= 15.0 + DT + 1e-9
    # gaps shorter than the patience are forgiven
    seq = [at(t, x=-1.5) if int(t) % 10 < 8 else wall(t) for t in ts(60.0)]
    assert run_ahd(seq, settle=100.0, patience=10.0) == []


def test_achieve_head_dist_drives_surge_and_yaw_only_and_stops_without_the_wall() -> None:
    b = AchieveHeadDist(gain=0.4, yaw_gain=0.4, speed=0.3)
    b.initialise({"heading": 0.0, "distance": 1.5}, 0.0)
    d = b.update(wall(0.0, 2.0, math.radians(-5.0))).demands
    assert set(d) == {"x", "yaw"}
    assert d["x"] == pytest.approx(0.4 * 0.5)  # too far: forward, towards the wall
    assert d["yaw"] == pytest.approx(0.4 * math.radians(5.0))  # turn back square on
    d = b.update(wall(0.1, 0.5)).demands
    assert d["x"] == pytest.approx(-0.3)  # too close: back off, at most 0.3 m/s
    d = b.update(wall(0.2, 30.0, math.radians(90.0))).demands
    assert d["x"] == pytest.approx(0.3) and d["yaw"] == pytest.approx(-0.3)
    assert b.update(at(0.3)).demands == {"x": 0.0, "yaw": 0.0}


def test_achieve_head_dist_closes_on_the_wall_in_closed_loop() -> None:
    # a straight wall x = 0 seen from the kinematic vehicle, normal +x
    b = AchieveHeadDist()
    b.initialise({"heading": 0.0, "distance": 1.5}, 0.0)
    p = at(0.0, x=-4.0, psi=math.radians(15.0))
    events = []
    for _ in range(round(120 / DT)):
        p = replace(p, wall_distance=-p.x / math.cos(p.psi), wall_heading=p.psi,
                    wall_normal=0.0)
        r = b.update(p)
        events += [(p.t, n) for n, _ in b.take_events()]
        p = step(p, r)
    assert [n for _, n in events] == ["achieved"]
    assert p.x == pytest.approx(-1.5, abs=0.02) and p.psi == pytest.approx(0.0, abs=0.01)


def test_achieve_head_dist_does_not_count_time_without_the_wall_as_settled() -> None:
    seq = [wall(t) if t < 1e-9 or t > 3.0 - 1e-9 else at(t, x=-1.5) for t in ts(4.0)]
    events = run_ahd(seq)
    assert all(t >= 6.0 - 1e-9 for t, _ in events)  # settles from t = 3 on, not from t = 0


# --- Surface ---------------------------------------------------------------------------------
def test_surface_rises_and_says_surfaced_near_the_surface() -> None:
    b = Surface()
    b.initialise({}, 0.0)
    assert b.update(at(0.0, z=3.0)).demands == {"z": -0.3}
    assert b.take_events() == []
    end, events, _ = closed_loop(b, at(0.0, z=3.0), 60.0)
    assert names(events) == ["surfaced"]
    assert events[0][0] == pytest.approx((3.0 - 0.2) / 0.3, abs=2 * DT)
    assert end.z <= 0.2
    b.update(at(0.0, z=0.05))
    assert b.take_events() == []  # once per enable
    b.terminate(1.0)
    b.initialise({}, 1.0)
    b.update(at(1.0, z=0.15))
    assert b.take_events() == [("surfaced", {})]


# --- Alarms ---------------------------------------------------------------------------------
@pytest.mark.parametrize("perception, event", [
    (at(leak=True), ("leak", {})),
    (at(temperature=50.5), ("overtemperature", {"temperature": 50.5})),
    (at(pressure=1.6), ("overpressure", {"pressure": 1.6})),
])
def test_alarms_raise_each_alarm(perception: Perception, event: tuple[str, dict[str, Any]]
                                 ) -> None:
    b = Alarms()
    b.initialise({}, 0.0)
    assert b.update(at()).demands == {}  # healthy: 20 deg C, 1 bar, dry
    assert b.take_events() == []
    for k in range(5):
        assert b.update(replace(perception, t=k * DT)).demands == {}
    assert b.take_events() == [event]


def test_alarms_take_thresholds_and_raise_several_alarms_at_once() -> None:
    b = Alarms()
    b.initialise({"max_temperature": 30.0, "max_pressure": 1.1}, 0.0)
    b.update(at(temperature=29.9, pressure=1.09))
    assert b.take_events() == []
    b.update(at(0.1, temperature=30.5, pressure=1.2, leak=True))
    assert sorted(n for n, _ in b.take_events()) == ["leak", "overpressure", "overtemperature"]


# --- the coordinator ------------------------------------------------------------------------
def test_the_coordinator_merges_disjoint_responses_as_a_union() -> None:
    c = Coordinator()
    out = c.merge({"WallInspection": Response({"y": 0.1, "z": -0.05}),
                   "AchieveHeadDist": Response({"x": 0.02, "yaw": 0.01}),
                   "StartCamera": Response(), "Alarms": Response()})
    assert out == {"x": 0.02, "y": 0.1, "z": -0.05, "yaw": 0.01}
    assert c.overlaps == 0
    assert c.last_owner == {"x": "AchieveHeadDist", "yaw": "AchieveHeadDist",
                            "y": "WallInspection", "z": "WallInspection"}


def test_the_coordinator_holds_free_degrees_of_freedom_at_zero() -> None:
    c = Coordinator()
    assert c.merge({}) == {"x": 0.0, "y": 0.0, "z": 0.0, "yaw": 0.0}
    assert c.merge({"Surface": Response({"z": -0.3})}) == {"x": 0.0, "y": 0.0, "z": -0.3,
                                                            "yaw": 0.0}
    assert c.overlaps == 0


def test_the_coordinator_gives_an_overlap_to_the_higher_priority_and_counts_it() -> None:
    assert PRIORITY == ("Surface", "AchieveHeadDist", "WallInspection", "GoTo")
    c = Coordinator()
    goto = Response({"x": 0.4, "y": 0.3, "z": 0.2, "yaw": 0.1})
    for k in range(1, 4):  # the dictionary's order does not matter
        out = c.merge({"GoTo": goto, "Surface": Response({"z": -0.3})})
        assert out == {"x": 0.4, "y": 0.3, "z": -0.3, "yaw": 0.1}
        assert c.last_owner["z"] == "Surface" and c.last_owner["x"] == "GoTo"
        assert c.overlaps == k
    out = c.merge({"WallInspection": Response({"y": 0.1, "z": 0.1}), "GoTo": goto})
    assert out == {"x": 0.4, "y": 0.1, "z": 0.1, "yaw": 0.1}
    assert c.last_owner == {"x": "GoTo", "yaw": "GoTo", "y": "WallInspection",
                            "z": "WallInspection"}
    out = c.merge({"Mystery": Response({"x": 9.0}), "AchieveHeadDist": Response({"x": 0.0})})
    assert out["x"] == 0.0  # a behaviour the coordinator does not rank comes last
    out = c.merge({"AchieveHeadDist": Response({"x": 0.05, "yaw": 0.02}), "GoTo": goto})
    assert (out["x"], out["yaw"], out["y"]) == (0.05, 0.02, 0.3)


def test_the_coordinator_counts_overlapping_ticks() -> None:
    c = Coordinator()
    c.merge({"GoTo": Response({"x": 0.4, "y": 0.3, "z": 0.2, "yaw": 0.1}),
             "AchieveHeadDist": Response({"x": 0.05, "yaw": 0.02})})
    assert c.overlaps == 1


def test_the_coordinator_counts_position_setpoints_like_demands() -> None:
    c = Coordinator()
    out = c.merge({"GoTo": Response(setpoints={"x": 3.0, "y": -1.0, "z": 2.0, "yaw": 0.5}),
                   "Surface": Response({"z": -0.3})})
    assert out == {"x": 0.0, "y": 0.0, "z": -0.3, "yaw": 0.0}  # z: Surface's; the rest held
    assert c.last_setpoints == {"x": 3.0, "y": -1.0, "yaw": 0.5}  # GoTo lost z to Surface
    assert c.last_owner == {"z": "Surface", "x": "GoTo", "y": "GoTo", "yaw": "GoTo"}
    assert c.overlaps == 1
    c.merge({"WallInspection": Response(setpoints={"y": 1.0}), "GoTo": Response({"y": 0.2})})
    assert (c.last_setpoints, c.last_owner["y"], c.overlaps) == ({"y": 1.0}, "WallInspection", 2)
    c.merge({})
    assert c.last_setpoints == {} and c.last_owner == {}


# --- the velocity controller --------------------------------------------------------------
M_SURGE = 90.0  # kg: 60 kg + 30 kg added mass (vehicle/world/robot.py)
LIN, QUAD = 10.0, 90.0  # surge damping, N s/m and N s2/m2


def plant(controller: VelocityController, setpoint: Callable[[float], float], seconds: float,
          dt: float = 0.05, v0: float = 0.0, disturbance: float = 0.0
          ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """A 1-DOF surge plant M dv/dt = tau - LIN v - QUAD v|v| + disturbance, under the
    controller: times, velocities, thrust demands, integrals."""
    v = v0
    rows = []
    for k in range(round(seconds / dt)):
        t = k * dt
        tau = controller.update({"x": setpoint(t)}, {"x": v}, dt)["x"]
        rows.append((t, v, tau, controller.integral["x"]))
        v += dt * (tau - LIN * v - QUAD * v * abs(v) + disturbance) / M_SURGE
    a = np.array(rows)
    return a[:, 0], a[:, 1], a[:, 2], a[:, 3]


def constant(value: float) -> Callable[[float], float]:
    return lambda _t: value


def test_the_controller_converges_on_a_setpoint() -> None:
    for target in (0.1, 0.3, -0.2):
        t, v, tau, _ = plant(VelocityController(), constant(target), 60.0)
        assert v[-1] == pytest.approx(target, abs=1e-3)
        assert np.all(np.abs(v[t > 30.0] - target) < 2e-3)  # and stays there
        assert np.max(np.abs(v)) < abs(target) * 1.3  # without a wild overshoot
        assert abs(tau[-1]) < 44.0


def test_the_controller_rejects_a_constant_disturbance() -> None:
    # the integral term removes the steady-state error a current's drag would leave
    _, v, _, integral = plant(VelocityController(), lambda _t: 0.2, 120.0, disturbance=-8.0)
    assert v[-1] == pytest.approx(0.2, abs=1e-3)
    assert integral[-1] > 1.0


def test_the_controller_saturates_at_its_limit() -> None:
    limit = DEFAULT_GAINS["x"].limit
    t, v, tau, _ = plant(VelocityController(), lambda _t: 2.0, 60.0)  # beyond full thrust
    assert np.all(np.abs(tau) <= limit + 1e-12)
    assert np.all(tau[t > 1.0] == pytest.approx(limit))
    terminal = (-LIN + math.sqrt(LIN**2 + 4 * QUAD * limit)) / (2 * QUAD)
    assert v[-1] == pytest.approx(terminal, rel=1e-3)  # as fast as 44 N can push it
    for dof, gains in DEFAULT_GAINS.items():
        c = VelocityController()
        assert c.update({dof: 1e3}, {dof: 0.0}, 0.05)[dof] == pytest.approx(gains.limit)
        assert c.update({dof: -1e3}, {dof: 0.0}, 0.05)[dof] == pytest.approx(-gains.limit)


def test_the_controller_integral_does_not_wind_up_while_saturated() -> None:
    limit = DEFAULT_GAINS["x"].limit
    c = VelocityController()
    # ten minutes asking for more than the thrusters can give, then a reachable setpoint
    t, v, _, integral = plant(c, lambda s: 2.0 if s < 600.0 else 0.2, 700.0)
    saturated = integral[(t > 60.0) & (t < 600.0)]
    assert np.all(np.abs(integral) <= limit + 1e-12)  # bounded
    assert np.ptp(saturated) < 1e-9  # not growing while saturated
    after = t >= 600.0
    assert v[after][-1] == pytest.approx(0.2, abs=1e-3)  # recovers
    recovered = t[after][np.argmax(np.abs(v[after] - 0.2) < 0.01)] - 600.0
    assert recovered < 30.0


def test_the_controller_reset_clears_the_integral() -> None:
    c = VelocityController()
    plant(c, lambda _t: 2.0, 30.0)
    assert c.integral["x"] != 0.0
    c.reset()
    assert c.integral == {"x": 0.0, "y": 0.0, "z": 0.0, "yaw": 0.0}
    assert c.update({}, {}, 0.05) == {"x": 0.0, "y": 0.0, "z": 0.0, "yaw": 0.0}


def test_wall_inspection_reports_its_waypoint_and_the_path_to_go() -> None:
    # a path of three legs of 3 m, 1 m and 3 m; the vehicle walks it (kinematic)
    b = WallInspection()
    assert b.progress_report() is None  # never ticked
    b.initialise({"path": [[0.0, 1.0], [0.0, 4.0], [1.0, 4.0], [1.0, 1.0]]}, 0.0)
    p = at(y=0.0, z=1.0)
    b.update(p)
    first = b.progress_report()
    assert first is not None and first["of"] == 4
    assert first["to_go"] == pytest.approx(7.0, abs=0.05)
    reports = [first]
    for _ in range(2000):
        p = step(p, b.update(p))
        report = b.progress_report()
        assert report is not None
        reports.append(report)
        if any(name == "done" for name, _ in b.raised):
            break
    waypoints = [r["waypoint"] for r in reports]
    to_go = [r["to_go"] for r in reports]
    assert waypoints == sorted(waypoints) and waypoints[-1] == 4 and 3 in waypoints
    assert to_go[-1] <= 0.2 and all(a >= b - 0.01 for a, b in zip(to_go, to_go[1:]))
    b.terminate(p.t)
    assert bh.base.progress_of([b]) == {}  # a disabled behaviour tells nothing


def test_goto_reports_the_distance_to_its_target() -> None:
    b = GoTo()
    b.initialise({"x": 3.0, "y": 4.0, "z": 2.0}, 0.0)
    b.update(at())
    assert b.progress_report() == {"to_go": 5.0}
    assert bh.base.progress_of([b]) == {"GoTo": {"to_go": 5.0}}
