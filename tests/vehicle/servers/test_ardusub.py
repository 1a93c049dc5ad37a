"""The ArduSub-like MAVLink vehicle (``mcl vehicle --mavlink``) seen by an independent client.

The vehicle is a real subprocess sending to a UDP port on loopback (``udpout:``); the test is a
plain pymavlink ground station listening there (system 255, component 190). Every wait is
bounded in wall time and synchronises on what the vehicle sends; rates are measured on the
vehicle's own clock (``time_boot_ms``), never on the wall clock. Every process is stopped.
"""

from __future__ import annotations

import hashlib
import math
import os
import subprocess
import sys
import time
from collections import Counter
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import pytest

os.environ["MAVLINK20"] = "1"
from pymavlink import mavutil  # noqa: E402

from aal import signing  # noqa: E402
from vehicle.servers import ardusub  # noqa: E402

from tests.in_process import mcl_in_process  # noqa: E402
from tests.support import REPO, budget, first_line, free_udp_port  # noqa: E402

pytestmark = pytest.mark.slow  # the ArduSub-like vehicle as a real process: not in make test-quick

mav = mavutil.mavlink
WAIT = budget(3.0)  # wall s: the longest any single wait may take before the test fails
GUIDED, SURFACE, MANUAL = ardusub.MODES["GUIDED"], ardusub.MODES["SURFACE"], \
    ardusub.MODES["MANUAL"]
ARMED = mav.MAV_MODE_FLAG_SAFETY_ARMED
POSITION_ONLY = 0b0000_1111_1111_1000  # type_mask: x, y, z and yaw
VELOCITY_ONLY = 0b0000_1101_1100_0111  # type_mask: vx, vy, vz and yaw rate


class Vehicle:
    """``mcl vehicle --mavlink udpout:127.0.0.1:PORT ...`` as a subprocess."""

    def __init__(self, port: int, args: list[str], env: dict[str, str], log: Path) -> None:
        self.log = log.open("w")
        self.proc = subprocess.Popen(
            [sys.executable, "-m", "app.mcl", "vehicle", "--mavlink",
             f"udpout:127.0.0.1:{port}", *args],
            cwd=REPO, env=env, stdin=subprocess.DEVNULL, stdout=subprocess.PIPE,
            stderr=self.log, text=True)
        self.ready = first_line(self.proc, WAIT) or ""  # "" if none within WAIT s
        self.output = ""

    def stop(self) -> str:
        """Stop it (SIGTERM, then kill) and return what it printed after 'ready'."""
        if self.proc.poll() is None:
            self.proc.terminate()
        try:
            out, _ = self.proc.communicate(timeout=10)
        except subprocess.TimeoutExpired:
            self.proc.kill()
            out, _ = self.proc.communicate(timeout=10)
        self.log.close()
        self.output += out or ""
        return self.output


@contextmanager
def vehicle(tmp_path: Path, port: int, *args: str, env: dict[str, str] | None = None
            ) -> Iterator[Vehicle]:
    full_env = dict(os.environ, PYTHONDONTWRITEBYTECODE="1", MCL_STATE_DIR=str(tmp_path / "st"))
    full_env.pop(signing.ENV_KEY, None)
    full_env.update(env or {})
    v = Vehicle(port, list(args), full_env, tmp_path / f"vehicle-{port}.log")
    try:
        assert v.ready.startswith("vehicle auv ready on udpout:127.0.0.1:"), \
            f"not ready: {v.ready!r}; log: {(tmp_path / f'vehicle-{port}.log').read_text()}"
        yield v
    finally:
        v.stop()


