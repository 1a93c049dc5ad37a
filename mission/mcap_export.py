"""A run as an MCAP file, the field's log format, for Foxglove (docs/MCAP.md).

:func:`write_mcap` writes a verified run log's records (mission/mcap_messages.py), the
vehicle's true and estimated poses and track (a :class:`Track`: the simulated stack's survey
during ``mcl run``, or the camera's index beside the log for ``mcl export``), the camera's
images (the PNGs the run wrote beside its log, by their time), the navigator's error as
plottable numbers, the run's metadata and the files it came from as attachments. Messages are
written in time order: a reader's log times never go back.
"""

from __future__ import annotations

import base64
import csv
import json
import math
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from mission.foxglove_schemas import SCHEMAS, schema_text
from mission.mcap_messages import LogMessages, Message, nanoseconds, stamp

FRAME = "world"  # the simulation's frame: x out from the wall, y along it, z depth (down), m
SURFACE = "surface"  # the frame to look in, z up: world turned half a turn about its x axis
TURN_OVER = {"x": 1.0, "y": 0.0, "z": 0.0, "w": 0.0}  # that half turn, as a quaternion
SEGMENT = 50  # poses per track entity (each entity stays until the end)
STRIDE = 5  # in a file, the track so far keeps one pose in 5 (1 s) before the last segment
TRUE_COLOR = {"r": 0.1, "g": 0.4, "b": 1.0, "a": 1.0}
ESTIMATE_COLOR = {"r": 1.0, "g": 0.5, "b": 0.0, "a": 1.0}


@dataclass(frozen=True)
class Pose:
    """The vehicle's pose at mission time ``t``: position (m) and yaw (rad)."""

    t: float
    x: float
    y: float
    z: float
    yaw: float


@dataclass(frozen=True)
class WallSample:
    """The sonar wall tracker at mission time ``t``: distance (m) and heading relative to the
    wall (rad), and the true ones when known."""

    t: float
    distance: float
    heading: float
    distance_true: float | None = None
    heading_true: float | None = None


@dataclass
class Track:
    """The vehicle's true and estimated poses (pairs at the same instants), USBL fixes
    (t, x, y, z, accepted) and the wall tracker's samples."""

    truth: list[Pose] = field(default_factory=list)
    estimate: list[Pose] = field(default_factory=list)
    fixes: list[tuple[float, float, float, float, bool]] = field(default_factory=list)
    wall: list[WallSample] = field(default_factory=list)
    plane: bool = True  # the dam's wall (the plane x = 0) is drawn beside the track


@dataclass(frozen=True)
class Picture:
    """One camera image the run wrote: its time and PNG file."""

    t: float
    path: Path


@dataclass
class Written:
    """What :func:`write_mcap` wrote: messages per topic, attachments."""

    path: Path
    topics: dict[str, int] = field(default_factory=dict)
    attachments: list[str] = field(default_factory=list)

    def line(self) -> str:
        counts = ", ".join(f"{topic} {n}" for topic, n in self.topics.items())
        return (f"{self.path} ({sum(self.topics.values())} messages: {counts}; "
                f"{len(self.attachments)} attachments)")


def track_of_survey(survey: Any) -> Track:
    """The track the simulated stack's survey kept (vehicle/world/survey.py): 5 poses a
    second, true and estimated, and every USBL fix."""
    headings = list(getattr(survey, "headings", []))
    track = Track(fixes=[(float(t), float(x), float(y), float(z), bool(ok))
                         for t, x, y, z, ok in survey.fixes])
    for i, ((t, x, y, z), (ex, ey, ez)) in enumerate(zip(survey.truth, survey.estimate)):
        yaw, eyaw = headings[i] if i < len(headings) else (0.0, 0.0)
        track.truth.append(Pose(float(t), float(x), float(y), float(z), float(yaw)))
        track.estimate.append(Pose(float(t), float(ex), float(ey), float(ez), float(eyaw)))
    track.wall = [WallSample(float(t), float(d), float(h), float(dt), float(ht))
                  for t, d, dt, h, ht in getattr(survey, "wall", [])]
    return track


