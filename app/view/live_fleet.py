"""``mcl view FLEET.mcl --fleet-vehicle NAME=ENDPOINT ...``: the page of a fleet's run as it
happens, every vehicle followed over Zenoh (docs/FLEET_ZENOH.md).

Each vehicle is followed as ``mcl view --zenoh`` follows one (app/view/live.py's
:class:`LiveRun`, an observer's client session to its endpoint); the page is made of the
vehicles' pages as a finished fleet run's is (app/view/fleet.py): the fleet's tree with each
vehicle's under it, changing colour as its player's status says, one timeline with each
vehicle's events and actions (with their lines) and the messages on the fleet's channels as
the senders' vehicles route them (``mcl/fleet/<fleet>/channel/<channel>``), each at its
sender's mission time. The fleet has ended once every vehicle has ended or is lost.
"""

from __future__ import annotations

import json
import threading
from typing import Any

from aal.zenoh_observer import SessionRefused, observer_session
from mcl.fleet import CompiledFleet

from app.view.data import mission_data
from app.view.fleet import vehicles_page
from app.view.live import LiveRun

MAX_MESSAGES = 1000  # the channel messages the page keeps (the latest)


class LiveFleet:
    """What the view knows of a fleet's live run: a :class:`LiveRun` per vehicle and the
    messages heard on its channels; fed from Zenoh's threads, read by the server's."""

    def __init__(self, fleet: CompiledFleet, endpoints: dict[str, str]):
        self.fleet = fleet
        self.runs = {name: LiveRun(mission_data(compiled), name, endpoints[name])
                     for name, compiled in fleet.vehicles.items()}
        self.lock = threading.Lock()
        self.seen: set[tuple[str, int]] = set()  # (sender, seq): a message heard twice is one
        self.messages: list[dict[str, Any]] = []  # channel, message, sender, sent (its clock)

    def on_channel(self, key: str, payload: bytes) -> None:
        """A message as its sender's player put it on the channel's key (ill-formed ones, and
        ones of another fleet or channel, are dropped)."""
        try:
            d = json.loads(payload)
            said: dict[str, Any] = {"channel": str(d["channel"]), "message": str(d["message"]),
                    "sender": str(d["sender"]), "sent": float(d["sent"])}
            seen = (str(d["sender"]), int(d["seq"]))
        except (ValueError, KeyError, TypeError):
            return
        channel = self.fleet.channels.get(said["channel"])
        if channel is None or key.rpartition("/")[2] != channel.name or \
                said["sender"] != channel.sender:
            return
        with self.lock:
            if seen in self.seen:
                return
            self.seen.add(seen)
            self.messages = [*self.messages, said][-MAX_MESSAGES:]

    def channel_timeline(self) -> list[dict[str, Any]]:
        """The messages heard as timeline entries, each at its sender's mission time (the
        sender's clock less the offset its last status gave)."""
        with self.lock:
            messages = list(self.messages)
        out = []
        for m in messages:
            offset = self.runs[m["sender"]].offset
            out.append({"t": round(m["sent"] - offset, 3), "kind": "channel", "line": None,
                        "text": f"channel {m['channel']}: {m['message']} sent by "
                                f"{m['sender']}"[:200]})
        return out

    def refused(self) -> str:
        """Why a vehicle refused the view's session ("": none did)."""
        return next((run.refused for run in self.runs.values() if run.refused), "")

    def data(self) -> dict[str, Any]:
        """The page's data now."""
        runs = {name: live.data() for name, live in self.runs.items()}
        page = vehicles_page(self.fleet, runs, self.channel_timeline())
        progress = {f"{name} {task}": how for name, d in runs.items()
                    for task, how in d["progress"].items()}
        return {**page, "live": True, "progress": progress,
                "link": "; ".join(d["link"] for d in runs.values())}


def follow_channels(live: LiveFleet, endpoints: list[str], securities: dict[str, Any],
                    stop: threading.Event, ready: threading.Event) -> None:
    """Feed ``live`` the fleet's channel messages heard through every endpoint (an observer's
    session each, as app/view/live.py's ``follow`` opens) until ``stop``; ``ready`` once
    subscribed on every one."""
    from vehicle_adapters.zenoh_channels import channel_key  # lazy: start-up speed (Zenoh)

    from aal.zenoh import close_session, payload_text

    sessions = []
    try:
        for endpoint in endpoints:
            try:
                session = observer_session(endpoint, securities[endpoint], stop)
            except SessionRefused:  # the vehicle's own follower says so (mcl view: exit 2)
                return
            if session is None:
                return
            sessions.append(session)
            session.declare_subscriber(channel_key(live.fleet.name, "*"), lambda s: (
                live.on_channel(str(s.key_expr), payload_text(s))))
        ready.set()
        while not stop.wait(0.5):
            pass
    finally:
        for session in sessions:
            close_session(session)
