"""A minimal WebSocket client (RFC 6455) for tests: enough to speak to a server as a
Foxglove client does (a subprotocol, text and binary frames), or to headless Chromium's
DevTools (a page's path, no subprotocol), with no library of its own."""

from __future__ import annotations

import base64
import json
import os
import socket
import struct


class WebSocket:
    """A client connection: :meth:`send_text`, :meth:`receive` (opcode, payload)."""

    def __init__(self, host: str, port: int, protocol: str, timeout: float = 10.0,
                 path: str = "/"):
        self.sock = socket.create_connection((host, port), timeout=timeout)
        key = base64.b64encode(os.urandom(16)).decode()
        asked = f"Sec-WebSocket-Protocol: {protocol}\r\n" if protocol else ""
        self.sock.sendall((f"GET {path} HTTP/1.1\r\nHost: {host}:{port}\r\nUpgrade: websocket"
                           f"\r\nConnection: Upgrade\r\nSec-WebSocket-Key: {key}\r\n"
                           f"Sec-WebSocket-Version: 13\r\n{asked}\r\n").encode())
        response = b""
        while b"\r\n\r\n" not in response:
            chunk = self.sock.recv(4096)
            if not chunk:
                raise ConnectionError("closed during the handshake")
            response += chunk
        head, _, self.buffer = response.partition(b"\r\n\r\n")
        self.head = head.decode("latin-1")
        if " 101 " not in self.head.splitlines()[0]:
            raise ConnectionError(self.head)

    def fill(self, n: int) -> None:
        """Until the buffer holds ``n`` bytes; a timeout (``sock.settimeout``) leaves what
        came in the buffer, so a frame half read is whole at the next call."""
        while len(self.buffer) < n:
            chunk = self.sock.recv(65536)
            if not chunk:
                raise ConnectionError("closed")
            self.buffer += chunk

    def receive(self) -> tuple[int, bytes]:
        """The next whole message: (1 text or 2 binary, its payload); pings are answered.
        Nothing is taken from the buffer until the whole frame is in it."""
        while True:
            self.fill(2)
            opcode, length, head = self.buffer[0] & 0x0F, self.buffer[1] & 0x7F, 2
            if length == 126:
                self.fill(4)
                length, head = struct.unpack_from(">H", self.buffer, 2)[0], 4
            elif length == 127:
                self.fill(10)
                length, head = struct.unpack_from(">Q", self.buffer, 2)[0], 10
            self.fill(head + length)
            payload, self.buffer = self.buffer[head:head + length], self.buffer[head + length:]
            if opcode == 9:
                self.send(10, payload)
                continue
            if opcode == 8:
                raise ConnectionError("closed by the server")
            return opcode, payload

    def send(self, opcode: int, payload: bytes) -> None:
        mask = os.urandom(4)
        head = bytes([0x80 | opcode])
        n = len(payload)
        if n < 126:
            head += bytes([0x80 | n])
        elif n < 1 << 16:
            head += bytes([0x80 | 126]) + struct.pack(">H", n)
        else:
            head += bytes([0x80 | 127]) + struct.pack(">Q", n)
        masked = bytes(b ^ mask[i % 4] for i, b in enumerate(payload))
        self.sock.sendall(head + mask + masked)

    def send_text(self, text: str) -> None:
        self.send(1, text.encode())

    def close(self) -> None:
        try:
            self.send(8, b"")
        except OSError:
            pass
        self.sock.close()


def subscribe(ws: WebSocket, topics: list[str] | tuple[str, ...]) -> dict[str, int]:
    """As a Foxglove client does (foxglove.sdk.v1): wait until the server has advertised every
    one of ``topics``, then subscribe to them, subscription i to ``topics[i]``. Returns the
    channel id of each topic."""
    seen: dict[str, int] = {}
    while not set(topics) <= set(seen):
        opcode, payload = ws.receive()
        message = json.loads(payload) if opcode == 1 else {}
        if message.get("op") == "advertise":
            seen.update({c["topic"]: c["id"] for c in message["channels"]})
    ws.send_text(json.dumps({"op": "subscribe", "subscriptions": [
        {"id": i, "channelId": seen[topic]} for i, topic in enumerate(topics)]}))
    return seen
