"""What both ends of a Zenoh link agree on (docs/AAL.md): the key layout, the one place a
configuration is built, endpoint and name checks, and closing a session in bounded time.

Key layout (``<v>`` is the vehicle's name)::

    mcl/<v>/aal/action            player -> vehicle, ActionMessage JSON, blocking congestion control
    mcl/<v>/aal/event             vehicle -> player, EventMessage JSON, blocking congestion control
    mcl/<v>/telemetry/clock       vehicle -> all, {"t": sim seconds, "speed": x wall, "running": bool}
    mcl/<v>/telemetry/<stream>    vehicle -> all, navigator, wall, behaviours (JSON, droppable)
    mcl/<v>/mission/status        player -> all, the mission's status (petri/execution/status.py), and a
                                  queryable answering with the latest one (late monitors)
    mcl/<v>/capabilities          vehicle queryable: what it can do, {"vehicle", "source", "text"}
                                  with ``text`` the task library's behaviour statements
    mcl/<v>/alive/vehicle         liveliness token of the vehicle
    mcl/<v>/alive/player/<run>    liveliness token of the player; <run> is its session id,
                                  also carried in every action's "run" field

Both sides run in peer mode with explicit endpoints (the vehicle listens, the player connects)
and multicast scouting off; the configuration is built in one place, :func:`zenoh_config`.
The transport lease is short (1 s by default) so that a vehicle that disappears without
closing its session (a partition) is noticed within about a second; a vehicle process that
dies closes its TCP socket and is noticed at once.
"""

from __future__ import annotations

import ipaddress
import json
import logging
import os
import re
import threading

import zenoh

from aal.zenoh_security import Security
from aal.zenoh_security import apply as apply_security

log = logging.getLogger(__name__)

DEFAULT_ENDPOINT = "tcp/127.0.0.1:7447"
MIN_LEASE_MS = 1000  # transport lease: a silent peer is declared gone after this long
MAX_LEASE_MS = 3_600_000  # the longest lease taken: an hour (Zenoh refuses 20 digits)


def lease_ms(text: str | None) -> int:
    """The lease ``$MCL_ZENOH_LEASE_MS`` asks for (a longer one for a slow or busy link, the
    tests on a loaded machine), within 1 s to an hour; the shortest if it is not an integer."""
    try:
        asked = int(text) if text else MIN_LEASE_MS
    except ValueError:  # not an integer, or past Python's 4,300 digits
        asked = MIN_LEASE_MS
    return min(max(asked, MIN_LEASE_MS), MAX_LEASE_MS)


LEASE_MS = lease_ms(os.environ.get("MCL_ZENOH_LEASE_MS"))
MAX_EXTRAPOLATION = 0.25  # wall s: how far the player's clock runs past the last clock message
CLOSE_TIMEOUT = 1.0  # wall s: the longest wait for a session to close
CLIENT_CONNECT_MS = 2000  # a client (mcl monitor) gives up opening after this long


PROTOCOLS = ("tcp", "udp", "tls", "quic", "ws", "unixsock-stream")  # Zenoh's link protocols
_HOST = re.compile(r"[A-Za-z0-9]([A-Za-z0-9-]{0,62}[A-Za-z0-9])?(\.[A-Za-z0-9]([A-Za-z0-9-]{0,62}"
                   r"[A-Za-z0-9])?)*")


def fleet_vehicle(text: str) -> tuple[str, str]:
    """``NAME=ENDPOINT`` (``--fleet-vehicle``): the vehicle's name and its endpoint, both
    checked; a ValueError saying what is wrong otherwise."""
    name, equals, endpoint = text.partition("=")
    if not equals:
        raise ValueError("write NAME=ENDPOINT, e.g. asv=tcp/127.0.0.1:7447")
    check_name(name)
    check_endpoint(endpoint)
    return name, endpoint


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
    """The key expressions of one vehicle (docs/AAL.md's suggested layout)."""
    base = f"mcl/{vehicle}"
    return {"action": f"{base}/aal/action", "event": f"{base}/aal/event",
            "clock": f"{base}/telemetry/clock", "telemetry": f"{base}/telemetry",
            "status": f"{base}/mission/status", "alive_vehicle": f"{base}/alive/vehicle",
            "capabilities": f"{base}/capabilities",
            "alive_player": f"{base}/alive/player", "alive": f"{base}/alive",
            "modem_payload": f"{base}/modem/payload", "modem_heard": f"{base}/modem/heard"}


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