def camera_index(folder: Path) -> tuple[list[Picture], Track]:
    """The images a run wrote into ``folder`` (``RUN.images/``: vehicle/sensors/
    image_recorder.py) and the true and estimated poses its ``index.csv`` holds, one per
    image; nothing when there is no index."""
    index = folder / "index.csv"
    if not index.is_file():
        return [], Track()
    pictures, track = [], Track()
    try:
        camera = json.loads((folder / "camera.json").read_text("utf-8"))
        flat = float(camera["wall"]["curvature"]) == 0.0
    except (OSError, ValueError, KeyError, TypeError):
        flat = False
    with index.open(newline="", encoding="utf-8") as f:
        for row in csv.DictReader(f):
            t = float(row["t"])
            pictures.append(Picture(t, folder / Path(row["file"]).name))
            track.truth.append(Pose(t, *(float(row[k]) for k in ("x", "y", "z", "psi"))))
            track.estimate.append(Pose(t, *(float(row[k]) for k in
                                            ("nav_x", "nav_y", "nav_z", "nav_psi"))))
            sample = wall_sample(row, flat)
            if sample is not None:
                track.wall.append(sample)
    return pictures, track


def wall_sample(row: dict[str, str], flat: bool) -> WallSample | None:
    """The wall tracker's sample of an ``index.csv`` row (None without one); the truth too
    for a flat wall (the plane x = 0: the distance is -x, the relative heading the yaw)."""
    try:
        d, h = float(row["wall_distance"]), float(row["wall_heading"])
    except (KeyError, ValueError):
        return None
    if not (math.isfinite(d) and math.isfinite(h)):
        return None
    if not flat:
        return WallSample(float(row["t"]), d, h)
    return WallSample(float(row["t"]), d, h, -float(row["x"]), float(row["psi"]))


def quaternion(yaw: float) -> dict[str, float]:
    """The rotation by ``yaw`` about z."""
    return {"x": 0.0, "y": 0.0, "z": math.sin(yaw / 2), "w": math.cos(yaw / 2)}


def pose_of(p: Pose) -> dict[str, Any]:
    return {"position": {"x": p.x, "y": p.y, "z": p.z}, "orientation": quaternion(p.yaw)}


def pose_messages(track: Track) -> Iterable[Message]:
    """The true and estimated poses, the navigator's error and the wall tracker's estimate
    and error, as numbers to plot."""
    for who, poses in (("true", track.truth), ("estimated", track.estimate)):
        for p in poses:
            yield Message(p.t, f"/vehicle/pose/{who}", "foxglove.PoseInFrame",
                          {"timestamp": stamp(p.t), "frame_id": FRAME, "pose": pose_of(p)})
    for p, e in zip(track.truth, track.estimate):
        yield Message(p.t, "/navigator", "mcl.Navigation", {
            "timestamp": stamp(p.t), "true_x": p.x, "true_y": p.y, "true_z": p.z,
            "true_yaw": p.yaw, "estimated_x": e.x, "estimated_y": e.y, "estimated_z": e.z,
            "estimated_yaw": e.yaw, "error_horizontal": math.hypot(e.x - p.x, e.y - p.y),
            "error_depth": e.z - p.z})
    for w in track.wall:
        yield Message(w.t, "/wall_tracker", "mcl.WallTracker", {
            "timestamp": stamp(w.t), "distance": w.distance, "heading": w.heading,
            **({"distance_true": w.distance_true, "distance_error": w.distance - w.distance_true}
               if w.distance_true is not None else {}),
            **({"heading_true": w.heading_true, "heading_error": w.heading - w.heading_true}
               if w.heading_true is not None else {})})


def frame_messages(track: Track) -> Iterable[Message]:
    """The frame :data:`FRAME` under :data:`SURFACE`, at the track's first pose: a 3D view
    in ``surface`` (z up, as viewers draw) shows depth going down, where one in ``world``
    shows the vehicle upside down. One message, which a viewer seeking anywhere later reads
    as the latest on its topic."""
    if track.truth:
        t = track.truth[0].t
        yield Message(t, "/tf", "foxglove.FrameTransform", {
            "timestamp": stamp(t), "parent_frame_id": SURFACE, "child_frame_id": FRAME,
            "translation": {"x": 0.0, "y": 0.0, "z": 0.0}, "rotation": TURN_OVER})


