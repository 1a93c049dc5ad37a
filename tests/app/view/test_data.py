"""What ``mcl view`` shows of a run (app/view/data.py): the tree, the states' changes, the
timeline linked to lines, the bounds, the track and the pictures."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest

from app.view.data import line_of, page_data, pictures, track
from mcl.analysis.duration import analyse
from mcl.api import compile_file
from mission.blocks import block_id, key_of
from tests.app.view.runs import DAM, dam_log


def records_of(log: Path) -> list[dict[str, Any]]:
    return [json.loads(line) for line in log.read_text("ascii").splitlines()]


@pytest.fixture(scope="module")
def leak(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return dam_log(tmp_path_factory.mktemp("leak"))


def flatten(node: dict[str, Any]) -> list[dict[str, Any]]:
    return [node] + [n for child in node["children"] for n in flatten(child)]


def test_the_tree_holds_every_task_call_with_its_line(leak: Path) -> None:
    compiled = compile_file(str(DAM), require_values=True)
    data = page_data(compiled, records_of(leak), leak)
    nodes = {n["id"]: n for n in flatten(data["tree"])}
    calls = compiled.mission.calls()
    assert len(calls) == 15
    for call in calls:
        n = nodes[block_id(key_of(call))]
        assert (n["kind"], n["line"]) == ("task", call.span.line)
        assert n["title"].startswith(call.name + "(")
        assert data["source"][call.span.line - 1].strip().startswith(call.name)
    slots = [n["slot"] for n in flatten(data["tree"]) if n["slot"]]
    assert slots == ["TRY", "TRY", "CATCH", "DO", "CATCH", "DO"]
    assert [n["title"] for n in data["tree"]["children"]][-1] == "ON STOP"


def test_changes_timeline_and_bounds(leak: Path) -> None:
    compiled = compile_file(str(DAM), require_values=True)
    records = records_of(leak)
    data = page_data(compiled, records, leak)
    ids = {n["id"] for n in flatten(data["tree"])}
    assert {c[1] for c in data["changes"]} <= ids
    assert [c[0] for c in data["changes"]] == sorted(c[0] for c in data["changes"])
    # every action is linked to its task call's line; every event that fired something to
    # the line of what it fired; the leak to the CATCH's Alarms() (line 49)
    actions = [r for r in records if r["kind"] == "action"]
    shown = [e for e in data["timeline"] if e["kind"] == "action"]
    assert [e["line"] for e in shown] == [line_of(a["task"]) for a in actions]
    leak_entry = next(e for e in data["timeline"] if e["text"] == "Alarms.leak")
    assert (leak_entry["t"], leak_entry["line"]) == (600.0, 49)
    assert data["timeline"][-1]["kind"] == "end" and "OK" in data["timeline"][-1]["text"]
    proved = analyse(compiled.checked)
    assert (data["bounds"]["best"], data["bounds"]["worst"]) == (proved.best, proved.worst)
    assert data["bounds"]["blocks"]["task@34:9"] == [0.0, 600.0]  # GoTo's timeout: 10 min
    assert data["bounds"]["blocks"]["task@49:9"] == [0.0, None]  # a watcher: unbounded
    assert data["end"] == {"t": records[-1]["t"], "status": "ok"}


def test_the_track_from_poses_else_the_images(leak: Path, tmp_path: Path) -> None:
    records = records_of(leak)
    assert track(records, tmp_path / "run.jsonl") == ("", [])
    images = tmp_path / "run.images"
    images.mkdir()
    (images / "index.csv").write_text("index,t,file,nav_x,nav_y,nav_z\n0,1.5,a.png,-1.5,0,1\n"
                                      "1,2.5,b.png,-1.5,0.5,nan\n2,3,c.png,-1.4,1,2\n")
    source, points = track(records, tmp_path / "run.jsonl")
    assert "camera" in source and points == [[1.5, -1.5, 0.0, 1.0], [3.0, -1.4, 1.0, 2.0]]
    poses = records + [{"kind": "pose", "t": 4.0, "x": 1, "y": 2, "z": 3}]
    assert track(poses, tmp_path / "run.jsonl") == ("the run log's poses", [[4.0, 1.0, 2.0, 3.0]])


def test_pictures_beside_the_log(tmp_path: Path) -> None:
    log = tmp_path / "r.jsonl"
    assert pictures(log) == {}
    (tmp_path / "r.mosaic.png").write_bytes(b"\x89PNG")
    (tmp_path / "r.svg").write_text("<svg/>")
    assert pictures(log) == {"mosaic": tmp_path / "r.mosaic.png",
                             "trajectory": tmp_path / "r.svg"}
