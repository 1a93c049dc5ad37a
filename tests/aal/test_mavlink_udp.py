"""aal/mavlink_udp.py: a listening MAVLink endpoint sends only to the peer it accepted.

Real pymavlink endpoints on UDP loopback, each on its own free port: the listener is the
player's side (``udpin``, peer system 1), the vehicle and an attacker are pymavlink ``udpout``
connections to it. pymavlink's own ``udpin`` copies everything it sends to every address a
datagram ever came from (issue 22: 156 datagrams of a signed session to an attacker whose one
unsigned datagram was rejected); these tests fail on it.
"""

from __future__ import annotations

import hashlib
import socket
import time
from collections.abc import Iterator
from typing import Any

import pytest

from aal import mavlink_udp, signing
from aal.mavlink_udp import PeerUdp, connect, mavutil

from tests.support import budget, free_udp_port

KEY = hashlib.sha256(b"issue 22").digest()
VEHICLE, GCS = 1, 255


def _listener(port: int, key: bytes | None = KEY) -> Any:
    conn = connect(f"udpin:127.0.0.1:{port}", source_system=GCS, source_component=190,
                   peer_system=VEHICLE)
    if key is not None:
        signing.enable(conn, key, require=True, link_id=1, timestamp_file=None)
    return conn


def _sender(port: int, system: int = VEHICLE, key: bytes | None = KEY) -> Any:
    conn = mavutil.mavlink_connection(f"udpout:127.0.0.1:{port}", source_system=system,
                                      source_component=1)
    if key is not None:
        signing.enable(conn, key, require=False, link_id=0, timestamp_file=None)
    return conn


def _address(conn: Any) -> tuple[str, int]:
    """Where a udpout connection's datagrams come from (it is bound to every interface)."""
    return ("127.0.0.1", conn.port.getsockname()[1])


def _heartbeat(conn: Any) -> None:
    conn.mav.heartbeat_send(12, 3, 0, 0, 0)


def _read(conn: Any, settle: float = 0.2) -> list[str]:
    """What the listener reads until nothing comes for ``settle`` s (bounded)."""
    got: list[str] = []
    end, quiet = time.monotonic() + budget(1), time.monotonic() + settle
    while time.monotonic() < min(end, quiet):
        msg = conn.recv_msg()
        if msg is None:
            time.sleep(0.005)
            continue
        got.append(msg.get_type())
        quiet = time.monotonic() + settle
    return got


def _received(conn: Any) -> int:
    """How many datagrams wait at a pymavlink udpout connection's socket (read them all)."""
    count = 0
    deadline = time.monotonic() + 0.3
    while time.monotonic() < deadline:
        try:
            conn.port.recvfrom(65535)
            count += 1
        except BlockingIOError:
            time.sleep(0.01)
    return count


@pytest.fixture
def ends() -> Iterator[tuple[Any, Any, Any]]:
    port = free_udp_port()
    listener = _listener(port)
    vehicle, attacker = _sender(port), _sender(port, key=None)
    try:
        yield listener, vehicle, attacker
    finally:
        for conn in (listener, vehicle, attacker):
            conn.close()


def test_listening_udp_urls_open_a_peer_endpoint_and_the_others_pymavlink_s() -> None:
    port = free_udp_port()
    for url in (f"udpin:127.0.0.1:{port}", f"udp:127.0.0.1:{port}"):
        conn = connect(url, source_system=GCS, source_component=190, peer_system=VEHICLE)
        try:
            assert isinstance(conn, PeerUdp) and conn.udp_server and conn.peer is None
        finally:
            conn.close()
    out = connect(f"udpout:127.0.0.1:{port}", source_system=GCS, source_component=190,
                  peer_system=VEHICLE)
    try:
        assert type(out) is mavutil.mavudp and not out.udp_server
    finally:
        out.close()
    assert mavlink_udp.LISTENING == ("udpin", "udp", "udpbcast")


