"""The Zenoh adapter (AAL.md): the player on one side of a Zenoh link, the vehicle on the other.

Key layout (``<v>`` is the vehicle's name)::

    mcl/<v>/aal/action            player -> vehicle, ActionMessage JSON, blocking congestion control
    mcl/<v>/aal/event             vehicle -> player, EventMessage JSON, blocking congestion control
    mcl/<v>/telemetry/clock       vehicle -> all, {"t": sim seconds, "speed": x wall, "running": bool}
    mcl/<v>/telemetry/<stream>    vehicle -> all, navigator, wall, behaviours (JSON, droppable)
    mcl/<v>/mission/status        player -> all, the mission's status (petri/status.py), and a
                                  queryable answering with the latest one (late monitors)
    mcl/<v>/capabilities          vehicle queryable: what it can do, {"vehicle", "source", "text"}
                                  with ``text`` the task library's behaviour statements
    mcl/<v>/alive/vehicle         liveliness token of the vehicle
    mcl/<v>/alive/player/<run>    liveliness token of the player; <run> is its session id,
                                  also carried in every action's "run" field

Restarts: a vehicle takes actions only from the run whose token it saw last (an action of
another run, or a ``seq`` at or below the last one taken, is stale: counted and dropped), and
switches every behaviour off when a new run appears, so nothing of a previous mission is left
enabled. A player whose vehicle went away (``Link.lost``) sends nothing more on that link: the
vehicle that comes back in its place starts with every behaviour off and is sent nothing old.

Both sides run in peer mode with explicit endpoints (the vehicle listens, the player connects)
and multicast scouting off; the configuration is built in one place, :func:`zenoh_config`.
The transport lease is short (1 s by default) so that a vehicle that disappears without
closing its session (a partition) is noticed within about a second; a vehicle process that
dies closes its TCP socket and is noticed at once.

The player-side adapter, :class:`ZenohVehicle`, follows the vehicle's clock: ``now()`` is the
last vehicle time received, advanced by wall time x speed since (bounded, so a stalled vehicle
does not run the player's clock far ahead). When the vehicle's liveliness token goes away,
or never appears within ``connect_timeout`` wall seconds, it delivers one synthetic
``Link.lost`` event; from then on its clock runs on wall time x speed so that the player's
timers and time limits still end the run.
"""

from __future__ import annotations

import dataclasses
import ipaddress
import json
import logging
import os
import re
import threading
import time
from typing import Any

import zenoh

from .aal import ActionMessage, Declaration, EventMessage, InvalidMessage
from .link import MAX_POLL, RemoteVehicle
from .zenoh_security import Security
from .zenoh_security import apply as apply_security

log = logging.getLogger(__name__)

DEFAULT_ENDPOINT = "tcp/127.0.0.1:7447"
LEASE_MS = 1000  # transport lease: a silent peer is declared gone after this long
try:  # $MCL_ZENOH_LEASE_MS: a longer lease for a slow or busy link (the tests on a loaded machine)
    LEASE_MS = max(LEASE_MS, int(os.environ.get("MCL_ZENOH_LEASE_MS", LEASE_MS)))
except ValueError:
    pass
MAX_EXTRAPOLATION = 0.25  # wall s: how far the player's clock runs past the last clock message
CLOSE_TIMEOUT = 1.0  # wall s: the longest wait for a session to close
CLIENT_CONNECT_MS = 2000  # a client (mcl monitor) gives up opening after this long


PROTOCOLS = ("tcp", "udp", "tls", "quic", "ws", "unixsock-stream")  # Zenoh's link protocols
_HOST = re.compile(r"[A-Za-z0-9]([A-Za-z0-9-]{0,62}[A-Za-z0-9])?(\.[A-Za-z0-9]([A-Za-z0-9-]{0,62}"
                   r"[A-Za-z0-9])?)*")


