"""``mcl view --zenoh ENDPOINT``: the page of a run as it happens, fed by the mission status
the player publishes (``mcl/<v>/mission/status``, docs/ZENOH.md) and both sides' liveliness
tokens, read as ``mcl monitor`` reads them (an observer: it sends nothing). ``mcl run
--view`` feeds the same :class:`LiveRun` in the player's own process, with the same status
dicts (:meth:`LiveRun.take_status`) and the vehicle's poses (app/view/run_view.py).

Each status names the state of every block started so far (``blocks``, mission/blocks.py); a
change from the status before is a change on the page, at the status's mission time. Its
last event and last action go into the timeline. The vehicle's track is its navigator's
estimate (``mcl/<v>/telemetry/navigator``), on the vehicle's clock, put on mission time by the
last status (which gives both); while the mission runs, the page's "now" moves on with the
vehicle's clock (``mcl/<v>/telemetry/clock``) between statuses, as ``mcl monitor``'s does. A status of a new run (another ``run`` id)
starts the page afresh; a status of another mission is set aside and said. The running tasks
with a bound or a progress (waypoint k of n, metres to go, time left of the bound) are the
page's ``progress``, shown beside its summary while the mission runs.
"""

from __future__ import annotations

import json
import math
import threading
from typing import Any

from aal.zenoh_observer import SessionRefused, observer_session

from app.monitor import task_detail
from app.view.data import MAX_TRACK, line_of

FRESH = {"changes": [], "timeline": [], "end": {"t": 0.0, "status": None}}