def track_messages(track: Track, first: int = 0, whole: bool = False) -> Iterable[Message]:
    """The track in segments of :data:`SEGMENT` poses that stay on screen, each with the USBL
    fixes taken while it was driven (at their own times), then the wall and any fix after the
    last pose; ``first``: the number of the track's first pose (a live run sends it in
    stretches). ``whole`` (a file, where a viewer may jump to any time and gets the latest
    message only): each message's entity ``track`` holds the track so far instead
    (:func:`so_far`), with the wall, so that it replaces the one before."""
    drawn = so_far if whole else segment
    for start in range(0, max(len(track.truth) - 1, 0), SEGMENT):
        end = min(start + SEGMENT, len(track.truth) - 1)
        t = track.truth[end].t
        after = track.truth[start].t if first + start > 0 else -math.inf
        lines = [line(drawn(track.truth, start, end), TRUE_COLOR)]
        if track.estimate:
            lines.append(line(drawn(track.estimate, start, end), ESTIMATE_COLOR))
        entities = [entity(t, "track" if whole else f"track/{first + start}", lines=lines)]
        if whole and track.plane:
            entities.append(wall_entity(track, t))
        fixes = [f for f in track.fixes if after < f[0] <= t]
        if fixes:
            entities.append(entity(t, f"usbl/{first + start}", spheres=spheres(fixes)))
        yield Message(t, "/vehicle/track", "foxglove.SceneUpdate",
                      {"deletions": [], "entities": entities})
    if track.truth:
        yield usbl_and_wall(track)


def segment(poses: list[Pose], start: int, end: int) -> list[Pose]:
    """The poses from ``start`` to ``end``, both included."""
    return poses[start:end + 1]


def so_far(poses: list[Pose], start: int, end: int) -> list[Pose]:
    """The poses up to ``end``: every :data:`STRIDE`-th before ``start``, then each one (a
    line of about 10,000 points for the dam's 20 minutes, where all of them make 60,000)."""
    return [*poses[:start:STRIDE], *poses[start:end + 1]]


def line(poses: list[Pose], color: dict[str, float]) -> dict[str, Any]:
    return {"type": 0, "pose": pose_of(Pose(0, 0, 0, 0, 0)), "thickness": 2.0,
            "scale_invariant": True, "points": [{"x": p.x, "y": p.y, "z": p.z} for p in poses],
            "color": color, "colors": [], "indices": []}


def entity(t: float, ident: str, lines: list[dict[str, Any]] | None = None,
           spheres: list[dict[str, Any]] | None = None,
           cubes: list[dict[str, Any]] | None = None) -> dict[str, Any]:
    """A scene entity that stays until the end (lifetime 0)."""
    return {"timestamp": stamp(t), "frame_id": FRAME, "id": ident,
            "lifetime": {"sec": 0, "nsec": 0}, "frame_locked": False, "metadata": [],
            "arrows": [], "cubes": cubes or [], "spheres": spheres or [], "cylinders": [],
            "lines": lines or [], "triangles": [], "texts": [], "models": []}


def spheres(fixes: list[tuple[float, float, float, float, bool]]) -> list[dict[str, Any]]:
    """USBL fixes as spheres at their positions (green: accepted, red: rejected)."""
    return [{"pose": pose_of(Pose(t, x, y, z, 0.0)),
             "size": {"x": 0.1, "y": 0.1, "z": 0.1},
             "color": {"r": 0.1 if ok else 1.0, "g": 0.8 if ok else 0.1, "b": 0.1, "a": 0.8}}
            for t, x, y, z, ok in fixes]


def wall_entity(track: Track, t: float) -> dict[str, Any]:
    """The wall, the plane x = 0, as far as the whole track goes (grey)."""
    ys = [p.y for p in track.truth]
    zs = [p.z for p in track.truth]
    wall = {"pose": pose_of(Pose(t, -0.05, (min(ys) + max(ys)) / 2, max(zs) / 2 + 0.5, 0.0)),
            "size": {"x": 0.1, "y": max(ys) - min(ys) + 4.0, "z": max(zs) + 1.0},
            "color": {"r": 0.6, "g": 0.6, "b": 0.6, "a": 0.4}}
    return entity(t, "wall", cubes=[wall])


def usbl_and_wall(track: Track) -> Message:
    """The wall and the USBL fixes taken after the track's last pose, at that pose's time."""
    t = track.truth[-1].t
    entities = [wall_entity(track, t)] if track.plane else []
    late = [f for f in track.fixes if f[0] > t]
    if late:
        entities.append(entity(t, "usbl/after", spheres=spheres(late)))
    return Message(t, "/vehicle/track", "foxglove.SceneUpdate",
                   {"deletions": [], "entities": entities})


def image_message(picture: Picture) -> Callable[[], Message]:
    """The image's message, read when it is written (a run's images do not all fit in
    memory at once)."""

    def read() -> Message:
        data = base64.b64encode(picture.path.read_bytes()).decode("ascii")
        return Message(picture.t, "/camera/image", "foxglove.CompressedImage", {
            "timestamp": stamp(picture.t), "frame_id": "camera", "data": data,
            "format": "png"})
    return read


