"""mission/poses.py: one pose a second of the vehicle's track into its run log, on mission
time, never before a record it follows; the scene a simulated vehicle says it moved in."""

from __future__ import annotations

from pathlib import Path
from types import SimpleNamespace
from typing import Any

from mission.logwriter import LogWriter
from mission.poses import Pose, PoseLog, is_scene, scene_of, track_of
from mission.vehicle import Vehicle
from petri.execution.player import Record
from petri.execution.runlog import RunLog, read_log, verify

NO_ADAPTER: Any = None  # what these vehicles run on does not matter here


def track(start: float, end: float, step: float = 0.1) -> list[Pose]:
    n = round((end - start) / step)
    return [(round(start + i * step, 3), float(i), 2.0 * i, 1.0, 0.5) for i in range(n + 1)]


def test_one_pose_a_second_of_mission_time_up_to_the_record_s() -> None:
    poses = track(10.0, 14.0)  # the vehicle's clock: the mission started at 10 s
    log = PoseLog(lambda: poses, lambda: 10.0)
    first = log.until(2.05)
    assert [p["t"] for p in first] == [0.0, 1.0, 2.0]
    assert first[1] == {"t": 1.0, "x": 10.0, "y": 20.0, "z": 1.0, "yaw": 0.5}
    assert log.until(2.05) == []  # each pose once
    assert [p["t"] for p in log.until(4.0)] == [3.0, 4.0]


def test_no_pose_before_the_mission_has_a_start() -> None:
    poses = track(0.0, 3.0)
    origin: list[float | None] = [None]
    log = PoseLog(lambda: poses, lambda: origin[0])
    assert log.until(5.0) == []
    origin[0] = 1.0
    assert [p["t"] for p in log.until(5.0)] == [0.0, 1.0, 2.0]  # none from before the start


def test_the_log_takes_each_pose_before_the_first_record_after_it(tmp_path: Path) -> None:
    poses = track(0.0, 6.0)
    path = tmp_path / "run.jsonl"
    writer = LogWriter(RunLog(path, {"mission": "m"}), PoseLog(lambda: poses, lambda: 0.0))
    writer(Record(2.5, "note", {"note": "a"}))
    writer(Record(2.5, "note", {"note": "b"}))
    writer.end(5.0, "ok")
    writer.log.close()
    records = read_log(path)
    verify(records, path)  # the chain holds and time never goes back
    kinds = [(r["kind"], r["t"]) for r in records[1:]]
    assert kinds == [("pose", 0.0), ("pose", 1.0), ("pose", 2.0), ("note", 2.5),
                     ("note", 2.5), ("pose", 3.0), ("pose", 4.0), ("pose", 5.0), ("end", 5.0)]


def test_the_tracks_and_scenes_of_the_simulated_vehicles() -> None:
    survey = SimpleNamespace(truth=[(0.0, -1.0, 2.0, 3.0)], headings=[(0.25, 0.2)])
    env = SimpleNamespace(area=(-10.0, 0.0, -5.0, 5.0), wall_x=lambda y: 0.01 * y * y)
    stack: Any = SimpleNamespace(survey=survey, env=env)
    ictineu = Vehicle(adapter=NO_ADAPTER, stack=stack)
    found = track_of(ictineu)
    assert found is not None and list(found()) == [(0.0, -1.0, 2.0, 3.0, 0.25)]
    wall = scene_of(ictineu)
    assert wall is not None and is_scene(wall)
    assert wall["lines"]["dam wall"][0] == [0.25, -5.0] and wall["points"] == {}
    scene = SimpleNamespace(target=(30.0, 1.5, 9.5), clutter=((29.0, 2.0),))
    modem = SimpleNamespace(track=[(0.1, 1.0, 2.0, 0.0, 0.0)],
                            world=SimpleNamespace(scene=scene))
    asv = Vehicle(adapter=NO_ADAPTER, modem=modem)
    found = track_of(asv)
    assert found is not None and found() == [(0.1, 1.0, 2.0, 0.0, 0.0)]
    assert scene_of(asv) == {"lines": {}, "points": {"mine": [[30.0, 1.5]],
                                                     "clutter": [[29.0, 2.0]]}}
    bare = Vehicle(adapter=NO_ADAPTER)
    assert track_of(bare) is None and scene_of(bare) is None


def test_a_scene_is_lines_and_points_of_finite_pairs() -> None:
    assert is_scene({"lines": {}, "points": {"mine": [[1, 2.5]]}})
    bad: Any
    for bad in ({"lines": {}}, {"lines": {}, "points": {"mine": [[1, 2, 3]]}},
                {"lines": {}, "points": {"mine": [["1", 2]]}}, [],
                {"lines": {"wall": [[True, 2]]}, "points": {}},
                {"lines": {}, "points": {"mine": [[float("nan"), 2]]}}):
        assert not is_scene(bad), bad