class Gcs:
    """A minimal ground station: heartbeats and neutral sticks, bounded waits, the vehicle's
    clock as the latest ``time_boot_ms`` seen."""

    def __init__(self, port: int, key: bytes | None = None) -> None:
        self.conn = mavutil.mavlink_connection(f"udpin:127.0.0.1:{port}", source_system=255,
                                               source_component=190, dialect="ardupilotmega")
        if key is not None:
            signing.enable(self.conn, key, require=False, link_id=1, timestamp_file=None)
        self.heartbeats = self.sticks = True
        self.now_ms = 0  # the vehicle's clock, from what it sent
        self.counts: dict[str, int] = {}  # NAMED_VALUE_INT
        self.seen: Counter[str] = Counter()
        self._last = 0.0

    def close(self) -> None:
        self.conn.close()

    def pump(self) -> None:
        if time.monotonic() - self._last >= 0.1:
            self._last = time.monotonic()
            if self.heartbeats:
                self.conn.mav.heartbeat_send(mav.MAV_TYPE_GCS, mav.MAV_AUTOPILOT_INVALID, 0, 0, 0)
            if self.sticks:
                self.conn.mav.manual_control_send(1, 0, 0, 500, 0, 0)

    def recv(self) -> Any:
        self.pump()
        msg = self.conn.recv_match(blocking=True, timeout=0.02)
        if msg is None or msg.get_type() == "BAD_DATA":
            return None
        self.seen[msg.get_type()] += 1
        self.now_ms = max(self.now_ms, getattr(msg, "time_boot_ms", 0))
        if msg.get_type() == "NAMED_VALUE_INT":
            self.counts[msg.name] = msg.value
        return msg

    def wait(self, kind: str | tuple[str, ...], test: Callable[[Any], bool] = lambda m: True,
             timeout: float = WAIT) -> Any:
        """The first message of that kind passing the test; fails after ``timeout`` wall s."""
        kinds = (kind,) if isinstance(kind, str) else kind
        end = time.monotonic() + timeout
        while time.monotonic() < end:
            msg = self.recv()
            if msg is not None and msg.get_type() in kinds and test(msg):
                return msg
        pytest.fail(f"no {kinds} passing the test within {timeout} s (clock {self.now_ms} ms)")

    def collect(self, until_ms: int, timeout: float = WAIT) -> list[Any]:
        """Everything received until the vehicle's clock passes ``until_ms``."""
        out, end = [], time.monotonic() + timeout
        while self.now_ms < until_ms:
            assert time.monotonic() < end, f"the clock stayed at {self.now_ms} ms"
            msg = self.recv()
            if msg is not None:
                out.append(msg)
        return out

    def command(self, command: int, *params: float) -> int:
        p = [*params, 0, 0, 0, 0, 0, 0, 0][:7]
        self.conn.mav.command_long_send(1, 1, command, 0, *p)
        return int(self.wait("COMMAND_ACK", lambda m: m.command == command).result)

    def set_mode(self, mode: int) -> int:
        self.conn.mav.set_mode_send(1, mav.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, mode)
        return int(self.wait("COMMAND_ACK", lambda m: m.command == mav.MAVLINK_MSG_ID_SET_MODE)
                   .result)

    def setpoint(self, mask: int, x: float = 0, y: float = 0, z: float = 0, vx: float = 0,
                 vy: float = 0, vz: float = 0, yaw: float = 0, yaw_rate: float = 0) -> None:
        self.conn.mav.set_position_target_local_ned_send(
            self.now_ms, 1, 1, mav.MAV_FRAME_LOCAL_NED, mask, x, y, z, vx, vy, vz, 0, 0, 0,
            yaw, yaw_rate)

    def position(self) -> Any:
        return self.wait("LOCAL_POSITION_NED")

    def heartbeat(self, test: Callable[[Any], bool] = lambda m: True) -> Any:
        return self.wait("HEARTBEAT", lambda m: m.get_srcSystem() == 1 and test(m))


@pytest.fixture
def gcs_port() -> Iterator[tuple[Gcs, int]]:
    port = free_udp_port()
    gcs = Gcs(port)
    try:
        yield gcs, port
    finally:
        gcs.close()