def check_endpoint(endpoint: str) -> str:
    """A Zenoh endpoint, ``PROTOCOL/HOST:PORT`` (``unixsock-stream/PATH``), checked before
    Zenoh sees it: ValueError saying what is wrong. Zenoh's own metadata (``?...``) and
    configuration (``#...``) suffixes are passed on unchecked."""
    protocol, slash, rest = endpoint.partition("/")
    address = re.split(r"[?#]", rest, maxsplit=1)[0]
    if not slash or not protocol or not address:
        raise ValueError(f"not an endpoint: write PROTOCOL/HOST:PORT, e.g. {DEFAULT_ENDPOINT}")
    if protocol not in PROTOCOLS:
        raise ValueError(f"unknown protocol {protocol!r}: use one of {', '.join(PROTOCOLS)}")
    if protocol == "unixsock-stream":
        return endpoint
    host, colon, port = address.rpartition(":")
    if not colon:
        raise ValueError(f"{address!r} has no port: write HOST:PORT, e.g. 127.0.0.1:7447")
    if not host:
        raise ValueError(f"{address!r} has no host: write HOST:PORT, e.g. 127.0.0.1:7447")
    if not port.isdigit() or not 1 <= int(port) <= 65535:
        raise ValueError(f"port {port!r}: a number from 1 to 65535 (0, any free port, "
                         "cannot be told to the other side)")
    bare = host[1:-1] if host.startswith("[") and host.endswith("]") else host
    try:
        ipaddress.ip_address(bare)
        if ":" in bare and bare == host:
            raise ValueError(f"host {host!r}: write an IPv6 address in brackets, [{host}]")
    except ValueError as exc:
        if "brackets" in str(exc):
            raise
        if bare != host or not _HOST.fullmatch(host) or len(host) > 253:
            raise ValueError(f"host {host!r}: an IP address ([::1] for IPv6) or a host "
                             "name") from None
    return endpoint


def check_name(name: str) -> str:
    """A vehicle's name, one chunk of a Zenoh key (``mcl/<name>/...``)."""
    if not re.fullmatch(r"[A-Za-z0-9_.-]{1,64}", name):
        raise ValueError("a vehicle's name is 1 to 64 letters, digits, '_', '.' or '-'")
    return name


def option_error(endpoint: str, name: str) -> str | None:
    """``--zenoh`` and ``--name`` as a command takes them: one line naming the bad option
    (exit 2 for the command), else None."""
    try:
        check_endpoint(endpoint)
    except ValueError as exc:
        return f"--zenoh {endpoint}: error: {exc}"
    try:
        check_name(name)
    except ValueError as exc:
        return f"--name {name}: error: {exc}"
    return None


def zenoh_error(exc: BaseException) -> str:
    """Zenoh's message without the source paths of the machine that built it."""
    text = re.sub(r" at /\S+?\.rs:\d+\.?", "", str(exc))
    return text.replace("Json5Err(Message { msg: ", "").strip()


def keys(vehicle: str) -> dict[str, str]:
    """The key expressions of one vehicle (AAL.md's suggested layout)."""
    base = f"mcl/{vehicle}"
    return {"action": f"{base}/aal/action", "event": f"{base}/aal/event",
            "clock": f"{base}/telemetry/clock", "telemetry": f"{base}/telemetry",
            "status": f"{base}/mission/status", "alive_vehicle": f"{base}/alive/vehicle",
            "capabilities": f"{base}/capabilities",
            "alive_player": f"{base}/alive/player", "alive": f"{base}/alive"}


