"""The JSON schemas of the messages a run's MCAP file holds (docs/MCAP.md).

Foxglove shows a JSON message with its own panels when the message's schema is named as one of
its well-known types: ``foxglove.Log``, ``foxglove.PoseInFrame``, ``foxglove.FrameTransform``,
``foxglove.SceneUpdate``, ``foxglove.CompressedImage``. The fields and their types below are
those of Foxglove's definitions (the foxglove-sdk repository, ``schemas/jsonschema/``, as of
its 2025 schemas): written out here as JSON Schema, so that a test can validate every message
against the schema it is recorded under. Every property is typed (an enumeration is a
``oneOf`` of ``const`` values, an array has typed ``items``), as Foxglove's own schemas are:
Lichtblick and Foxglove derive a message's fields from its schema and refuse a channel whose
schema has a property without a type. Fields Foxglove adds and a run never fills
(``message_id``, ``lineage``) are left out; a JSON Schema allows them anyway. The schemas
named ``mcl.*`` are ours: the mission's status (each task call's state, for Foxglove's State
Transitions panel), the navigator's estimate and the sonar wall tracker's against the truth
(for its Plot panel), and a fleet's channel events (each message sent, delivered, lost,
dropped or left undelivered: its delay plottable).
"""

from __future__ import annotations

import json
from typing import Any

Schema = dict[str, Any]


def _object(title: str, properties: dict[str, Any], required: list[str] | None = None
            ) -> Schema:
    """An object schema whose every property is required unless ``required`` says which."""
    return {"title": title, "type": "object", "properties": properties,
            "required": list(properties) if required is None else required}


def _numbers(title: str, names: str) -> Schema:
    return _object(title, {n: {"type": "number"} for n in names})


def _enumeration(title: str, names: str) -> Schema:
    """A Foxglove enumeration as its own schemas write it: one ``const`` per value, each titled
    with its name (a bare ``enum`` has no type, and Lichtblick and Foxglove refuse the whole
    channel: "Unsupported type undefined for level")."""
    return {"title": title, "description": ", ".join(
        f"{name} {n}" for n, name in enumerate(names.split())),
        "oneOf": [{"title": name, "const": n} for n, name in enumerate(names.split())]}


TIME = {"type": "object", "title": "time", "required": ["sec", "nsec"], "properties": {
    "sec": {"type": "integer", "minimum": 0},
    "nsec": {"type": "integer", "minimum": 0, "maximum": 999_999_999}}}
DURATION = {"type": "object", "title": "duration", "required": ["sec", "nsec"], "properties": {
    "sec": {"type": "integer"},
    "nsec": {"type": "integer", "minimum": 0, "maximum": 999_999_999}}}
VECTOR3 = _numbers("foxglove.Vector3", "xyz")
POINT3 = _numbers("foxglove.Point3", "xyz")
QUATERNION = _numbers("foxglove.Quaternion", "xyzw")
COLOR = _numbers("foxglove.Color", "rgba")
POSE = _object("foxglove.Pose", {"position": VECTOR3, "orientation": QUATERNION})

LOG = _object("foxglove.Log", {
    "timestamp": TIME,
    "level": _enumeration("foxglove.LogLevel", "UNKNOWN DEBUG INFO WARNING ERROR FATAL"),
    "message": {"type": "string"},
    "name": {"type": "string", "description": "process or node name"},
    "file": {"type": "string"},
    "line": {"type": "integer", "minimum": 0}})

POSE_IN_FRAME = _object("foxglove.PoseInFrame", {
    "timestamp": TIME, "frame_id": {"type": "string"}, "pose": POSE})

FRAME_TRANSFORM = _object("foxglove.FrameTransform", {
    "timestamp": TIME, "parent_frame_id": {"type": "string"},
    "child_frame_id": {"type": "string"}, "translation": VECTOR3, "rotation": QUATERNION})

COMPRESSED_IMAGE = _object("foxglove.CompressedImage", {
    "timestamp": TIME, "frame_id": {"type": "string"},
    "data": {"type": "string", "contentEncoding": "base64"},
    "format": {"type": "string", "enum": ["jpeg", "png", "webp", "avif"]}})

LINE_PRIMITIVE = _object("foxglove.LinePrimitive", {
    "type": _enumeration("foxglove.LineType", "LINE_STRIP LINE_LOOP LINE_LIST"),
    "pose": POSE, "thickness": {"type": "number", "minimum": 0},
    "scale_invariant": {"type": "boolean"},
    "points": {"type": "array", "items": POINT3}, "color": COLOR,
    "colors": {"type": "array", "items": COLOR},
    "indices": {"type": "array", "items": {"type": "integer", "minimum": 0}}})

SPHERE_PRIMITIVE = _object("foxglove.SpherePrimitive", {
    "pose": POSE, "size": VECTOR3, "color": COLOR})
CUBE_PRIMITIVE = _object("foxglove.CubePrimitive", {
    "pose": POSE, "size": VECTOR3, "color": COLOR})
# the primitives a run never draws: typed all the same, since a reader (Lichtblick, Foxglove)
# derives the message's fields from every property of the schema and refuses an untyped one
ARROW_PRIMITIVE = _object("foxglove.ArrowPrimitive", {
    "pose": POSE, **{n: {"type": "number"} for n in (
        "shaft_length", "shaft_diameter", "head_length", "head_diameter")}, "color": COLOR})
