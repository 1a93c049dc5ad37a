"""What a fleet adds to its MCAP file besides each vehicle's run (docs/MCAP.md): the channel
record as topics, its metadata, and the tracks of vehicles that keep only their true poses.

- :func:`channel_messages`: every line of the channel record (``channels.jsonl``,
  :class:`mission.channels.ChannelRecord`) but its header and end, as an ``mcl.ChannelEvent``
  on ``/channel/NAME``: the message, its fate (sent, delivered, lost, dropped, undelivered),
  sender and receiver, and the delay of a delivery (to plot);
- :func:`fleet_metadata`: the record's header (the fleet, the seed, the losses, the
  channels' declarations) and its final digest, as the ``mcl.fleet`` metadata;
They go into :class:`mission.mcap_export.Shared` (app/export.py puts them together).

- :func:`track_of_poses`: the true poses a simulated vehicle of paper 003 keeps
  (``McmStack.track``: t, x, y, z, yaw at each tick) as a :class:`Track` at 5 poses a second,
  with no wall and no estimate (its navigator works in the target's frame, not the world's).
"""

from __future__ import annotations

import json
from collections.abc import Iterable
from typing import Any

from mission.mcap_export import Pose, Track
from mission.mcap_messages import Message, stamp

CHANNEL_SCHEMA = "mcl.ChannelEvent"
POSE_INTERVAL = 0.2  # s: a track's poses, 5 a second (as the simulated Ictineu's survey)


def channel_messages(record: list[dict[str, Any]]) -> list[Message]:
    """The channel record's events, each on its channel's topic ``/channel/NAME``."""
    out = []
    for r in record:
        if r.get("kind") in ("header", "end"):
            continue
        data: dict[str, Any] = {
            "timestamp": stamp(float(r["t"])), "channel": str(r["channel"]),
            "message": str(r["message"]), "fate": str(r["kind"]),
            "sender": str(r["sender"]), "receiver": str(r.get("receiver", "")),
            "seq": int(r["seq"]), "sent": float(r["sent"])}
        if "delay" in r:
            data["delay"] = float(r["delay"])
        if r.get("why"):
            data["why"] = str(r["why"])
        out.append(Message(float(r["t"]), f"/channel/{r['channel']}", CHANNEL_SCHEMA, data))
    return out


def fleet_metadata(record: list[dict[str, Any]]) -> dict[str, str]:
    """The ``mcl.fleet`` metadata: the record's header, each value as text (JSON where it is
    not a string), and the record's final digest."""
    header = {k: v for k, v in record[0].items() if k not in ("kind", "_line")}
    said = {k: v if isinstance(v, str) else json.dumps(v, separators=(",", ":"))
            for k, v in header.items()}
    said["run"] = str(header.get("digest", ""))
    said["final_digest"] = str(record[-1].get("digest", ""))
    said.pop("digest", None)
    return said


def track_of_poses(poses: Iterable[tuple[float, float, float, float, float]]) -> Track:
    """A track of true poses (t, x, y, z, yaw), one every :data:`POSE_INTERVAL` s."""
    track = Track(plane=False)
    due = -float("inf")
    for t, x, y, z, yaw in poses:
        if t >= due - 1e-9:
            track.truth.append(Pose(float(t), float(x), float(y), float(z), float(yaw)))
            due = t + POSE_INTERVAL
    return track
