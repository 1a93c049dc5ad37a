"""The running mission served live to Foxglove (docs/MCAP.md, "Live").

:class:`LiveView` starts foxglove-sdk's WebSocket server (protocol ``foxglove.sdk.v1``) and
publishes on it the channels of a run's MCAP file as they happen: a player observer turns each
record into its ``/mission/log`` and ``/mission/status`` messages (mission/mcap_messages.py),
and :meth:`LiveView.follow` publishes the simulated vehicle's poses, navigator error and track
as its survey records them. The server's time is mission time (:meth:`LiveView.publish`), so
that a viewer stamps what it receives as in the run's file; ``mcl monitor`` forwards what it hears over Zenoh instead
(:meth:`LiveView.remote_status`, :meth:`LiveView.remote_pose`). foxglove-sdk is an optional extra (``pip install
mcl-auv[foxglove]``); without it the view is refused with that hint.
"""

from __future__ import annotations

import json
import math
import threading
import time
from typing import Any

from diagnostics import MclError
from petri.execution.player import Record
from petri.net import Net
from petri.semantics import block_of

from mission.foxglove_schemas import SCHEMAS
from mission.mcap_export import (SEGMENT, Pose, Track, frame_messages, pose_messages, track_messages,
                                 track_of_survey)
from mission.mcap_messages import LogMessages, nanoseconds, source_order

FOLLOW_EVERY = 0.2  # wall s between two looks at the survey's new poses
LAST_WORDS = 0.2  # wall s for the last messages (the mission's end) to reach the clients
STATUS_EVERY = 1.0  # mission s: the status is sent again this often while it does not change


def address(text: str) -> tuple[str, int]:
    """``HOST:PORT`` (``--foxglove``); ValueError with the reason if it is not one."""
    host, colon, port = text.rpartition(":")
    if not colon or not host or not port.isdigit() or not 0 <= int(port) < 65536:
        raise ValueError(f"{text!r} is not HOST:PORT (e.g. 127.0.0.1:8765)")
    return host, int(port)


def _json_object(text: str | bytes) -> dict[str, Any] | None:
    try:
        data = json.loads(text)
    except ValueError:
        return None
    return data if isinstance(data, dict) else None


def _number(value: Any) -> bool:
    return (isinstance(value, (int, float)) and not isinstance(value, bool)
            and math.isfinite(value))


def task_calls(net: Net) -> list[str]:
    """The task calls of a mission's net, in source order (``GoTo@34:9``)."""
    return sorted({block_of(t.name) for t in net.transitions
                   if t.origin is not None and t.origin.kind == "task"}, key=source_order)


