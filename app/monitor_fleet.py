"""``mcl monitor --fleet-vehicle NAME=ENDPOINT ...``: what the monitor knows of a fleet, every
vehicle at once and the messages on the fleet's channels (docs/FLEET_ZENOH.md); the sessions
are opened by app/monitor.py.

    mcl monitor --fleet-vehicle asv=tcp/ASV:7447 --fleet-vehicle uuv=tcp/UUV:7448 [--until-end]

One observer session (a client) per endpoint; each vehicle's status, telemetry and liveliness
as ``mcl monitor`` shows one (:class:`app.monitor.View`), one block (or, ``--plain``, one line)
each, under its name; then each channel's messages as its sender's vehicle routes them
(``mcl/fleet/<fleet>/channel/<channel>``): how many were sent and the last one. With
``--until-end`` it exits once every vehicle has ended or is lost: OK when every one ended OK,
FAILED otherwise (a lost vehicle's end cannot be known from here).
"""

from __future__ import annotations

import argparse
import json
import signal
import sys
import threading
from collections.abc import Callable, Mapping
from typing import Any, Protocol, TextIO

from aal.zenoh_observer import SessionRefused, observer_session
from mission.exits import Exit

from app import zenoh_options

CHANNELS = "mcl/fleet/*/channel/*"  # every channel of every fleet, as a vehicle routes them


class Watched(Protocol):
    """What the monitor's drawing loop reads (app/monitor.py's ``watch``): one vehicle's view
    (app/monitor.py's View), or a fleet's (:class:`FleetView`, made of vehicles' views)."""

    changed: threading.Event

    @property
    def vehicle_alive(self) -> bool | None: ...
    def ended(self) -> str | None: ...
    def line(self) -> str: ...
    def screen(self, width: int = 80) -> list[str]: ...


def fleet_vehicles(given: list[str]) -> dict[str, str] | str:
    """``--fleet-vehicle NAME=ENDPOINT`` options, checked: name -> endpoint, or one line
    naming the bad option."""
    from aal.zenoh import fleet_vehicle  # start-up speed: it imports zenoh

    found: dict[str, str] = {}
    for text in given:
        try:
            name, endpoint = fleet_vehicle(text)
        except ValueError as exc:
            return f"--fleet-vehicle {text[:80]}: error: {exc}"
        if name in found:
            return f"--fleet-vehicle {name}=...: error: {name} is given twice"
        found[name] = endpoint
    return found


class FleetView:
    """What the monitor knows of a fleet: a :class:`View` per vehicle (sharing one
    ``changed``) and each channel's messages; read by :func:`app.monitor.watch`."""

    def __init__(self, views: Mapping[str, Watched]) -> None:
        self.changed = threading.Event()
        self.views = dict(views)
        for view in self.views.values():
            view.changed = self.changed
        self.lock = threading.Lock()
        self.channels: dict[str, dict[str, Any]] = {}  # channel -> {sent, last, seen}

    @property
    def vehicle_alive(self) -> bool | None:
        """Never False: a lost vehicle does not end the watch of the others (see ended)."""
        return None

    def on_channel(self, key: str, payload: bytes) -> None:
        try:
            d = json.loads(payload)
            seen = (str(d["sender"]), int(d["seq"]))
            said = f"{d['message']} from {d['sender']} at {float(d['sent']):.1f} s"
        except (ValueError, KeyError, TypeError):
            return
        channel = key.rpartition("/")[2]
        with self.lock:
            c = self.channels.setdefault(channel, {"sent": 0, "last": "", "seen": set()})
            if seen in c["seen"]:  # heard through two vehicles
                return
            c["seen"].add(seen)
            c["sent"] += 1
            c["last"] = said
        self.changed.set()

    def channel_lines(self) -> list[str]:
        with self.lock:
            return [f"channel {name}: {c['sent']} sent, last {c['last']}"
                    for name, c in sorted(self.channels.items())]

    def ended(self) -> str | None:
        """None while a vehicle neither ended nor is lost; then "ok" if every one ended OK,
        else "fail"."""
        ends = []
        for view in self.views.values():
            end = view.ended()
            if end is None and view.vehicle_alive is not False:
                return None
            ends.append(end)
        return "ok" if all(e == "ok" for e in ends) else "fail"

    def line(self) -> str:
        width = max(len(n) for n in self.views)
        return "\n".join([f"{name:<{width}} {view.line()}" for name, view in self.views.items()]
                         + self.channel_lines())

    def screen(self, width: int = 80) -> list[str]:
        lines: list[str] = []
        for view in self.views.values():
            lines += [*view.screen(width), ""]
        return lines + [line[:width] for line in self.channel_lines()]


