"""Paper 003's behaviours (behaviours/mcm.py) against their task libraries, and their laws."""

from __future__ import annotations

import pytest

from behaviours.base import Behaviour
from behaviours.mcm import (
    ASV,
    UUV,
    DetectUUV,
    FollowLine,
    Home,
    McmPerception,
    Snapshot,
    TrackUUV,
)
from diagnostics import Source
from mcl import tasklib
from tests.support import MISSIONS


def library(name: str) -> tasklib.Library:
    path = MISSIONS / name
    return tasklib.load_sources([Source(str(path), path.read_text("utf-8"))])


@pytest.mark.parametrize(("name", "classes"), [("asv.tasks", ASV), ("uuv.tasks", UUV)])
def test_each_library_declares_its_vehicles_behaviours_as_the_classes_do(
        name: str, classes: tuple[type[Behaviour], ...]) -> None:
    lib = library(name)
    assert set(lib.behaviours) == {c.name for c in classes}
    for cls in classes:
        declared = lib.behaviours[cls.name]
        assert (declared.dofs, declared.events) == (cls.drives, cls.events), cls.name
    for forms in lib.tasks.values():
        for form in forms:
            for action in form.start + form.stop:
                takes = next(c for c in classes if c.name == action.behaviour).parameters
                assert {k for k, _ in action.bindings} <= set(takes), form.name


def see(t: float, x: float, y: float, psi: float = 0.0, **more: object) -> McmPerception:
    return McmPerception(t, x, y, 5.0, psi, **more)  # type: ignore[arg-type]


def test_follow_line_steers_back_to_the_line_and_says_near() -> None:
    b = FollowLine()
    b.initialise({"speed": 0.5, "height": 1.5, "distance": 2.0}, 0.0)
    r = b.update(see(0.0, -20.0, 0.0))  # on the line, heading for the mine at the origin
    assert r.demands["x"] == pytest.approx(0.5) and r.demands["yaw"] == pytest.approx(0.0)
    left = b.update(see(1.0, -15.0, 2.0))  # 2 m to the left of the line (+y): turn right
    assert left.demands["yaw"] < 0.0
    assert b.take_events() == []
    b.update(see(2.0, -1.5, 0.2))
    assert [n for n, _ in b.take_events()] == ["near"]


def test_home_stops_short_of_the_mine_facing_it_only_when_the_camera_sees_it() -> None:
    b = Home()
    b.initialise({"distance": 1.0, "height": 0.5, "patience": 8.0}, 0.0)
    b.update(see(1.0, -1.1, 0.0, sighted_at=-5.0))  # there, but not seen lately
    assert b.take_events() == []
    b.update(see(2.0, -1.1, 0.0, sighted_at=1.9))
    assert [n for n, _ in b.take_events()] == ["over"]
    lost = Home()
    lost.initialise({"patience": 8.0}, 0.0)
    lost.update(see(8.5, -4.0, 0.0))
    assert [n for n, _ in lost.take_events()] == ["lost"]


def test_the_snapshot_needs_the_mine_in_view() -> None:
    taken, missed = Snapshot(), Snapshot()
    taken.initialise({"wait": 3.0}, 10.0)
    missed.initialise({"wait": 3.0}, 10.0)
    taken.update(see(10.2, -1.0, 0.0, sighted_at=10.2))
    missed.update(see(13.5, -1.0, 0.0, sighted_at=2.0))
    assert [n for n, _ in taken.take_events()] == ["taken"]
    assert [n for n, _ in missed.take_events()] == ["missed"]


def test_detect_uuv_says_acquired_at_the_first_detection_since_it_was_enabled() -> None:
    b = DetectUUV()
    b.initialise({}, 10.0)
    b.update(see(11.0, 0.0, 0.0, uuv_track=((9.5, -3.0, 0.0),)))  # before it was enabled
    assert b.take_events() == []
    b.update(see(11.5, 0.0, 0.0, uuv_track=((9.5, -3.0, 0.0), (11.5, -3.0, 0.1))))
    assert [n for n, _ in b.take_events()] == ["acquired"]


def test_track_uuv_tells_landed_when_the_echo_stays_still_then_lost() -> None:
    b = TrackUUV()
    b.initialise({"still": 8.0, "patience": 20.0}, 0.0)
    moving = tuple((k / 2, -15.0 + 0.25 * k, 0.0) for k in range(0, 60))  # a ping every 0.5 s
    b.update(see(30.0, 0.0, 0.0, uuv_track=moving))
    assert b.take_events() == []
    glimpses = moving + ((34.0, -1.0, 0.0), (35.0, -1.0, 0.0), (36.0, -1.0, 0.0))
    b.update(see(36.0, 0.0, 0.0, uuv_track=glimpses))
    assert b.take_events() == []  # seen still only over 2 s of the last 8: not yet
    still = moving + tuple((k / 2, -1.0, 0.0) for k in range(60, 84))
    b.update(see(42.0, 0.0, 0.0, uuv_track=still))
    assert [n for n, _ in b.take_events()] == ["landed"]
    b.update(see(70.0, 0.0, 0.0, uuv_track=still))
    assert [n for n, _ in b.take_events()] == ["lost"]
