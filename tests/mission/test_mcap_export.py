"""What Lichtblick (and Foxglove) need of a run's MCAP file to draw it (docs/MCAP.md, "Seen
in Lichtblick"): every schema typed as their JSON Schema reader requires, the 3D view's frame
with z up, and the Lichtblick layout of tools/lichtblick/ naming only what a run writes.

Opening the dam run in Lichtblick found the first two: its reader refused ``/mission/log`` and
``/vehicle/track`` whole ("Unsupported type undefined for level"), and the frame ``world`` was
unknown to its 3D panel, which drew the vehicle upside down in depth."""

from __future__ import annotations

import json
import math
import re
from pathlib import Path
from typing import Any

import pytest

from mcl.api import compile_file
from mission.foxglove_live import task_calls
from mission.foxglove_schemas import SCHEMAS, Schema
from mission.mcap_export import FRAME, SURFACE, Picture, Pose, Track, WallSample, write_mcap
from tests.support import MISSIONS, REPO

jsonschema = pytest.importorskip("jsonschema")
reader = pytest.importorskip("mcap.reader")

LAYOUT = REPO / "tools" / "lichtblick" / "layout.json"
PNG = bytes.fromhex("89504e470d0a1a0a0000000d4948445200000001000000010800000000"
                    "3a7e9b550000000a4944415478da63600000000200017e21bc330000000049454e44ae426082")


def unreadable(schema: Schema, path: str) -> list[str]:
    """The properties of an object schema that Lichtblick's JSON Schema reader refuses
    (packages/mcap-support/src/parseJsonSchema.ts, v1.28.1): each property needs a type
    (boolean, string, number, integer, object, array) or a ``oneOf`` of numeric ``const``
    values; an array's items need a type other than an array; a string's only encoding is
    base64, and never in an array."""
    if schema.get("type") != "object":
        return [f"{path}: not an object"]
    wrong = []
    for name, field in schema.get("properties", {}).items():
        where = f"{path}.{name}"
        if "oneOf" in field:
            if not all(isinstance(a.get("const"), int) for a in field["oneOf"]):
                wrong.append(f"{where}: oneOf without numeric const values")
            continue
        kind = field.get("type")
        if kind == "object":
            wrong += unreadable(field, where)
        elif kind == "array":
            items = field.get("items") or {}
            if items.get("type") == "object":
                wrong += unreadable(items, f"{where}[]")
            elif items.get("type") not in ("boolean", "string", "number", "integer") or \
                    "contentEncoding" in items:
                wrong.append(f"{where}[]: items of type {items.get('type')!r}")
        elif kind not in ("boolean", "string", "number", "integer"):
            wrong.append(f"{where}: type {kind!r}")
        elif field.get("contentEncoding", "base64") != "base64":
            wrong.append(f"{where}: encoding {field['contentEncoding']!r}")
    return wrong


@pytest.mark.parametrize("name", sorted(SCHEMAS))
def test_every_schema_is_one_lichtblick_reads(name: str) -> None:
    assert unreadable(SCHEMAS[name], name) == []


def test_an_untyped_enumeration_is_found() -> None:
    """The check above catches what Lichtblick refused in the first file it was given."""
    bare = {"type": "object", "properties": {"level": {"enum": [0, 1, 2]},
                                             "arrows": {"type": "array"}}}
    assert unreadable(bare, "foxglove.Log") == ["foxglove.Log.level: type None",
                                                "foxglove.Log.arrows[]: items of type None"]


