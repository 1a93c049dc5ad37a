"""A signed MAVLink session attacked as in issue 22, with real processes on loopback UDP.

The vehicle is ``mcl vehicle --mavlink udpout:... --signing-key KEY --require-signing`` in a
subprocess, the player the MAVLink adapter (:class:`MavlinkVehicle`) with the same key, on a
``udpin`` port of its own. The attacker has no key. Two attacks:

- one unsigned datagram at the player's ``udpin`` port: pymavlink made its sender a client and
  copied every datagram the player sent to it; the player now sends to nobody but the vehicle
  (and a vehicle listening on ``udpin`` to nobody but its ground station);
- a session captured on the path (a relay between the two records what the player sends),
  replayed at the vehicle restarted with a fresh ``$MCL_STATE_DIR``: pymavlink took it (a new
  stream at most a minute old), armed, went GUIDED and moved; the vehicle now refuses every
  datagram signed before it started (less 2 s) and stays disarmed, its clock stopped.

Every port is a free one, every process is stopped, every wait is bounded.
"""

from __future__ import annotations

import select
import socket
import threading
import time
from pathlib import Path
from typing import Any

from pymavlink.dialects.v20 import ardupilotmega as mavlink

from aal import signing
from aal.mavlink_udp import mavutil
from aal.messages import ActionMessage
from vehicle_adapters.mavlink.link import MavlinkVehicle

from tests.support import BIN, budget, free_udp_port, started
from tests.vehicle_adapters.test_mavlink import env, vehicle_process

SIGNED = mavlink.MAVLINK_IFLAG_SIGNED
GUIDED, ARMED = 4, mavlink.MAV_MODE_FLAG_SAFETY_ARMED
GO = {"x": -4.0, "y": 3.0, "z": 3.0, "yaw": 0.0, "tolerance": 0.3}


def _key(tmp_path: Path) -> tuple[Path, bytes]:
    path = tmp_path / "key"
    path.write_text("the passphrase of the ground station and the vehicle\n")
    key = signing.load_key(str(path))
    assert key is not None
    return path, key


def _player(port: int, key: bytes, tmp_path: Path) -> MavlinkVehicle:
    return MavlinkVehicle(f"udpin:127.0.0.1:{port}", signing_key=key, require_signing=True,
                          timestamp_file=tmp_path / "player.timestamp",
                          connect_timeout=budget(1))


def _messages(datagrams: list[bytes]) -> list[Any]:
    """The messages in datagrams, read without the key (a signature is not checked)."""
    parser = mavlink.MAVLink(None)
    return [m for d in datagrams for m in parser.parse_buffer(d) or []]


def _collect(sock: socket.socket, seconds: float) -> list[tuple[bytes, tuple[str, int]]]:
    """Every datagram that reaches ``sock`` in ``seconds`` of wall time."""
    got: list[tuple[bytes, tuple[str, int]]] = []
    deadline = time.monotonic() + seconds
    while (left := deadline - time.monotonic()) > 0:
        if select.select([sock], [], [], left)[0]:
            got.append(sock.recvfrom(65535))
    return got


def _udp(port: int = 0) -> socket.socket:
    sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    sock.bind(("127.0.0.1", port))
    return sock


class Tap:
    """A relay on the path: the vehicle sends to :attr:`port`, the relay passes it on to the
    player's port and passes the player's answers back, recording them (wall time, bytes)."""

    def __init__(self, player_port: int) -> None:
        self.outer, self.inner = _udp(), _udp()
        self.port = self.outer.getsockname()[1]
        self.player = ("127.0.0.1", player_port)
        self.vehicle: tuple[str, int] | None = None
        self.captured: list[tuple[float, bytes]] = []
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._relay, daemon=True)
        self._thread.start()

    def _relay(self) -> None:
        while not self._stop.is_set():
            for sock in select.select([self.outer, self.inner], [], [], 0.05)[0]:
                data, address = sock.recvfrom(65535)
                if sock is self.outer:
                    self.vehicle = address
                    self.inner.sendto(data, self.player)
                elif self.vehicle is not None:
                    self.captured.append((time.time(), data))
                    self.outer.sendto(data, self.vehicle)

    def close(self) -> None:
        self._stop.set()
        self._thread.join(timeout=2)
        self.outer.close()
        self.inner.close()


def test_an_unsigned_datagram_does_not_make_the_player_copy_its_link_to_the_sender(
        tmp_path: Path) -> None:
    key_file, key = _key(tmp_path)
    port = free_udp_port()
    attacker = _udp()
    try:
        with vehicle_process(port, tmp_path, "--signing-key", str(key_file),
                             "--require-signing", speed=10), \
                _player(port, key, tmp_path) as player:
            assert not player.lost and player.link.signing is not None, player.lost_reason
            intruder = mavlink.MAVLink(None, srcSystem=1, srcComponent=1)  # claims the vehicle
            hello = intruder.heartbeat_encode(12, 3, 0, 0, 0).pack(intruder)
            attacker.sendto(hello, ("127.0.0.1", port))
            before = player.link.received
            copied = _collect(attacker, 2.0)  # 2 s: 2 GCS heartbeats, 20 MANUAL_CONTROL
            assert copied == [], f"the player copied {len(copied)} datagrams to the attacker"
            assert player.link.received > before and not player.lost, "the link still works"
            assert player.link.signing.rejected_unsigned >= 1
            assert player.link.conn.peer[1] != attacker.getsockname()[1]
    finally:
        attacker.close()