def zenoh_config(endpoint: str = DEFAULT_ENDPOINT, mode: str = "peer", *,
                 listen: bool = False, connect: bool = False,
                 lease_ms: int = LEASE_MS, security: Security | None = None,
                 role: str = "player", scouting: bool = False) -> zenoh.Config:
    """The one place a Zenoh configuration is built.

    ``listen``: accept connections on ``endpoint`` (the vehicle); ``connect``: connect to it
    (the player, tools). Observers (``mcl monitor``) connect in ``client`` mode: the vehicle,
    a peer, forwards to its clients what other peers (the player) publish, which peers do not
    do for one another. Neither: no endpoint (a session that only talks to itself). Multicast
    scouting is off unless ``scouting`` (``--scouting``: on a LAN, also find the vehicle by
    Zenoh's multicast scouting, UDP 224.0.0.224:7446), gossip always: otherwise peers meet only
    through the explicit endpoints. A peer that does not listen has no listening socket at all
    (Zenoh's default would be ``tcp/[::]:0``).
    """
    if listen == connect and listen:
        raise ValueError("listen or connect, not both")
    config = zenoh.Config()
    config.insert_json5("mode", json.dumps(mode))
    config.insert_json5("listen/endpoints", json.dumps([endpoint] if listen else []))
    config.insert_json5("connect/endpoints", json.dumps([endpoint] if connect else []))
    if connect and mode == "client":  # a client's open waits for its connection: bound it
        config.insert_json5("connect/exit_on_failure", "true")
        config.insert_json5("connect/timeout_ms", str(CLIENT_CONNECT_MS))
    elif connect:  # keep retrying in the background: the liveliness watch reports absence
        config.insert_json5("connect/exit_on_failure", "false")
        config.insert_json5("connect/timeout_ms", "-1")
    config.insert_json5("scouting/multicast/enabled", json.dumps(scouting))
    config.insert_json5("scouting/gossip/enabled", "false")
    config.insert_json5("transport/link/tx/lease", str(int(lease_ms)))
    config.insert_json5("transport/link/tx/keep_alive", "4")
    if security:
        apply_security(config, security, role)
    return config


def close_session(session: zenoh.Session, timeout: float = CLOSE_TIMEOUT) -> None:
    """Close a session, waiting at most ``timeout`` wall seconds: a frozen peer never answers
    the close, and Zenoh would wait 10 s for it."""
    def close() -> None:
        try:
            session.close()  # type: ignore[no-untyped-call]
        except zenoh.ZError as exc:
            log.warning("Zenoh session closed uncleanly: %s", exc)

    closer = threading.Thread(target=close, name="zenoh-close", daemon=True)
    closer.start()
    closer.join(timeout)
    if closer.is_alive():
        log.warning("Zenoh session not closed within %g s: leaving it", timeout)


def payload_text(sample: zenoh.Sample) -> bytes:
    return sample.payload.to_bytes()