def test_an_attacker_s_rejected_datagram_gets_none_of_the_link(
        ends: tuple[Any, Any, Any]) -> None:
    listener, vehicle, attacker = ends
    _heartbeat(attacker)  # unsigned, and signing is required: rejected
    assert _read(listener) == ["BAD_DATA"]
    assert listener.peer is None
    _heartbeat(listener)  # nobody accepted yet: sent nowhere
    assert _received(attacker) == 0
    _heartbeat(vehicle)
    assert _read(listener) == ["HEARTBEAT"]
    assert listener.peer == _address(vehicle)
    _heartbeat(attacker)
    assert _read(listener) == ["BAD_DATA"]
    for _ in range(20):
        _heartbeat(listener)
    assert (_received(vehicle), _received(attacker)) == (20, 0)


def test_the_peer_follows_the_vehicle_s_accepted_messages_to_a_new_address() -> None:
    port = free_udp_port()
    listener, first = _listener(port), _sender(port)
    second = _sender(port)  # the vehicle again, from another port (e.g. a restarted router)
    try:
        _heartbeat(first)
        _read(listener)
        _heartbeat(second)
        _read(listener)
        assert listener.peer == _address(second)
        _heartbeat(listener)
        assert (_received(first), _received(second)) == (0, 1)
    finally:
        for conn in (listener, first, second):
            conn.close()


def test_without_signing_only_the_vehicle_s_system_becomes_the_peer() -> None:
    port = free_udp_port()
    listener = _listener(port, key=None)
    other, vehicle = _sender(port, system=42, key=None), _sender(port, key=None)
    try:
        _heartbeat(other)  # accepted (no signing) but not from system 1
        assert _read(listener) == ["HEARTBEAT"] and listener.peer is None
        _heartbeat(vehicle)
        _read(listener)
        _heartbeat(listener)
        assert (_received(vehicle), _received(other)) == (1, 0)
    finally:
        for conn in (listener, other, vehicle):
            conn.close()


def test_a_message_is_credited_to_the_datagram_it_came_in(
        ends: tuple[Any, Any, Any]) -> None:
    """Two of the vehicle's messages in one datagram, then the attacker's: the second message
    is the vehicle's (pymavlink parses it after reading the next datagram, and would credit it
    to the attacker); a fragment a datagram leaves is dropped, not joined to the next one."""
    listener, vehicle, attacker = ends
    to_listener = ("127.0.0.1", listener.port.getsockname()[1])
    two = b"".join(bytes(vehicle.mav.heartbeat_encode(12, 3, 0, 0, 0).pack(vehicle.mav))
                   for _ in range(2))
    vehicle.port.sendto(two, to_listener)
    first, deadline = None, time.monotonic() + budget(1)
    while first is None and time.monotonic() < deadline:
        first = listener.recv_msg()
    assert first is not None and first.get_type() == "HEARTBEAT"
    assert listener.mav.buf_len() > 0  # the second message waits in the buffer
    attacker.port.sendto(two[:20], to_listener)  # a fragment of a message
    time.sleep(0.05)
    second = listener.recv_msg()
    assert second is not None and second.get_type() == "HEARTBEAT"
    assert listener.sender == _address(vehicle) == listener.peer
    _read(listener)
    assert listener.sender == _address(attacker)  # its datagram was read...
    assert listener.mav.buf_len() == 0  # ...and its fragment dropped
    assert listener.peer == _address(vehicle)
    _heartbeat(listener)
    assert (_received(vehicle), _received(attacker)) == (1, 0)


def test_a_real_socket_sees_nothing_before_an_accepted_message() -> None:
    port = free_udp_port()
    listener = _listener(port)
    spy = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    spy.bind(("127.0.0.1", 0))
    spy.setblocking(False)
    try:
        spy.sendto(b"\xfd\x00", ("127.0.0.1", port))  # junk: read, never accepted
        _read(listener)
        for _ in range(5):
            _heartbeat(listener)
        time.sleep(0.1)
        with pytest.raises(BlockingIOError):
            spy.recvfrom(65535)
    finally:
        spy.close()
        listener.close()