class LiveView:
    """A Foxglove WebSocket server for one run; call it with the player's records."""

    def __init__(self, host: str, port: int, header: dict[str, Any], calls: list[str]):
        try:
            import foxglove  # lazy: an optional extra, and only a live run needs it
        except ImportError:
            raise MclError("--foxglove needs foxglove-sdk, an optional extra: pip install "
                           "'mcl-auv[foxglove]'", code="missing-extra") from None
        try:
            self.server = foxglove.start_server(name="mcl", host=host, port=port,
                                                capabilities=[foxglove.Capability.Time])
        except Exception as exc:  # foxglove's own error type: the port is taken, a bad host
            raise MclError(f"--foxglove {host}:{port}: cannot serve there ({exc})",
                           code="foxglove") from None
        self.channels = {}
        self.lock = threading.Lock()
        self.messages = LogMessages(header, calls)
        self.sent = 0  # poses of the followed survey published so far
        self.drawn = 0  # the last pose of the track published so far
        self.walls = 0  # the wall tracker's samples published so far
        self.clock = -1  # the mission time (ns) last sent to the clients as the server's time
        self.said: float | None = None  # the mission time of the last status published
        self.stopped = threading.Event()
        self.follower: threading.Thread | None = None
        topics = {"/mission/log": "foxglove.Log", "/mission/status": "mcl.MissionStatus",
                  "/vehicle/pose/true": "foxglove.PoseInFrame",
                  "/vehicle/pose/estimated": "foxglove.PoseInFrame",
                  "/navigator": "mcl.Navigation", "/vehicle/track": "foxglove.SceneUpdate",
                  "/wall_tracker": "mcl.WallTracker", "/tf": "foxglove.FrameTransform"}
        for topic, schema in topics.items():
            self.channels[topic] = foxglove.Channel(topic, schema=SCHEMAS[schema])

    @property
    def port(self) -> int:
        return int(self.server.port)

    def __call__(self, record: Record) -> None:
        with self.lock:
            self.publish(self.messages.feed({"t": record.t, "kind": record.kind,
                                             **record.data}))

    def publish(self, messages: Any) -> None:
        """Log each message at its mission time, after telling the clients the time if it is
        later than the last they were told: a viewer stamps what it receives with the server's
        time (Lichtblick does, with its own clock otherwise), so its clock, Plot and State
        Transitions run on mission time as with the run's file. The server's time never goes
        back (Lichtblick drops what it holds when it does). foxglove-sdk sends the time and the
        messages to a client from two queues of its own (control and data), so a message may
        reach it just before the time told before it, never without it."""
        for m in messages:
            channel = self.channels.get(m.topic)
            if channel is None:
                continue
            if m.topic == "/mission/status":
                self.said = m.t if self.said is None else max(self.said, m.t)
            at = nanoseconds(m.t)
            if at > self.clock:
                self.server.broadcast_time(at)
                self.clock = at
            channel.log(m.data, log_time=at)

    def poses(self, track: Track) -> None:
        """Publish the vehicle's poses and the navigator's error, with the frame they are in
        (``/tf``, as in a file) each time, so that a viewer that connects late knows it too;
        and the status again if it has not changed for a while (:meth:`still`)."""
        with self.lock:
            self.publish(frame_messages(track))
            self.publish(pose_messages(track))
            self.still(track.truth[-1].t if track.truth else -math.inf)

    def still(self, t: float) -> None:
        """The status again at mission time ``t`` if it was last sent :data:`STATUS_EVERY` or
        more before (not before it is first sent): a viewer draws a state up to the next message of its topic only (in
        Lichtblick's State Transitions panel, a task call running for minutes was a label
        with no bar after it)."""
        if self.said is not None and t >= self.said + STATUS_EVERY:
            self.publish([self.messages.status_message(t)])

    def follow(self, survey: Any) -> None:
        """Publish the simulated vehicle's new poses every :data:`FOLLOW_EVERY` seconds, from
        a thread of its own, until :meth:`close`."""
        def run() -> None:
            while not self.stopped.wait(FOLLOW_EVERY):
                self.catch_up(survey)

        self.follower = threading.Thread(target=run, name="foxglove-live", daemon=True)
        self.follower.start()

    def catch_up(self, survey: Any, last: bool = False) -> None:
        """Publish the poses the survey recorded since the last look, and the track in
        segments of :data:`SEGMENT` poses (``last``: what is left of it too)."""
        track = track_of_survey(survey)
        self.poses(Track(track.truth[self.sent:], track.estimate[self.sent:],
                         wall=track.wall[self.walls:]))
        self.sent, self.walls = len(track.truth), len(track.wall)
        while self.sent - 1 - self.drawn >= (1 if last else SEGMENT):
            end = min(self.drawn + SEGMENT, self.sent - 1)
            part = Track(track.truth[self.drawn:end + 1], track.estimate[self.drawn:end + 1],
                         track.fixes)
            with self.lock:
                self.publish(track_messages(part, self.drawn))
            self.drawn = end

    def remote_status(self, text: str | bytes) -> None:
        """A player's status as ``mcl monitor`` hears it over Zenoh (petri/execution/status.py,
        ``v`` 1): the task calls it names running are ``running``; one no longer running is
        ``ended`` (the status does not say how it ended)."""
        status = _json_object(text)
        if status is None or status.get("v") != 1:
            return
        running = {str(r.get("task")) for r in status.get("running") or []
                   if isinstance(r, dict)}
        with self.lock:
            states = self.messages.states
            for call in running:
                states[call] = "running"
            for call, state in states.items():
                if state == "running" and call not in running:
                    states[call] = "ended"
            self.messages.states = dict(sorted(states.items(), key=lambda i: source_order(i[0])))
            self.messages.mission = str(status.get("mission", ""))
            self.messages.status = str(status.get("status", "running"))
            t = status.get("t")
            at = float(t) if isinstance(t, (int, float)) and _number(t) else 0.0
            self.publish([self.messages.status_message(at)])

    def remote_pose(self, text: str | bytes) -> None:
        """The navigator's telemetry as ``mcl monitor`` hears it (docs/ZENOH.md): its pose,
        on ``/vehicle/pose/estimated`` (the true pose is the simulator's own)."""
        data = _json_object(text)
        if data is None or not all(_number(data.get(k)) for k in ("t", "x", "y", "z", "yaw")):
            return
        pose = Pose(*(float(data[k]) for k in ("t", "x", "y", "z", "yaw")))
        with self.lock:
            self.publish(frame_messages(Track([pose], [pose])))
            self.publish([m for m in pose_messages(Track([pose], [pose]))
                          if m.topic == "/vehicle/pose/estimated"])

    def close(self, survey: Any = None) -> None:
        """The last poses and messages, a moment for them to leave, then the server
        stopped."""
        self.stopped.set()
        if self.follower is not None:
            self.follower.join()
        if survey is not None:
            self.catch_up(survey, last=True)
        with self.lock:
            self.publish(self.messages.flush())
        time.sleep(LAST_WORDS)
        self.server.stop()