class ZenohVehicle(RemoteVehicle):
    """The player's adapter to a vehicle stack reached over Zenoh (the Vehicle protocol).

    ``with ZenohVehicle("tcp/127.0.0.1:7447", "auv") as vehicle: run(player, vehicle, ...)``.
    Entering opens the session, declares the player's liveliness token, the action publisher,
    the event, clock and behaviour-telemetry subscribers and the vehicle's liveliness watch,
    and waits (at most ``connect_timeout`` wall seconds) for the vehicle's token, its clock and
    its word that it takes this run's actions (its telemetry names this run: a vehicle whose
    access control refuses us never does). It does not raise if the vehicle is absent or
    refuses us: the run then gets ``Link.lost`` saying why.
    """

    def __init__(self, endpoint: str = DEFAULT_ENDPOINT, vehicle: str = "auv", *,
                 connect_timeout: float = 5.0, lease_ms: int = LEASE_MS,
                 max_poll: float = MAX_POLL, config: zenoh.Config | None = None,
                 security: Security | None = None, scouting: bool = False):
        super().__init__(max_poll=max_poll, max_extrapolation=MAX_EXTRAPOLATION)
        self.endpoint = endpoint
        self.name = vehicle
        self.keys = keys(vehicle)
        self.connect_timeout = connect_timeout
        self._config = config or zenoh_config(endpoint, connect=True, lease_ms=lease_ms,
                                              security=security, role="player",
                                              scouting=scouting)
        self._alive = threading.Event()  # the vehicle's token is present
        self._clocked = threading.Event()  # a clock message has arrived
        self._taken = threading.Event()  # the vehicle's telemetry names this run
        self.dropped = 0  # invalid events received and dropped
        self.received = 0  # valid events received
        self.sent = 0
        self.session: zenoh.Session | None = None
        self.run = ""  # this run's id: the session's Zenoh id
        self._declared: list[Any] = []
        self._status: bytes | None = None  # the latest mission status (JSON)
        self._declaration: Declaration | None = None
        self._asked = False
        self._active: list[str] | None = None  # the vehicle's behaviours on, per telemetry
        self._active_t = -1.0  # the vehicle time of that telemetry
        self._sent_t = 0.0  # vehicle time when the last action was sent

    # -- context manager ----------------------------------------------------------------------
    def __enter__(self) -> ZenohVehicle:
        self.session = zenoh.open(self._config)
        s = self.session
        self.run = str(s.zid())
        try:
            k = self.keys
            self._status_publisher = s.declare_publisher(
                k["status"], congestion_control=zenoh.CongestionControl.BLOCK)
            self._publisher = s.declare_publisher(
                k["action"], congestion_control=zenoh.CongestionControl.BLOCK,
                priority=zenoh.Priority.INTERACTIVE_HIGH, express=True)
            self._declared += [
                self._publisher, self._status_publisher,
                s.declare_queryable(k["status"], self._on_status_query),
                s.declare_subscriber(k["event"], self._on_event),
                s.declare_subscriber(k["clock"], self._on_clock),
                s.declare_subscriber(f"{k['telemetry']}/behaviours", self._on_behaviours),
                s.liveliness().declare_subscriber(k["alive_vehicle"], self._on_liveliness,
                                                  history=True),
                s.liveliness().declare_token(f"{k['alive_player']}/{self.run}"),
            ]
            self._wait_for_vehicle()
        except BaseException:
            self.__exit__()
            raise
        return self

    def _wait_for_vehicle(self) -> None:
        """Bounded by ``connect_timeout``: the vehicle's token, its clock, its taking this run
        (else ``Link.lost``), and the action publisher matched so that no action is lost."""
        k, deadline = self.keys, time.monotonic() + self.connect_timeout
        if not self._alive.wait(self.connect_timeout):
            self._link_lost(f"no vehicle token on {k['alive_vehicle']} within "
                            f"{self.connect_timeout:g} s (endpoint {self.endpoint})")
            return
        self._clocked.wait(max(0.0, deadline - time.monotonic()))
        if not self._taken.wait(max(0.0, deadline - time.monotonic())):
            self._link_lost(f"the vehicle does not take this run's actions within "
                            f"{self.connect_timeout:g} s: are we its player? (with access "
                            "control: --user / --tls-cert must be the vehicle's --player-user "
                            "/ --player-cn)")
            return
        while not self._publisher.matching_status and time.monotonic() < deadline:
            time.sleep(0.002)

    def __exit__(self, *exc: object) -> None:
        for entity in reversed(self._declared):
            try:
                entity.undeclare()
            except Exception:  # already gone with the session
                pass
        self._declared.clear()
        if self.session is not None:
            close_session(self.session)
            self.session = None

    # -- Zenoh callbacks (Zenoh's threads) --------------------------------------------------------
    def _on_event(self, sample: zenoh.Sample) -> None:
        try:
            event = EventMessage.from_json(payload_text(sample))
        except InvalidMessage as exc:
            with self._lock:
                self.dropped += 1
            log.warning("player dropped an invalid event on %s: %s", sample.key_expr, exc)
            return
        with self._lock:
            self.received += 1
            if event.t > self._vehicle_time_locked():  # the event is news of the clock too
                self._clock_locked(event.t, running=self._running)
        self.deliver(event)

    def _on_clock(self, sample: zenoh.Sample) -> None:
        try:
            d = json.loads(payload_text(sample))
            t, speed, running = float(d["t"]), float(d["speed"]), bool(d["running"])
            if not (t >= 0 and speed > 0):
                raise ValueError("bad clock")
        except (ValueError, KeyError, TypeError) as exc:
            log.warning("player ignored an invalid clock message: %s", exc)
            return
        with self._lock:
            if not self._lost:
                self._clock_locked(t, speed, running)
        self._clocked.set()

    def _on_behaviours(self, sample: zenoh.Sample) -> None:
        """The vehicle says whose actions it takes: this run's (taken), or, once taken,
        another's — a second player took the vehicle, whose events are not ours any more."""
        try:
            d = json.loads(payload_text(sample))
            run = d.get("run")
        except (ValueError, AttributeError):
            return
        if run == self.run and isinstance(d.get("active"), list):
            with self._lock:
                self._active = [str(b) for b in d["active"]]
                self._active_t = float(d.get("t", 0.0))
        if run == self.run:
            self._taken.set()
        elif self._taken.is_set() and run:
            self._link_lost(f"another player (run {run}) took the vehicle")

    def _on_status_query(self, query: zenoh.Query) -> None:
        status = self._status
        if status is not None:
            query.reply(self.keys["status"], status)

    def publish_status(self, status: dict[str, Any]) -> None:
        """Publish the mission's status (and keep it for the queryable); never raises."""
        self._status = json.dumps(status, separators=(",", ":")).encode()
        if self.session is None:
            return
        try:
            self._status_publisher.put(self._status)
        except zenoh.ZError as exc:  # a status lost is not worth ending a mission for
            log.warning("mission status not published: %s", exc)

    def _on_liveliness(self, sample: zenoh.Sample) -> None:
        if sample.kind == zenoh.SampleKind.PUT:
            self._alive.set()
        else:
            self._alive.clear()
            self._link_lost(f"the vehicle's token {sample.key_expr} went away")

    # -- the Vehicle protocol ---------------------------------------------------------------------
    def send(self, action: ActionMessage) -> None:
        if self.session is None:
            raise RuntimeError("ZenohVehicle used outside its 'with' block")
        if self._lost:
            log.warning("link lost: action %s %s not sent", action.kind, action.behaviour)
            return
        self._publisher.put(dataclasses.replace(action, run=self.run).to_json())
        self.sent += 1
        with self._lock:
            self._sent_t = self._vehicle_time_locked()

    def declaration(self) -> Declaration | None:
        """What the vehicle says it can do (asked once, at most ``connect_timeout`` s; None
        before connecting, after ``Link.lost``, or if it does not say)."""
        if self.session is None or self._lost:
            return None
        if not self._asked:
            self._asked = True
            try:
                for reply in self.session.get(self.keys["capabilities"],
                                              timeout=self.connect_timeout):
                    if reply.ok is None:
                        continue
                    d = json.loads(reply.ok.payload.to_bytes())
                    self._declaration = Declaration(
                        str(d["vehicle"]), f"{d['source']} (said by {self.keys['capabilities']})",
                        str(d["text"]))
                    break
            except (zenoh.ZError, ValueError, KeyError, TypeError) as exc:
                log.warning("the vehicle's capabilities could not be read: %s", exc)
        return self._declaration

    def confirm_off(self, names: list[str], timeout: float) -> str:
        """Wait (at most ``timeout`` wall s) for the vehicle's telemetry, sent after the last
        action, to show no behaviour on."""
        if self._lost:
            return f"not confirmed: the link is lost ({self.lost_reason})"
        end = time.monotonic() + timeout
        while True:
            with self._lock:
                active, fresh = self._active, self._active_t >= self._sent_t
            if fresh and active == []:
                return "confirmed by the vehicle's telemetry: no behaviour on"
            if time.monotonic() >= end:
                break
            time.sleep(0.02)
        if not fresh or active is None:
            return f"NOT confirmed: no telemetry from the vehicle within {timeout:g} s"
        return f"NOT confirmed: the vehicle still reports {', '.join(active)} on"