def test_a_well_formed_ardusub_vehicle(tmp_path: Path, gcs_port: tuple[Gcs, int]) -> None:
    gcs, port = gcs_port
    with vehicle(tmp_path, port, "--speed", "20", "--inject", "leak@40"):
        hb = gcs.heartbeat()
        assert hb.get_msgbuf()[0] == 0xFD, "MAVLink 2"
        assert (hb.get_srcSystem(), hb.get_srcComponent()) == (1, mav.MAV_COMP_ID_AUTOPILOT1)
        assert (hb.type, hb.autopilot) == (mav.MAV_TYPE_SUBMARINE,
                                           mav.MAV_AUTOPILOT_ARDUPILOTMEGA)
        assert hb.base_mode & mav.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED
        assert not hb.base_mode & ARMED and hb.custom_mode == MANUAL
        assert hb.system_status == mav.MAV_STATE_STANDBY

        # the usual telemetry at its usual rates, on the vehicle's clock: 5 s from t = 2 s
        gcs.collect(2000)
        window = [m for m in gcs.collect(7000) if 2000 <= getattr(m, "time_boot_ms", 2000) < 7000]
        assert all(m.get_msgbuf()[0] == 0xFD for m in window)
        count = Counter(m.get_type() for m in window)
        for name, hz in ardusub.STREAMS.items():
            assert abs(count[name] - 5 * hz) <= max(1.0, 0.1 * 5 * hz), (name, count)

        # SET_MESSAGE_INTERVAL: LOCAL_POSITION_NED at 2 Hz, VFR_HUD off; acknowledged, obeyed
        local, hud = mav.MAVLINK_MSG_ID_LOCAL_POSITION_NED, mav.MAVLINK_MSG_ID_VFR_HUD
        assert gcs.command(mav.MAV_CMD_SET_MESSAGE_INTERVAL, local, 500_000) == mav.MAV_RESULT_ACCEPTED
        assert gcs.command(mav.MAV_CMD_SET_MESSAGE_INTERVAL, hud, -1) == mav.MAV_RESULT_ACCEPTED
        assert gcs.command(mav.MAV_CMD_GET_MESSAGE_INTERVAL, local) == mav.MAV_RESULT_ACCEPTED
        assert gcs.wait("MESSAGE_INTERVAL").interval_us == 500_000
        start = gcs.now_ms + 1000
        gcs.collect(start)
        later = Counter(m.get_type() for m in gcs.collect(start + 5000)
                        if start <= getattr(m, "time_boot_ms", start) < start + 5000)
        assert abs(later["LOCAL_POSITION_NED"] - 10) <= 1 and later["VFR_HUD"] == 0, later
        assert later["ATTITUDE"] >= 45, "the others unchanged"
        assert gcs.command(mav.MAV_CMD_SET_MESSAGE_INTERVAL, 9999, 100_000) == mav.MAV_RESULT_FAILED
        assert gcs.command(mav.MAV_CMD_NAV_TAKEOFF) == mav.MAV_RESULT_UNSUPPORTED

        # DISTANCE_SENSOR: the sonar's wall, 6 m ahead (start x = -6, facing the wall)
        sonar = gcs.wait("DISTANCE_SENSOR", lambda m: m.current_distance <= m.max_distance)
        assert (sonar.id, sonar.type, sonar.orientation) == (
            1, mav.MAV_DISTANCE_SENSOR_ULTRASOUND, mav.MAV_SENSOR_ROTATION_CUSTOM)
        assert (sonar.min_distance, sonar.max_distance) == (30, 5000)
        assert 500 <= sonar.current_distance <= 700
        w, _, _, z = sonar.quaternion
        assert abs(math.degrees(2 * math.atan2(z, w))) < 10, "the wall's normal is ahead"

        # leak at t = 40 s: nothing before, then "Leak Detected" (CRITICAL) every 5 s
        texts = [m for m in gcs.collect(39_000) if m.get_type() == "STATUSTEXT"]
        assert not any("Leak" in m.text for m in texts), texts
        leak = gcs.wait("STATUSTEXT", lambda m: m.text == ardusub.LEAK_TEXT)
        assert leak.severity == mav.MAV_SEVERITY_CRITICAL
        first = gcs.now_ms
        assert first >= 40_000
        assert gcs.heartbeat().system_status == mav.MAV_STATE_CRITICAL
        gcs.wait("STATUSTEXT", lambda m: m.text == ardusub.LEAK_TEXT)
        assert 4_500 <= gcs.now_ms - first <= 5_500