def _capture_a_session(tmp_path: Path, key_file: Path, key: bytes
                       ) -> tuple[list[tuple[float, bytes]], list[str]]:
    """The datagrams a player sent in a session that armed, went GUIDED and moved the vehicle,
    as captured on the path (wall time, bytes), and the vehicle's words at exit."""
    player_port = free_udp_port()
    tap = Tap(player_port)
    try:
        with vehicle_process(tap.port, tmp_path / "before", "--signing-key", str(key_file),
                             "--require-signing", speed=10) as (_, said):
            with _player(player_port, key, tmp_path) as player:
                assert not player.lost, player.lost_reason
                player.send(ActionMessage(0, player.now(), "m", "GoTo@1:1", "enable", "GoTo",
                                          GO))
                time.sleep(2.0)  # 20 s of the vehicle's clock: a few metres
    finally:
        tap.close()
    assert tap.captured, "nothing captured"
    return tap.captured, said.seen


def test_a_captured_session_cannot_move_a_vehicle_restarted_without_its_state(
        tmp_path: Path) -> None:
    key_file, key = _key(tmp_path)
    capture, said = _capture_a_session(tmp_path, key_file, key)
    datagrams = [d for _, d in capture]
    moved = [line for line in said if "path " in line]
    assert moved and not moved[0].strip().startswith("path 0.0 m"), said  # it did move
    assert all(d[0] == 0xFD and d[2] & SIGNED for d in datagrams), "every datagram signed"
    arms = [m for m in _messages(datagrams) if m.get_type() == "COMMAND_LONG"
            and m.command == mavlink.MAV_CMD_COMPONENT_ARM_DISARM and m.param1 == 1]
    setpoints = [m for m in _messages(datagrams)
                 if m.get_type() == "SET_POSITION_TARGET_LOCAL_NED"]
    assert arms and setpoints, "the capture arms and drives the vehicle"

    # the restart: a fresh state directory; the capture is more than CLOCK_SKEW old
    time.sleep(max(0.0, capture[-1][0] + signing.CLOCK_SKEW / signing.TICKS_PER_SECOND + 0.5
                   - time.time()))
    attacker = _udp()
    heartbeats: list[Any] = []
    try:
        with vehicle_process(attacker.getsockname()[1], tmp_path / "after", "--signing-key",
                             str(key_file), "--require-signing", speed=10) as (_, said_after):
            attacker.settimeout(budget(1))
            vehicle = attacker.recvfrom(65535)[1]  # where the restarted vehicle is
            attacker.settimeout(None)
            start = time.monotonic()
            for at, datagram in capture:  # at the pace it was captured
                time.sleep(max(0.0, start + at - capture[0][0] - time.monotonic()))
                attacker.sendto(datagram, vehicle)
            got = _collect(attacker, 1.5)
            heartbeats = [m for m in _messages([d for d, _ in got])
                          if m.get_type() == "HEARTBEAT"]
    finally:
        attacker.close()
    assert heartbeats, "the restarted vehicle said nothing"
    assert not any(h.base_mode & ARMED or h.custom_mode == GUIDED for h in heartbeats)
    summary = "".join(said_after.seen)
    assert "stopped after 0.0 s of simulated time" in summary, summary  # its clock never ran
    assert "path 0.0 m" in summary and "behaviours on at exit: none" in summary, summary
    assert "disarmed" in summary, summary
    assert (f"0 signed accepted, 0 unsigned accepted, 0 unsigned rejected, {len(capture)} "
            f"badly signed rejected ({len(capture)} of them signed before it started)"
            ) in summary, summary


def test_a_listening_vehicle_answers_its_ground_station_and_not_an_intruder(
        tmp_path: Path) -> None:
    key_file, key = _key(tmp_path)
    port = free_udp_port()
    gcs = mavutil.mavlink_connection(f"udpout:127.0.0.1:{port}", source_system=255,
                                     source_component=190)
    signing.enable(gcs, key, require=True, link_id=1, timestamp_file=None)
    attacker = _udp()
    intruder = mavlink.MAVLink(None, srcSystem=255, srcComponent=190)  # claims the GCS
    try:
        with started([str(BIN / "mcl"), "vehicle", "--mavlink", f"udpin:127.0.0.1:{port}",
                      "--speed", "10", "--signing-key", str(key_file), "--require-signing"],
                     env=env(tmp_path)):
            attacker.sendto(intruder.heartbeat_encode(6, 8, 0, 0, 0).pack(intruder),
                            ("127.0.0.1", port))
            heard: list[Any] = []
            deadline = time.monotonic() + budget(1)
            while len(heard) < 2 and time.monotonic() < deadline:
                gcs.mav.heartbeat_send(6, 8, 0, 0, 0)
                msg = gcs.recv_match(type="HEARTBEAT", blocking=True, timeout=0.2)
                if msg is not None:
                    heard.append(msg)
            copied = _collect(attacker, 1.0)
    finally:
        attacker.close()
        gcs.close()
    assert len(heard) == 2 and all(h.get_srcSystem() == 1 for h in heard), heard
    assert copied == [], f"the vehicle copied {len(copied)} datagrams to the intruder"
