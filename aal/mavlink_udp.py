"""The MAVLink connection both ends open, and the UDP endpoint that answers only its peer.

pymavlink's listening UDP endpoint (``udpin:``, ``udp:``) adds the sender of EVERY datagram it
reads to its ``clients`` and copies everything it sends to each of them: one datagram from
anyone, even one it then rejects (unsigned, badly signed), and that sender gets the whole link
(the vehicle's commands, signed, to capture and replay). ``udpbcast:`` is worse: the first
datagram read from anyone becomes the one destination for good (``last_address``).

:class:`PeerUdp` sends to one address only, its *peer*: the sender of the last datagram that
carried a message the connection accepted (its signature checked, when signing is on) from the
peer's system (the vehicle for the player, the ground station for the vehicle). Until such a
message it sends nothing. Without signing any sender that claims the peer's system is accepted
(there is nothing to check it by); with ``--require-signing`` only one that holds the key, and
not a replay (:mod:`aal.signing`).

A message is one datagram's bytes: MAVLink over UDP never splits a message across datagrams,
so the bytes a datagram leaves over are dropped before the next is read, and a message is
never credited to the sender of another datagram.
"""

from __future__ import annotations

import errno
import os
import time
from typing import Any

os.environ["MAVLINK20"] = "1"  # before pymavlink loads a dialect: MAVLink 2 only

from pymavlink import mavutil as mavutil  # noqa: E402  (re-exported: MAVLink 2 is set)

from aal.mavlink import parse_url  # noqa: E402

DIALECT = "ardupilotmega"
LISTENING = ("udpin", "udp", "udpbcast")  # the URLs a PeerUdp serves


class PeerUdp(mavutil.mavudp):  # type: ignore[misc]  # pymavlink has no type information
    """A UDP endpoint that listens (``udpin``) or finds its peer by broadcast (``udpbcast``)
    and sends only to the peer it has accepted (:attr:`peer`)."""

    def __init__(self, device: str, *, peer_system: int, broadcast: bool = False,
                 source_system: int, source_component: int) -> None:
        super().__init__(device, input=not broadcast, broadcast=broadcast,
                         source_system=source_system, source_component=source_component)
        self.peer_system = peer_system
        self.peer: tuple[str, int] | None = None  # where everything is sent; None: nowhere yet
        self.sender: tuple[str, int] | None = None  # who sent the datagram being parsed

    def recv(self, n: int | None = None) -> bytes:
        """One datagram's bytes (b"" if none is waiting); nobody is added as a client."""
        try:
            data, address = self.port.recvfrom(mavutil.UDP_MAX_PACKET_LEN)
        except OSError as exc:
            if exc.errno in (errno.EAGAIN, errno.EWOULDBLOCK, errno.ECONNREFUSED):
                return b""
            raise
        self.sender = address
        return bytes(data)

    def recv_msg(self) -> Any:
        """The next message: the rest of the last datagram, else one from the next datagram.
        A message accepted from the peer's system makes its sender the peer."""
        self.pre_message()
        msg = self.mav.parse_char(b"") if self.mav.buf_len() > 0 else None
        if msg is None:
            self.mav.buf, self.mav.buf_index = bytearray(), 0  # a fragment: not a message
            data = self.recv()
            if data and self.first_byte:
                self.auto_mavlink_version(data)
            msg = self.mav.parse_char(data)
        if msg is None:
            return None
        self.post_message(msg)
        if msg.get_type() != "BAD_DATA" and msg.get_srcSystem() == self.peer_system:
            self.accept(self.sender)
        return msg

    def accept(self, address: tuple[str, int] | None) -> None:
        """Send to ``address`` from now on (and to nobody else)."""
        if address is None or address == self.peer:
            return
        if self.peer is not None and self.peer in self.clients_last_alive:
            del self.clients_last_alive[self.peer]
        self.peer = address
        self.clients = {address}
        self.clients_last_alive[address] = time.time()
        if self.broadcast:
            self.last_address = address  # pymavlink's write() locks on to it

    def write(self, buf: bytes) -> None:
        """Send to the peer. Before there is one, a listening endpoint sends nothing and a
        broadcast one broadcasts (to find its peer, as pymavlink's)."""
        if self.peer is not None or not self.udp_server:
            super().write(buf)


def connect(url: str, *, source_system: int, source_component: int, peer_system: int,
            **options: Any) -> Any:
    """The pymavlink connection for ``url`` (as :func:`aal.mavlink.parse_url` reads it): a
    :class:`PeerUdp` answering only ``peer_system`` for a listening or broadcast UDP URL, else
    what ``mavutil.mavlink_connection`` opens (``options`` go to it)."""
    scheme, host, port = parse_url(url)
    if scheme not in LISTENING:
        return mavutil.mavlink_connection(url, source_system=source_system,
                                          source_component=source_component,
                                          dialect=DIALECT, **options)
    mavutil.set_dialect(DIALECT)
    return PeerUdp(f"{host}:{port}", peer_system=peer_system, broadcast=scheme == "udpbcast",
                   source_system=source_system, source_component=source_component)