def test_modes_arming_and_setpoints(tmp_path: Path, gcs_port: tuple[Gcs, int]) -> None:
    gcs, port = gcs_port
    with vehicle(tmp_path, port, "--speed", "20") as v:
        start = gcs.position()
        target = (start.x + 2.0, start.y, 2.0)
        # outside GUIDED (MANUAL, disarmed, then armed) setpoints are ignored
        gcs.setpoint(POSITION_ONLY, *target)
        assert gcs.command(mav.MAV_CMD_COMPONENT_ARM_DISARM, 1) == mav.MAV_RESULT_ACCEPTED
        assert gcs.heartbeat(lambda m: m.base_mode & ARMED).system_status == mav.MAV_STATE_ACTIVE
        gcs.setpoint(POSITION_ONLY, *target)
        gcs.collect(gcs.now_ms + 5000)
        p = gcs.position()
        assert math.dist((p.x, p.y, p.z), (start.x, start.y, start.z)) < 0.5

        # GUIDED (by SET_MODE): it goes there
        assert gcs.set_mode(GUIDED) == mav.MAV_RESULT_ACCEPTED
        hb = gcs.heartbeat(lambda m: m.custom_mode == GUIDED)
        assert hb.base_mode & mav.MAV_MODE_FLAG_GUIDED_ENABLED
        gcs.setpoint(POSITION_ONLY, *target)
        p = gcs.wait("LOCAL_POSITION_NED",
                     lambda m: math.dist((m.x, m.y, m.z), target) < 0.3, timeout=WAIT)
        assert p.time_boot_ms < 60_000
        # a velocity setpoint: 0.2 m/s along the wall (y), for at most 3 s of vehicle time
        gcs.setpoint(VELOCITY_ONLY, vy=0.2)
        gcs.wait("LOCAL_POSITION_NED", lambda m: m.vy > 0.1)
        moved = gcs.wait("LOCAL_POSITION_NED", lambda m: m.y - p.y > 0.3)
        assert moved.x == pytest.approx(p.x, abs=0.3)

        assert gcs.command(mav.MAV_CMD_IMAGE_START_CAPTURE) == mav.MAV_RESULT_ACCEPTED
        assert gcs.command(mav.MAV_CMD_LOGGING_START) == mav.MAV_RESULT_ACCEPTED
        assert gcs.command(mav.MAV_CMD_DO_SET_MODE, 1, ardusub.MODES["AUTO"]) == \
            mav.MAV_RESULT_FAILED

        # SURFACE (by MAV_CMD_DO_SET_MODE): it rises and stays in SURFACE
        assert gcs.command(mav.MAV_CMD_DO_SET_MODE, 1, SURFACE) == mav.MAV_RESULT_ACCEPTED
        gcs.wait("LOCAL_POSITION_NED", lambda m: m.z <= 0.2)
        surfaced = gcs.now_ms
        assert gcs.heartbeat(lambda m: gcs.now_ms > surfaced + 1500).custom_mode == SURFACE

        assert gcs.command(mav.MAV_CMD_COMPONENT_ARM_DISARM, 0) == mav.MAV_RESULT_ACCEPTED
        assert gcs.heartbeat(lambda m: not m.base_mode & ARMED).system_status == \
            mav.MAV_STATE_STANDBY
        out = v.stop()
    assert v.proc.returncode == 0
    assert "4 setpoints, 2 ignored" in out, out
    assert "images" in out


def test_pilot_input_and_ground_station_failsafes(tmp_path: Path,
                                                  gcs_port: tuple[Gcs, int]) -> None:
    gcs, port = gcs_port
    with vehicle(tmp_path, port, "--speed", "10", "--pilot-timeout", "1",
                 "--gcs-timeout", "1"):
        gcs.heartbeat()
        assert gcs.command(mav.MAV_CMD_COMPONENT_ARM_DISARM, 1) == mav.MAV_RESULT_ACCEPTED
        assert gcs.set_mode(GUIDED) == mav.MAV_RESULT_ACCEPTED
        gcs.heartbeat(lambda m: m.custom_mode == GUIDED)

        gcs.sticks = False  # no MANUAL_CONTROL: pilot-input failsafe
        text = gcs.wait("STATUSTEXT", lambda m: m.text == ardusub.PILOT_TEXT)
        assert text.severity == mav.MAV_SEVERITY_CRITICAL
        hb = gcs.heartbeat(lambda m: m.custom_mode == SURFACE)
        assert hb.base_mode & ARMED and hb.system_status == mav.MAV_STATE_CRITICAL

        gcs.sticks = True  # it stays in SURFACE until the ground station sets another mode
        assert gcs.set_mode(GUIDED) == mav.MAV_RESULT_ACCEPTED
        gcs.heartbeat(lambda m: m.custom_mode == GUIDED)
        gcs.collect(gcs.now_ms + 5000)
        assert gcs.heartbeat().custom_mode == GUIDED

        gcs.heartbeats = False  # no GCS HEARTBEAT: ground-station failsafe
        gcs.wait("STATUSTEXT", lambda m: m.text == ardusub.GCS_TEXT)
        gcs.heartbeat(lambda m: m.custom_mode == SURFACE)


def _signature_timestamp(msg: Any) -> int:
    """The signing timestamp in a signed message's signature block."""
    return int.from_bytes(bytes(msg.get_msgbuf()[-12:-6]), "little")