class LiveRun:
    """What the view knows of a live run; fed from Zenoh's threads, read by the server's."""

    def __init__(self, base: dict[str, Any], vehicle: str, endpoint: str):
        self.base = base  # the mission's page data before any run (app/view/data.py)
        self.vehicle, self.endpoint = vehicle, endpoint
        self.lock = threading.Lock()
        self.run: str | None = None
        self.t = 0.0
        self.status: str | None = None
        self.states: dict[str, str] = {}
        self.changes: list[list[Any]] = []
        self.timeline: list[dict[str, Any]] = []
        self.vehicle_alive: bool | None = None
        self.other = ""  # the mission of a status set aside
        self.positions: list[list[float]] = []  # the navigator's [vehicle t, x, y, z]
        self.offset = 0.0  # the vehicle's clock minus mission time, as the last status says
        self.clock: float | None = None  # the vehicle's clock, as its telemetry last said
        self.running: list[dict[str, Any]] = []  # the last status's running tasks
        self.refused = ""  # why the vehicle refused this observer's session ("": it did not)
        self.track_from = "the navigator's estimate"  # what the track's points are

    def on_status(self, payload: bytes) -> None:
        """A status as the player published it over Zenoh (ill-formed ones are dropped)."""
        try:
            status = json.loads(payload)
        except ValueError:
            return
        self.take_status(status)

    def take_status(self, status: Any) -> None:
        """A status as the player's observer made it (petri/execution/status.py, with its
        ``blocks``): over Zenoh, or in the player's own process (``mcl run --view``,
        app/view/run_view.py); ill-formed ones are dropped."""
        if not isinstance(status, dict) or status.get("v") != 1 or \
                not isinstance(status.get("blocks", {}), dict):
            return
        with self.lock:
            if status.get("mission") != self.base["mission"]:
                self.other = str(status.get("mission"))[:80]
                return
            if status.get("run") != self.run:  # a new run: start afresh
                self.run, self.states, self.changes, self.timeline = status.get("run"), {}, [], []
                self.positions = []
            elif float(status.get("t", 0)) < self.t:
                return
            self.take(status)

    def take(self, status: dict[str, Any]) -> None:
        self.t = float(status.get("t", 0))
        self.offset = float(status.get("clock", self.t)) - self.t
        self.status = str(status.get("status"))
        self.running = [r for r in status.get("running") or [] if isinstance(r, dict)]
        for block, state in (status.get("blocks") or {}).items():
            if self.states.get(block) != state:
                self.states[block] = state
                self.changes.append([self.t, str(block), str(state)])
        ev, ac = status.get("last_event"), status.get("last_action")
        entries = []
        if isinstance(ev, dict):
            line = ev.get("line")  # that of the firing the event caused (once it fired)
            entries.append({"t": ev.get("t"), "kind": "event", "text": str(ev.get("event")),
                            "line": line if isinstance(line, int) else None})
        if isinstance(ac, dict):
            entries.append({"t": ac.get("t"), "kind": "action", "line": line_of(
                str(ac.get("task", ""))), "text": f"{ac.get('action')} {ac.get('behaviour')}"})
        for entry in entries:
            same = [e for e in self.timeline
                    if (e["t"], e["kind"], e["text"]) == (entry["t"], entry["kind"], entry["text"])]
            if not same:
                self.timeline.append(entry)
            elif entry["line"] is not None:
                same[0]["line"] = entry["line"]
        self.timeline.sort(key=lambda e: float(e["t"] or 0))

    def on_navigator(self, payload: bytes) -> None:
        """The navigator's estimate (telemetry): one point of the track."""
        try:
            nav = json.loads(payload)
            point = [float(nav[k]) for k in ("t", "x", "y", "z")]
        except (ValueError, TypeError, KeyError):
            return
        self.take_position(point)

    def take_position(self, point: list[float]) -> None:
        """One point of the track, ``[t, x, y, z]`` on the vehicle's clock (non-finite ones
        are dropped)."""
        if not all(math.isfinite(v) for v in point):
            return
        with self.lock:
            self.positions.append(point)
            if len(self.positions) > 2 * MAX_TRACK:  # a long run: keep every other point
                self.positions = self.positions[::2]

    def on_clock(self, payload: bytes) -> None:
        """The vehicle's clock (telemetry)."""
        try:
            t = float(json.loads(payload)["t"])
        except (ValueError, TypeError, KeyError):
            return
        self.take_clock(t)

    def take_clock(self, t: float) -> None:
        """The vehicle's clock now (a non-finite one is dropped)."""
        if math.isfinite(t):
            with self.lock:
                self.clock = t

    def now(self) -> float:
        """Mission time now: the last status's, moved on by the vehicle's clock since while
        the mission runs."""
        if self.status != "running" or self.clock is None:
            return self.t
        return self.t + max(0.0, self.clock - (self.t + self.offset))

    def on_alive(self, key: str, present: bool) -> None:
        if key.endswith("/alive/vehicle"):
            self.seen_alive(present)

    def seen_alive(self, present: bool) -> None:
        """Whether the vehicle is there (its liveliness token, or its link)."""
        with self.lock:
            self.vehicle_alive = present

    def data(self) -> dict[str, Any]:
        """The page's data now."""
        with self.lock:
            vehicle = {None: "not seen", True: "alive", False: "LOST"}[self.vehicle_alive]
            link = f"vehicle {self.vehicle} @ {self.endpoint}: {vehicle}"
            if self.run is None:
                link += "; no run of this mission yet" + (
                    f" (a run of {self.other} set aside)" if self.other else "")
            ended = self.status if self.status in ("ok", "fail") else None
            if ended is None and self.vehicle_alive is False and self.run is not None:
                ended = "lost"
            track = [[t - self.offset, x, y, z] for t, x, y, z in self.positions
                     if t - self.offset >= 0.0] if self.run is not None else []
            now = self.now()
            progress = {str(r.get("task")): task_detail(r, now) for r in self.running
                        if "bound" in r or "progress" in r} if ended is None else {}
            return {**self.base, "changes": list(self.changes), "progress": progress,
                    "timeline": list(self.timeline), "end": {"t": now, "status": ended},
                    "live": True, "link": link, "track": track,
                    "track_from": self.track_from if track else ""}


def follow(live: LiveRun, endpoint: str, security: Any, stop: threading.Event,
           ready: threading.Event) -> None:
    """Feed ``live`` from the vehicle at ``endpoint`` until ``stop`` (a client session,
    reopened while the vehicle is not there yet); ``ready`` once subscribed."""
    import zenoh  # lazy: for start-up speed (a log's view needs no Zenoh)

    from aal.zenoh import close_session, keys, payload_text

    k = keys(live.vehicle)
    try:
        session = observer_session(endpoint, security, stop)
    except SessionRefused as exc:
        live.refused = f"mcl view: error: {exc}"
        return
    if session is None:
        return
    try:
        session.declare_subscriber(k["status"], lambda s: live.on_status(payload_text(s)))
        session.declare_subscriber(k["telemetry"] + "/navigator",
                                   lambda s: live.on_navigator(payload_text(s)))
        session.declare_subscriber(k["clock"], lambda s: live.on_clock(payload_text(s)))
        session.liveliness().declare_subscriber(
            k["alive"] + "/**", lambda s: live.on_alive(
                str(s.key_expr), s.kind == zenoh.SampleKind.PUT), history=True)
        for reply in session.get(k["status"], timeout=1.0):  # a mission already running
            if reply.ok is not None:
                live.on_status(payload_text(reply.ok))
        ready.set()
        while not stop.wait(0.5):
            pass
    finally:
        close_session(session)