def rotate(q: dict[str, float], p: tuple[float, float, float]) -> tuple[float, ...]:
    """The point ``p`` turned by the unit quaternion ``q``."""
    x, y, z, w = q["x"], q["y"], q["z"], q["w"]
    matrix = [[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
              [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
              [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]]
    return tuple(sum(row[i] * p[i] for i in range(3)) for row in matrix)


def diving(n: int = 120) -> Track:
    """A vehicle going down (z grows in ``world``) along the wall, 5 poses a second."""
    truth = [Pose(0.2 * i, -1.5, 0.05 * i, 0.5 + 0.02 * i, 0.1) for i in range(n)]
    return Track(truth, [Pose(p.t, p.x + 0.01, p.y, p.z, p.yaw) for p in truth],
                 wall=[WallSample(p.t, 1.49, 0.1, 1.5, 0.1) for p in truth])


RECORDS = [{"kind": "header", "mission": "dive", "file": "dive.mcl", "format": 1},
           {"t": 24.0, "kind": "end", "how": "ok", "exit": 0}]


def read(path: Path) -> list[tuple[str, str, int, dict[str, Any]]]:
    with path.open("rb") as f:
        return [(channel.topic, schema.name, message.log_time, json.loads(message.data))
                for schema, channel, message in reader.make_reader(f).iter_messages()]


def test_the_3d_view_has_a_frame_with_z_up_where_depth_goes_down(tmp_path: Path) -> None:
    out = tmp_path / "dive.mcap"
    write_mcap(out, RECORDS, diving())
    held = read(out)
    frames = [(t, d) for topic, name, t, d in held if topic == "/tf"]
    assert len(frames) == 1 and frames[0][0] == 0  # once, at the first pose: any seek reads it
    tf = frames[0][1]
    jsonschema.validate(tf, SCHEMAS["foxglove.FrameTransform"])
    assert (tf["parent_frame_id"], tf["child_frame_id"]) == (SURFACE, FRAME)
    assert math.isclose(sum(v * v for v in tf["rotation"].values()), 1.0)
    poses = [d for topic, _, _, d in held if topic == "/vehicle/pose/true"]
    assert {p["frame_id"] for p in poses} == {FRAME}
    heights = [rotate(tf["rotation"], tuple(p["pose"]["position"][k] for k in "xyz"))[2]
               for p in poses]
    depths = [p["pose"]["position"]["z"] for p in poses]
    assert depths[-1] > depths[0] > 0 and heights[-1] < heights[0] < 0  # deeper is lower
    along = [rotate(tf["rotation"], tuple(p["pose"]["position"][k] for k in "xyz"))[0]
             for p in poses]
    assert along == pytest.approx([p["pose"]["position"]["x"] for p in poses])


def layout_topics(layout: dict[str, Any]) -> set[str]:
    """Every topic the layout's panels read: message paths' topics, 3D and image topics."""
    text = json.dumps(layout["configById"])
    paths = re.findall(r'"value": "(/[\w/]+)', text)
    panels = layout["configById"].values()
    return {*paths, *(t for p in panels for t in p.get("topics", {})),
            *(p["imageMode"]["imageTopic"] for p in panels
              if p.get("imageMode", {}).get("imageTopic"))}


def test_the_lichtblick_layout_names_what_a_run_writes(tmp_path: Path) -> None:
    layout = json.loads(LAYOUT.read_text("utf-8"))
    picture = tmp_path / "0001.png"
    picture.write_bytes(PNG)
    out = tmp_path / "dive.mcap"
    write_mcap(out, RECORDS, diving(), [Picture(1.0, picture)])
    written = {topic for topic, _, _, _ in read(out)}
    assert layout_topics(layout) <= written and "/camera/image" in layout_topics(layout)
    follow = {p["followTf"] for p in layout["configById"].values() if "followTf" in p}
    assert follow == {SURFACE}
    calls = set(task_calls(compile_file(str(MISSIONS / "dam_inspection.mcl")).net))
    named = set(re.findall(r'task==\\"([^\\]+)\\"', json.dumps(layout["configById"])))
    assert named and named <= calls, named - calls
    panels = set(re.findall(r'"([A-Za-z0-9]+![A-Za-z0-9]+)"', json.dumps(layout["layout"])))
    assert panels == set(layout["configById"])  # every panel placed, none unconfigured


def test_the_latest_track_message_holds_the_track_so_far(tmp_path: Path) -> None:
    """A viewer that jumps to a time gets only the latest message of each topic: each track
    message of a file draws the whole track up to its time (a pose a second at least) and the
    wall, where a live view's draw only their own stretch."""
    track = diving(230)
    out = tmp_path / "dive.mcap"
    write_mcap(out, RECORDS, track)
    updates = [(t, d) for topic, _, t, d in read(out) if topic == "/vehicle/track"]
    assert len(updates) >= 5
    times = [p.t for p in track.truth]
    for t, update in updates[:-1]:  # the last: the wall and the fixes after the last pose
        drawn = {e["id"]: e for e in update["entities"]}
        assert {"track", "wall"} <= set(drawn)
        true, estimated = (line["points"] for line in drawn["track"]["lines"])
        assert len(true) == len(estimated)
        at = [times[[p.y for p in track.truth].index(q["y"])] for q in true]
        assert at[0] == times[0] and at[-1] * 1e9 == pytest.approx(t)  # from the start to now
        assert max(b - a for a, b in zip(at, at[1:])) <= 1.0 + 1e-9  # a pose a second at least
    assert len(true) < len(times) / 2  # the past kept at a pose a second, not all five