def test_signing_required_rejects_unsigned_and_wrong_keys(tmp_path: Path) -> None:
    key_file = tmp_path / "key"
    key_file.write_text("correct horse battery staple\n")
    key = signing.load_key(str(key_file))
    assert key is not None
    port = free_udp_port()
    gcs = Gcs(port)
    try:
        with vehicle(tmp_path, port, "--speed", "10", "--signing-key", str(key_file),
                     "--require-signing") as v:
            hb = gcs.heartbeat()
            assert hb.get_msgbuf()[2] & mav.MAVLINK_IFLAG_SIGNED, "signed"
            # unsigned: heartbeats and commands rejected and counted, never acknowledged
            gcs.conn.mav.command_long_send(1, 1, mav.MAV_CMD_COMPONENT_ARM_DISARM, 0, 1, 0, 0,
                                           0, 0, 0, 0)
            gcs.wait("NAMED_VALUE_INT", lambda m: m.name == "SIG_UNSIGN" and m.value >= 3)
            assert gcs.seen["COMMAND_ACK"] == 0 and gcs.now_ms == 0, "the clock waits"
            # a wrong key: rejected and counted as bad signatures
            signing.enable(gcs.conn, hashlib.sha256(b"wrong").digest(), require=False,
                           link_id=1, timestamp_file=None)
            gcs.conn.mav.signing.allow_unsigned_callback = lambda *_: True  # still read it
            gcs.conn.mav.command_long_send(1, 1, mav.MAV_CMD_COMPONENT_ARM_DISARM, 0, 1, 0, 0,
                                           0, 0, 0, 0)
            gcs.wait("NAMED_VALUE_INT", lambda m: m.name == "SIG_BAD" and m.value >= 2)
            assert gcs.seen["COMMAND_ACK"] == 0
            # the right key: obeyed
            signing.enable(gcs.conn, key, require=False, link_id=1, timestamp_file=None)
            assert gcs.command(mav.MAV_CMD_COMPONENT_ARM_DISARM, 1) == mav.MAV_RESULT_ACCEPTED
            gcs.wait("NAMED_VALUE_INT", lambda m: m.name == "SIG_OK" and m.value >= 2)
            last = _signature_timestamp(gcs.heartbeat(lambda m: m.base_mode & ARMED))
            out = v.stop()
        assert "unsigned rejected" in out and "badly signed rejected" in out, out
        files = list((tmp_path / "st").glob("mavlink-signing-vehicle-*.timestamp"))
        assert len(files) == 1
        saved = int(files[0].read_text())
        assert saved > last, "the timestamp reached is saved at exit"

        # a restart never signs with an old timestamp: put the saved one far ahead of the clock
        ahead = max(saved, signing.wall_timestamp()) + 10**9  # ~3 h ahead of the wall clock
        files[0].write_text(f"{ahead}\n")
        port2 = free_udp_port()
        gcs2 = Gcs(port2, key)
        try:
            with vehicle(tmp_path, port2, "--speed", "10", "--signing-key", str(key_file)):
                assert _signature_timestamp(gcs2.heartbeat()) > ahead
        finally:
            gcs2.close()
    finally:
        gcs.close()


def test_load_key_forms_and_errors(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.delenv(signing.ENV_KEY, raising=False)
    assert signing.load_key(None) is None
    hex_file = tmp_path / "hex"
    hex_file.write_text("00" * 31 + "ff\n")
    assert signing.load_key(str(hex_file)) == bytes(31) + b"\xff"
    phrase = tmp_path / "phrase"
    phrase.write_text("my passphrase\n")  # hashed as MAVProxy's 'signing setup' does
    assert signing.load_key(str(phrase)) == hashlib.sha256(b"my passphrase").digest()
    monkeypatch.setenv(signing.ENV_KEY, "ab" * 32)
    assert signing.load_key(None) == bytes([0xAB]) * 32
    assert signing.load_key(str(phrase)) == hashlib.sha256(b"my passphrase").digest()
    empty = tmp_path / "empty"
    empty.write_text("  \n")
    for path, reason in ((tmp_path / "missing", "no such signing key file"),
                         (empty, "is empty"), (tmp_path, "is a directory")):
        with pytest.raises(signing.SigningError, match=reason) as info:
            signing.load_key(str(path))
        assert str(path) in str(info.value)
    monkeypatch.setenv(signing.ENV_KEY, "")
    with pytest.raises(signing.SigningError, match=r"\$MCL_MAVLINK_KEY: the signing key is empty"):
        signing.load_key(None)


@pytest.mark.parametrize("args, message", [
    (["--mavlink", "udpout:127.0.0.1"], "is not a MAVLink URL"),
    (["--mavlink", "serial:/dev/ttyS0:57600"], "is not a MAVLink URL"),
    (["--mavlink", "udpout:127.0.0.1:70000"], "not in 1..65535"),
    (["--mavlink", "udpout:127.0.0.1:14550", "--signing-key", "/nonexistent/key"],
     "no such signing key file"),
    (["--mavlink", "udpout:127.0.0.1:14550", "--require-signing"], "needs a key"),
])
def test_bad_input_is_one_line_and_status_2(args: list[str], message: str,
                                            monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.delenv(signing.ENV_KEY, raising=False)  # in process: the tests above start it
    done = mcl_in_process("vehicle", *args)
    assert done.returncode == 2
    assert done.stderr.startswith("mcl vehicle: error: ") and message in done.stderr
    assert len(done.stderr.strip().splitlines()) == 1 and not done.stdout