CYLINDER_PRIMITIVE = _object("foxglove.CylinderPrimitive", {
    "pose": POSE, "size": VECTOR3, "bottom_scale": {"type": "number"},
    "top_scale": {"type": "number"}, "color": COLOR})
TRIANGLE_LIST_PRIMITIVE = _object("foxglove.TriangleListPrimitive", {
    "pose": POSE, "points": {"type": "array", "items": POINT3}, "color": COLOR,
    "colors": {"type": "array", "items": COLOR},
    "indices": {"type": "array", "items": {"type": "integer", "minimum": 0}}})
TEXT_PRIMITIVE = _object("foxglove.TextPrimitive", {
    "pose": POSE, "billboard": {"type": "boolean"}, "font_size": {"type": "number"},
    "scale_invariant": {"type": "boolean"}, "color": COLOR, "text": {"type": "string"}})
MODEL_PRIMITIVE = _object("foxglove.ModelPrimitive", {
    "pose": POSE, "scale": VECTOR3, "color": COLOR, "override_color": {"type": "boolean"},
    "url": {"type": "string"}, "media_type": {"type": "string"},
    "data": {"type": "string", "contentEncoding": "base64"}})

SCENE_ENTITY = _object("foxglove.SceneEntity", {
    "timestamp": TIME, "frame_id": {"type": "string"}, "id": {"type": "string"},
    "lifetime": DURATION, "frame_locked": {"type": "boolean"},
    "metadata": {"type": "array", "items": _object("foxglove.KeyValuePair", {
        "key": {"type": "string"}, "value": {"type": "string"}})},
    "arrows": {"type": "array", "items": ARROW_PRIMITIVE},
    "cubes": {"type": "array", "items": CUBE_PRIMITIVE},
    "spheres": {"type": "array", "items": SPHERE_PRIMITIVE},
    "cylinders": {"type": "array", "items": CYLINDER_PRIMITIVE},
    "lines": {"type": "array", "items": LINE_PRIMITIVE},
    "triangles": {"type": "array", "items": TRIANGLE_LIST_PRIMITIVE},
    "texts": {"type": "array", "items": TEXT_PRIMITIVE},
    "models": {"type": "array", "items": MODEL_PRIMITIVE}})

SCENE_UPDATE = _object("foxglove.SceneUpdate", {
    "deletions": {"type": "array", "items": _object("foxglove.SceneEntityDeletion", {
        "timestamp": TIME, "type": _enumeration("foxglove.SceneEntityDeletionType",
                                                "MATCHING_ID ALL"),
        "id": {"type": "string"}})},
    "entities": {"type": "array", "items": SCENE_ENTITY}})

TASK_STATES = ("waiting", "running", "ok", "fail", "aborted", "ended")  # ended: mcl monitor

MISSION_STATUS = _object("mcl.MissionStatus", {
    "timestamp": TIME,
    "mission": {"type": "string"},
    "status": {"type": "string", "enum": ["running", "ok", "fail", "ended"]},
    "tasks": {"type": "array", "items": _object("mcl.TaskState", {
        "task": {"type": "string", "description": "the task call, Task@line:column"},
        "line": {"type": "integer", "minimum": 0},
        "state": {"type": "string", "enum": list(TASK_STATES)}})}})

NAVIGATION = _object("mcl.Navigation", {
    "timestamp": TIME,
    **{f"{who}_{axis}": {"type": "number"} for who in ("true", "estimated")
       for axis in ("x", "y", "z", "yaw")},
    "error_horizontal": {"type": "number", "minimum": 0,
                         "description": "m, the navigator's horizontal error"},
    "error_depth": {"type": "number", "description": "m, estimated depth minus true depth"}})

WALL_TRACKER = _object("mcl.WallTracker", {
    "timestamp": TIME,
    "distance": {"type": "number", "description": "m, the sonar wall tracker's distance"},
    "heading": {"type": "number", "description": "rad, its heading relative to the wall"},
    "distance_true": {"type": "number"}, "heading_true": {"type": "number"},
    "distance_error": {"type": "number", "description": "m, tracked minus true"},
    "heading_error": {"type": "number", "description": "rad, tracked minus true"}},
    required=["timestamp", "distance", "heading"])

FATES = ("sent", "delivered", "lost", "dropped", "undelivered")  # a channel record's lines

CHANNEL_EVENT = _object("mcl.ChannelEvent", {
    "timestamp": TIME,
    "channel": {"type": "string"},
    "message": {"type": "string"},
    "fate": {"type": "string", "enum": list(FATES)},
    "sender": {"type": "string"},
    "receiver": {"type": "string", "description": "\"\" for sent (every receiver)"},
    "seq": {"type": "integer", "minimum": 0, "description": "the sender's message number"},
    "sent": {"type": "number", "description": "s, the sender's mission time when sent"},
    "delay": {"type": "number", "minimum": 0, "description": "s, from send to delivery"},
    "why": {"type": "string"}},
    required=["timestamp", "channel", "message", "fate", "sender", "receiver", "seq",
              "sent"])

SCHEMAS: dict[str, Schema] = {s["title"]: s for s in (
    LOG, POSE_IN_FRAME, FRAME_TRANSFORM, SCENE_UPDATE, COMPRESSED_IMAGE, MISSION_STATUS,
    NAVIGATION, WALL_TRACKER, CHANNEL_EVENT)}


def schema_text(name: str) -> bytes:
    """The schema ``name`` as the bytes an MCAP schema record holds."""
    return json.dumps(SCHEMAS[name], separators=(",", ":")).encode()