def metadata(records: list[dict[str, Any]]) -> dict[str, str]:
    """The run's metadata: mission, net digest, run id (its header's digest), final digest."""
    header, last = records[0], records[-1]
    return {"mission": str(header.get("mission", "")), "file": str(header.get("file", "")),
            "net": str(header.get("net", "")), "run": str(header.get("digest", "")),
            "final_digest": str(last.get("digest", "")), "format": str(header.get("format")),
            "how": str(last.get("how", "")), "exit": str(last.get("exit", "")),
            "time": "mission time: 0 at the mission's start (log_time in ns)"}


@dataclass
class Run:
    """One vehicle's run in an MCAP file: its verified log's ``records``, what else it left,
    and its ``namespace`` (a fleet's: each vehicle's topics, metadata and attachments under
    ``/NAME``; "" for a single run)."""

    records: list[dict[str, Any]]
    track: Track | None = None
    pictures: list[Picture] = field(default_factory=list)
    attachments: list[tuple[str, bytes]] = field(default_factory=list)
    namespace: str = ""

    def items(self) -> list[tuple[float, Message | Callable[[], Message]]]:
        """Its messages (an image's read when written), each with its time."""
        track = self.track
        messages = [*LogMessages.of_log(self.records),
                    *(frame_messages(track) if track is not None else ()),
                    *(pose_messages(track) if track is not None else ()),
                    *(track_messages(track, whole=True) if track is not None else ())]
        out: list[tuple[float, Message | Callable[[], Message]]] = [(m.t, m) for m in messages]
        out += [(p.t, image_message(p)) for p in self.pictures]
        return out


def write_mcap(out: Path, records: list[dict[str, Any]], track: Track | None = None,
               pictures: Iterable[Picture] = (), attachments: Iterable[tuple[str, bytes]] = ()
               ) -> Written:
    """Write the MCAP file ``out`` of a verified run log's ``records`` with what else the run
    left; ``attachments``: (name, bytes) of its files (a ``.png`` is an image, else text)."""
    return write_fleet(out, [Run(records, track, list(pictures), list(attachments))])


@dataclass
class Shared:
    """What a fleet's MCAP file holds outside its vehicles' namespaces: messages (its channel
    record's: mission/mcap_channels.py), metadata by name, attachments."""

    messages: list[Message] = field(default_factory=list)
    metadata: dict[str, dict[str, str]] = field(default_factory=dict)
    attachments: list[tuple[str, bytes]] = field(default_factory=list)


def write_fleet(out: Path, runs: list[Run], shared: Shared | None = None) -> Written:
    """Write the MCAP file ``out`` of one or more runs (a fleet's, each in its namespace, and
    what they share), every message in time order (the runs' mission times side by side)."""
    from mcap.writer import Writer  # lazy, for start-up speed: only a run that asks for it

    shared = shared if shared is not None else Shared()
    items = [(t, n, run.namespace, item) for n, (run, (t, item)) in enumerate(
        (run, pair) for run in runs for pair in run.items())]
    items += [(m.t, len(items) + n, "", m) for n, m in enumerate(shared.messages)]
    items.sort(key=lambda item: (item[0], item[1]))
    written = Written(out)
    with open(out, "wb") as stream:
        writer = Writer(stream)
        writer.start(profile="", library="mcl-auv")
        schemas = {name: writer.register_schema(name, "jsonschema", schema_text(name))
                   for name in SCHEMAS}
        channels: dict[str, int] = {}
        for t, _, namespace, item in items:
            m = item if isinstance(item, Message) else item()
            topic = f"/{namespace}{m.topic}" if namespace else m.topic
            if topic not in channels:
                channels[topic] = writer.register_channel(topic, "json", schemas[m.schema])
            ns = nanoseconds(t)
            writer.add_message(channels[topic], ns, _json(m.data), ns)
            written.topics[topic] = written.topics.get(topic, 0) + 1
        for run in runs:
            writer.add_metadata(f"mcl.run/{run.namespace}" if run.namespace else "mcl.run",
                                metadata(run.records))
        for name, said in shared.metadata.items():
            writer.add_metadata(name, said)
        files = [(f"{run.namespace}/" if run.namespace else "", name, data)
                 for run in runs for name, data in run.attachments]
        for prefix, name, data in [*files, *(("", n, d) for n, d in shared.attachments)]:
            media = "image/png" if name.endswith(".png") else "text/plain"
            writer.add_attachment(0, 0, prefix + name, media, data)
            written.attachments.append(prefix + name)
        writer.finish()  # type: ignore[no-untyped-call]
    return written


def _json(data: dict[str, Any]) -> bytes:
    return json.dumps(data, separators=(",", ":"), allow_nan=False).encode()