class Follows(Protocol):
    """A view fed by :func:`follow` (app/monitor.py's View)."""

    vehicle: str

    def on_status(self, payload: bytes) -> None: ...
    def on_telemetry(self, stream: str, payload: bytes) -> None: ...
    def on_alive(self, key: str, present: bool) -> None: ...


class Watches(Protocol):
    """app/monitor.py's drawing loop."""

    def __call__(self, view: Any, until_end: bool, timeout: float | None, plain: bool,
                 out: TextIO, stop: threading.Event) -> int: ...


def open_session(endpoint: str, security: Any, scouting: bool, timeout: float | None,
                 stop: threading.Event) -> Any:
    """The observer's session to the vehicle at ``endpoint`` (aal/zenoh_observer.py), saying
    once that it waits for a vehicle not there yet; None if none came within ``timeout`` or
    ``stop`` came first (said unless ``stop``). :class:`SessionRefused` when the vehicle is
    there but refuses this observer's credentials."""
    session = observer_session(endpoint, security, stop, timeout=timeout, scouting=scouting,
                               waiting=lambda why: print(
                                   f"mcl monitor: waiting for the vehicle at {endpoint} "
                                   f"({why})", file=sys.stderr, flush=True))
    if session is None and not stop.is_set():
        print(f"mcl monitor: no vehicle at {endpoint} within {timeout:g} s", file=sys.stderr)
    return session


def refused(exc: SessionRefused) -> int:
    """Say on one line that the vehicle refused this observer's session: exit 2."""
    print(f"mcl monitor: error: {exc}", file=sys.stderr)
    return Exit.INVALID


def follow(session: Any, view: Follows) -> list[Any]:
    """Subscribe ``view`` to its vehicle's status, telemetry and liveliness on ``session``,
    and ask for the status of a mission already running; the subscribers (undeclare them)."""
    import zenoh  # start-up speed: only once watching

    from aal.zenoh import keys, payload_text

    k = keys(view.vehicle)
    prefix = k["telemetry"] + "/"
    entities = [
        session.declare_subscriber(k["status"], lambda s: view.on_status(payload_text(s))),
        session.declare_subscriber(prefix + "*", lambda s: view.on_telemetry(
            str(s.key_expr)[len(prefix):], payload_text(s))),
        session.liveliness().declare_subscriber(
            k["alive"] + "/**", lambda s: view.on_alive(
                str(s.key_expr), s.kind == zenoh.SampleKind.PUT), history=True),
    ]
    for reply in session.get(k["status"], timeout=1.0):  # a mission already running
        if reply.ok is not None:
            view.on_status(payload_text(reply.ok))
    return entities


def monitor_fleet(args: argparse.Namespace, make_view: Callable[[str, str], Any],
                  watch: Watches) -> int:
    """Watch every vehicle ``--fleet-vehicle`` names (one observer session per endpoint; its
    options checked by app/monitor.py) and the fleet's channels, until the end, the timeout
    or a signal; ``make_view(name, endpoint)`` makes one vehicle's view, ``watch`` is the
    drawing loop."""
    from aal.zenoh import close_session, payload_text  # start-up speed: it imports zenoh

    vehicles = fleet_vehicles(args.fleet_vehicle)
    if isinstance(vehicles, str):
        print(vehicles, file=sys.stderr)
        return Exit.INVALID
    views = {name: make_view(name, endpoint) for name, endpoint in vehicles.items()}
    view = FleetView(views)
    stop = threading.Event()
    for sig in (signal.SIGTERM, signal.SIGINT):
        signal.signal(sig, lambda *_: stop.set())
    sessions: dict[str, Any] = {}
    entities: list[Any] = []
    try:
        for endpoint in dict.fromkeys(vehicles.values()):
            own = zenoh_options.from_args(
                argparse.Namespace(**{**vars(args), "zenoh": endpoint}), "observer")
            session = open_session(endpoint, own, args.scouting, args.timeout, stop)
            if session is None:
                return Exit.UNDECIDED if not stop.is_set() else Exit.OK
            sessions[endpoint] = session
            entities.append(session.declare_subscriber(CHANNELS, lambda s: view.on_channel(
                str(s.key_expr), payload_text(s))))
        for name, endpoint in vehicles.items():
            entities += follow(sessions[endpoint], views[name])
        code = watch(view, args.until_end, args.timeout, args.plain or not sys.stdout.isatty(),
                     sys.stdout, stop)
        for e in entities:
            e.undeclare()
        return code
    except SessionRefused as exc:
        return refused(exc)
    finally:
        for session in sessions.values():
            close_session(session)
