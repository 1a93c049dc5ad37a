"""The MAVLink adapter (AAL.md): the player on one side, an ArduSub-class vehicle on the other.

    with MavlinkVehicle("udpin:127.0.0.1:14550") as vehicle: run(player, vehicle, ...)

MAVLink 2, dialect ardupilotmega; the player is a ground station (sysid 255, compid 190,
MAV_COMP_ID_MISSIONPLANNER) talking to the vehicle's autopilot (sysid 1, compid 1). Entering
opens the connection (URL as pymavlink writes it), enables signing if a key is given, starts
ONE reader thread, waits (bounded) for the vehicle's HEARTBEAT, asks for the telemetry it
needs (MAV_CMD_SET_MESSAGE_INTERVAL), sets GUIDED and arms.

The reader thread dispatches every message and does the periodic work of a ground station: the
GCS HEARTBEAT (1 Hz) and a neutral MANUAL_CONTROL stream (10 Hz), which ArduSub's ground-station
and pilot-input failsafes expect; link health; command retries. Every send goes through one
lock (pymavlink's sequence numbers and signing timestamps are not thread-safe), and so does
every receive (checking a signature moves the signing timestamp).

Behaviours (the task library's, docs/VEHICLES.md) map onto what ArduSub accepts:

- GoTo: a SET_POSITION_TARGET_LOCAL_NED (position and yaw) in GUIDED; ``reached`` when
  LOCAL_POSITION_NED is within the tolerance and the yaw (ATTITUDE) within 5 deg.
- WallInspection, AchieveHeadDist (ArduSub has neither) run here, on guided setpoints:
  WallInspection walks its (y, z) waypoints with a look-ahead point on each leg (a slow survey
  pace); AchieveHeadDist estimates the wall from DISTANCE_SENSOR (distance and bearing of the
  wall's normal) and holds the vehicle at the distance, turned to the heading.
- Surface: ArduSub's SURFACE mode; ``surfaced`` when LOCAL_POSITION_NED's z <= 0.2 m.
- StartCamera: MAV_CMD_IMAGE_START_CAPTURE / STOP_CAPTURE; StartLogs: MAV_CMD_LOGGING_START /
  STOP. Alarms: STATUSTEXT ("Leak", "temperature", "pressure") and the internal barometer
  (SCALED_PRESSURE) against the Alarms thresholds.

Degrees of freedom follow the vehicle's coordinator: each setpoint takes x, y, z, yaw from the
highest-priority active behaviour that drives them; a free one holds its last value.

Clock: every ``time_boot_ms`` the vehicle sends is its (simulated) clock; ``now()`` is the last
one received, run on by wall time x the speed estimated from them (bounded). Link health:
when the vehicle's HEARTBEAT has been missing for ``link_timeout`` wall seconds (or never came
within ``connect_timeout``), one synthetic ``Link.lost`` event; from then on the clock runs on
wall time x the last speed, so that the player's timers still end the run.
"""

from __future__ import annotations

import logging
import math
import os
import select
import threading
import time
from collections import deque
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

os.environ["MAVLINK20"] = "1"  # before pymavlink loads a dialect: MAVLink 2 only

# mavutil is re-exported: importing it from here guarantees MAVLink 2
from pymavlink import mavutil as mavutil  # noqa: E402
from pymavlink.dialects.v20 import ardupilotmega as mavlink  # noqa: E402

from behaviours.base import wrap  # noqa: E402
from mcl.errors import Diagnostic, MclError  # noqa: E402

from . import signing  # noqa: E402
from . import capabilities  # noqa: E402
from .aal import ActionMessage, Declaration, EventMessage  # noqa: E402
from .ardusub_protocol import GCS_SYSID, MODE_NAMES, MODES, VEHICLE_SYSID, parse_url  # noqa: E402
from .link import MAX_POLL, RemoteVehicle  # noqa: E402
from .mavlink_behaviours import (  # noqa: E402
    PRIORITY,
    AchieveHeadDist,
    Alarms,
    Behaviour,
    GoTo,
    Surface,
    Telemetry,
    WallInspection,
)

log = logging.getLogger(__name__)

DEFAULT_URL = "udpin:127.0.0.1:14550"
GCS_COMPID = mavlink.MAV_COMP_ID_MISSIONPLANNER
VEHICLE_COMPID = mavlink.MAV_COMP_ID_AUTOPILOT1
# the telemetry the adapter asks for (Hz; the vehicle's clock says what a second is) and the
# streams it stops (None): what it does not use only loads the link, the vehicle and a router
RATES: dict[str, float | None] = {
    "LOCAL_POSITION_NED": 5.0, "ATTITUDE": 5.0, "DISTANCE_SENSOR": 5.0, "SYSTEM_TIME": 1.0,
    "SYS_STATUS": 1.0, "SCALED_PRESSURE": 1.0, "GLOBAL_POSITION_INT": None, "VFR_HUD": None,
    "SCALED_PRESSURE2": None, "BATTERY_STATUS": None}
LINK_PERIOD = {"HEARTBEAT": 1.0, "MANUAL_CONTROL": 0.1}  # wall s: what the failsafes expect
POSITION_AND_YAW = 0b1001_1111_1000  # type_mask: ignore velocity, acceleration, yaw rate
ACK_TIMEOUT = 0.5  # wall s before a command without COMMAND_ACK is sent again
ACK_TRIES = 3
SETPOINT_PERIOD = 0.5  # vehicle s between setpoints while a target moves
SETPOINT_REFRESH = 2.0  # vehicle s: a constant target is sent again this often (UDP)
MAX_EXTRAPOLATION = 0.1  # wall s the clock runs on past the last time_boot_ms
SAVE_PERIOD = 5.0  # wall s between saves of the signing timestamp
ALARM_TEXTS = {"leak": "leak", "temperature": "overtemperature", "pressure": "overpressure"}


class MavlinkError(MclError):
    """A MAVLink URL or connection the user gave that cannot be used (``mcl run`` exit 2)."""

    def __init__(self, message: str, hint: str = ""):
        super().__init__(Diagnostic("error", message, hint=hint))


def check_url(url: str) -> str:
    """The URL if pymavlink can open it as a network link, else MavlinkError saying why."""
    try:
        parse_url(url)
    except ValueError as exc:
        raise MavlinkError(f"--vehicle mavlink:{url}: {exc}",
                           "e.g. --vehicle mavlink:udpin:127.0.0.1:14550") from None
    return url


COMMANDS = {("StartCamera", "enable"): mavlink.MAV_CMD_IMAGE_START_CAPTURE,
            ("StartCamera", "disable"): mavlink.MAV_CMD_IMAGE_STOP_CAPTURE,
            ("StartLogs", "enable"): mavlink.MAV_CMD_LOGGING_START,
            ("StartLogs", "disable"): mavlink.MAV_CMD_LOGGING_STOP}


@dataclass
class Command:
    """A COMMAND_LONG waiting for its COMMAND_ACK."""

    command: int
    params: tuple[float, ...]
    sent_at: float  # monotonic, first send
    last_sent: float
    tries: int = 1
    result: int | None = None
    done: threading.Event = field(default_factory=threading.Event)


class MavlinkVehicle(RemoteVehicle):
    """The player's adapter to an ArduSub-class vehicle over MAVLink 2 (the Vehicle protocol).

    It does not raise if the vehicle is absent or refuses GUIDED or arming: the run then gets
    ``Link.lost`` (with the reason). A bad URL or a connection that cannot be opened raises
    :class:`MavlinkError`."""

    def __init__(self, url: str = DEFAULT_URL, *, signing_key: bytes | None = None,
                 require_signing: bool = False, connect_timeout: float = 10.0,
                 link_timeout: float = 2.0, max_poll: float = MAX_POLL,
                 timestamp_file: Path | None = None, arm: bool = True):
        super().__init__(max_poll=max_poll, max_extrapolation=MAX_EXTRAPOLATION)
        self.url = check_url(url)
        if require_signing and signing_key is None:
            raise MavlinkError("--require-signing needs a key",
                               "give --signing-key FILE or set $" + signing.ENV_KEY)
        self.signing_key, self.require_signing = signing_key, require_signing
        self.connect_timeout, self.link_timeout = connect_timeout, link_timeout
        self.timestamp_file = timestamp_file
        self.arm = arm
        self.conn: Any = None
        self.signing: signing.SigningState | None = None
        self._io = threading.Lock()  # every send and receive on the connection
        self._stop = threading.Event()
        self._seen = threading.Event()  # the vehicle's HEARTBEAT has come
        self._positioned = threading.Event()
        self._thread: threading.Thread | None = None
        self.last_heartbeat = 0.0  # monotonic
        self.mode: int | None = None
        self.armed = False
        self.vehicle_signs = False  # its HEARTBEATs are signed
        self._wanted_mode: int | None = None  # the mode the adapter last set
        self._in_control = False  # the vehicle is in that mode (and armed): a change is a take-over
        self._taken_over = ""  # why the vehicle took over, for Link.lost (reader thread)
        self._controlled = threading.Event()  # a HEARTBEAT has shown GUIDED and armed
        self.tel = Telemetry()
        self.behaviours: dict[str, Behaviour] = {
            "GoTo": GoTo("GoTo"), "WallInspection": WallInspection("WallInspection"),
            "AchieveHeadDist": AchieveHeadDist("AchieveHeadDist"),
            "Surface": Surface("Surface"), "Alarms": Alarms("Alarms")}
        self._hold: dict[str, float] = {}  # the last setpoint, per degree of freedom
        self._setpoint_at = -math.inf  # vehicle time of the last setpoint
        self._ref: tuple[float, float] | None = None  # (t, wall) the speed is measured from
        self._pending: list[Command] = []
        self.commands_sent = 0
        self.acks_received = 0
        self.ack_latencies: list[float] = []  # wall s from first send to COMMAND_ACK
        self.results: dict[int, int] = {}  # command -> last MAV_RESULT
        self.texts: deque[tuple[int, str]] = deque(maxlen=100)  # the last STATUSTEXTs
        self.received = 0
        self.bad_data = 0  # unparsable or rejected (signing) messages
        self.sent = 0  # actions sent
        self.unknown_actions: list[str] = []

    # -- context manager ----------------------------------------------------------------------
    def __enter__(self) -> MavlinkVehicle:
        try:
            self.conn = mavutil.mavlink_connection(
                self.url, source_system=GCS_SYSID, source_component=GCS_COMPID,
                dialect="ardupilotmega", autoreconnect=False, retries=0)
        except (OSError, ValueError) as exc:
            raise MavlinkError(f"--vehicle mavlink:{self.url}: cannot open it: {exc}",
                               "is another program using that port?") from None
        try:
            if self.signing_key is not None:
                path = self.timestamp_file or signing.default_timestamp_file(
                    self.signing_key, "player")
                self.signing = signing.enable(self.conn, self.signing_key,
                                              require=self.require_signing, link_id=1,
                                              timestamp_file=path)
            self._thread = threading.Thread(target=self._reader, name="mavlink-reader",
                                            daemon=True)
            self._thread.start()
            self._connect()
        except BaseException:
            self.__exit__()
            raise
        return self

    def _connect(self) -> None:
        """Wait for the vehicle, ask for telemetry, set GUIDED and arm (all bounded)."""
        deadline = time.monotonic() + self.connect_timeout
        if not self._seen.wait(self.connect_timeout):
            self._link_lost(f"no HEARTBEAT from the vehicle on {self.url} within "
                            f"{self.connect_timeout:g} s")
            return
        for name, hz in RATES.items():
            msg_id = getattr(mavlink, f"MAVLINK_MSG_ID_{name}")
            self.command(mavlink.MAV_CMD_SET_MESSAGE_INTERVAL, msg_id, 1e6 / hz if hz else -1)
        if self.arm:
            with self._lock:
                self._wanted_mode = MODES["GUIDED"]
            for what, cmd, params in (
                    ("GUIDED mode", mavlink.MAV_CMD_DO_SET_MODE,
                     (mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, MODES["GUIDED"])),
                    ("arming", mavlink.MAV_CMD_COMPONENT_ARM_DISARM, (1,))):
                result = self.command(cmd, *params, wait=max(0.1, deadline - time.monotonic()))
                if result != mavlink.MAV_RESULT_ACCEPTED:
                    hint = ""
                    if result is None and self.signing is None and self.vehicle_signs:
                        hint = ": it signs its messages, give its key (--signing-key FILE)"
                    self._link_lost(f"the vehicle refused {what} ({_result_name(result)})"
                                    + hint)
                    return
            # from its HEARTBEAT on, a change of mode we did not ask for is a take-over
            if not self._controlled.wait(max(0.1, deadline - time.monotonic())):
                self._link_lost("the vehicle acknowledged GUIDED and arming but its "
                                "HEARTBEAT never showed them")
                return
        self._positioned.wait(max(0.1, deadline - time.monotonic()))

    def __exit__(self, *exc: object) -> None:
        if self.conn is None:
            return
        with self._lock:
            self._in_control = False  # disarming at the end is no take-over
        try:
            if self._thread is not None and not self._lost and self.arm and self.armed:
                self.command(mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 0, wait=0.5)
        finally:
            self._stop.set()
            if self._thread is not None:
                self._thread.join(timeout=2.0)
            with self._io:
                if self.signing is not None:
                    self._save_signing()
                self.conn.close()
            self.conn = None
            log.info("MAVLink link closed: %s", self.summary())

    def declaration(self) -> Declaration:
        """What this adapter can make an ArduSub-class vehicle do: the Ictineu task library's
        declarations of the behaviours it maps (its own and the commands')."""
        names = set(self.behaviours) | {name for name, _ in COMMANDS}
        return capabilities.ictineu(f"mavlink:{self.url} (an ArduSub-class vehicle)", names)

    def confirm_off(self, names: list[str], timeout: float) -> str:
        """Wait (at most ``timeout`` wall s) for the COMMAND_ACK of every command sent (the
        camera's and the logger's stop among them); the behaviours the adapter runs itself are
        off as soon as they are disabled."""
        if self._lost:
            return f"not confirmed: the link is lost ({self.lost_reason})"
        end = time.monotonic() + timeout
        while True:
            with self._lock:
                pending = [c.command for c in self._pending]
                on = sorted(n for n, b in self.behaviours.items() if b.active)
            refused = [n for n in names if (n, "disable") in COMMANDS and
                       self.results.get(COMMANDS[n, "disable"]) != mavlink.MAV_RESULT_ACCEPTED]
            if not pending and not on and not refused:
                return (f"confirmed: every command acknowledged ({self.acks_received} "
                        "COMMAND_ACKs), no behaviour on")
            if not pending and refused:
                return f"NOT confirmed: the vehicle did not accept stopping {', '.join(refused)}"
            if time.monotonic() >= end:
                break
            time.sleep(0.02)
        what = [f"{len(pending)} command(s) unacknowledged"] if pending else []
        what += [f"{', '.join(on)} still on"] if on else []
        return f"NOT confirmed within {timeout:g} s: {'; '.join(what)}"

    def summary(self) -> dict[str, Any]:
        """What went over the link: counts, command latencies, signing."""
        ms = sorted(1e3 * s for s in self.ack_latencies)
        return {"actions": self.sent, "commands": self.commands_sent, "acks": self.acks_received,
                "ack_median_ms": round(ms[len(ms) // 2], 3) if ms else None,
                "ack_max_ms": round(ms[-1], 3) if ms else None,
                "messages": self.received, "bad_data": self.bad_data,
                "signing": self.signing.counts() if self.signing else None,
                "lost": self.lost_reason or None}

    # -- sending (any thread) ---------------------------------------------------------------------
    def _send(self, msg: Any) -> None:
        with self._io:
            if self.conn is not None:
                self.conn.mav.send(msg)

    def command(self, command: int, *params: float, wait: float | None = None) -> int | None:
        """Send a COMMAND_LONG; with ``wait``, block at most that long for its COMMAND_ACK and
        return its MAV_RESULT (None: none came)."""
        padded = tuple(float(p) for p in params) + (0.0,) * (7 - len(params))
        now = time.monotonic()
        pending = Command(command, padded, now, now)
        with self._lock:
            self._pending.append(pending)
            self.commands_sent += 1
        self._send(self._command_long(pending, 0))
        if wait is None:
            return None
        pending.done.wait(wait)
        return pending.result

    def _command_long(self, c: Command, confirmation: int) -> Any:
        return mavlink.MAVLink_command_long_message(
            VEHICLE_SYSID, VEHICLE_COMPID, c.command, confirmation, *c.params)

    def set_mode(self, mode: str) -> None:
        with self._lock:  # a mode we ask for is no take-over: watched from its first heartbeat
            self._wanted_mode, self._in_control = MODES[mode], False
        self.command(mavlink.MAV_CMD_DO_SET_MODE, mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED,
                     MODES[mode])

    def _setpoint(self, target: dict[str, float], t: float) -> None:
        msg = mavlink.MAVLink_set_position_target_local_ned_message(
            int(t * 1000) & 0xFFFFFFFF, VEHICLE_SYSID, VEHICLE_COMPID,
            mavlink.MAV_FRAME_LOCAL_NED, POSITION_AND_YAW, target["x"], target["y"],
            target["z"], 0, 0, 0, 0, 0, 0, target["yaw"], 0)
        self._send(msg)

    # -- the reader thread ------------------------------------------------------------------------
    def _reader(self) -> None:
        next_beat = {name: 0.0 for name in LINK_PERIOD}
        next_save = time.monotonic() + SAVE_PERIOD
        while not self._stop.is_set():
            count = 0
            while count < 500:  # a burst is bounded: the periodic work below still runs
                with self._io:
                    try:
                        msg = self.conn.recv_msg()
                    except (OSError, mavlink.MAVError) as exc:
                        log.debug("receive error: %s", exc)
                        msg = None
                if msg is None:
                    break
                count += 1
                try:
                    self._dispatch(msg)
                except Exception:  # one bad message must not stop the link
                    log.exception("could not handle %s", msg.get_type())
            now = time.monotonic()
            for name, period in LINK_PERIOD.items():
                if now >= next_beat[name] and self._seen.is_set():
                    self._send(self._link_message(name))
                    next_beat[name] = now + period
            self._check_link(now)
            self._retry(now)
            if self.signing is not None and now >= next_save:
                with self._io:
                    self._save_signing()
                next_save = now + SAVE_PERIOD
            if count == 0:
                try:
                    select.select([self.conn.fd], [], [], 0.02)
                except (OSError, ValueError):
                    time.sleep(0.02)

    def _save_signing(self) -> None:
        assert self.signing is not None
        try:
            self.signing.save()
        except OSError as exc:
            log.warning("could not save the signing timestamp: %s", exc)

    def _link_message(self, name: str) -> Any:
        if name == "HEARTBEAT":
            return mavlink.MAVLink_heartbeat_message(
                mavlink.MAV_TYPE_GCS, mavlink.MAV_AUTOPILOT_INVALID, 0, 0,
                mavlink.MAV_STATE_ACTIVE, 3)
        # neutral sticks: x, y, r centred, z (throttle) at mid-range 500, no buttons
        return mavlink.MAVLink_manual_control_message(VEHICLE_SYSID, 0, 0, 500, 0, 0)

    def _check_link(self, now: float) -> None:
        if self._seen.is_set() and not self._lost and \
                now - self.last_heartbeat > self.link_timeout:
            self._link_lost(f"no HEARTBEAT from the vehicle for {self.link_timeout:g} s")

    def _retry(self, now: float) -> None:
        again: list[tuple[Command, int]] = []
        with self._lock:
            for c in list(self._pending):
                if now - c.last_sent < ACK_TIMEOUT:
                    continue
                if c.tries >= ACK_TRIES or self._lost:
                    self._pending.remove(c)
                    log.warning("no COMMAND_ACK for command %d after %d tries", c.command,
                                c.tries)
                    c.done.set()
                    continue
                c.tries += 1
                c.last_sent = now
                again.append((c, c.tries - 1))
        for c, confirmation in again:
            self._send(self._command_long(c, confirmation))

    def _dispatch(self, msg: Any) -> None:
        kind = msg.get_type()
        if kind == "BAD_DATA":
            self.bad_data += 1
            return
        if msg.get_srcSystem() != VEHICLE_SYSID:
            return  # another ground station, or a router's own messages
        self.received += 1
        t_ms = getattr(msg, "time_boot_ms", None)
        with self._lock:
            if t_ms is not None:
                self._on_clock(t_ms / 1000.0)
            handler = getattr(self, f"_on_{kind.lower()}", None)
            if handler is not None:
                handler(msg)
            taken_over, self._taken_over = self._taken_over, ""
        if taken_over:
            self._link_lost(taken_over)

    # -- message handlers (reader thread, self._lock held) ---------------------------------------
    def _on_heartbeat(self, msg: Any) -> None:
        if msg.type == mavlink.MAV_TYPE_GCS:
            return
        self.last_heartbeat = time.monotonic()
        self.vehicle_signs = bool(msg.get_header().incompat_flags & mavlink.MAVLINK_IFLAG_SIGNED)
        mode, armed = msg.custom_mode, bool(msg.base_mode & mavlink.MAV_MODE_FLAG_SAFETY_ARMED)
        if self._in_control and (mode != self._wanted_mode or (self.arm and not armed)):
            # the vehicle left the mode we set (its failsafe) or disarmed on its own: the
            # mission no longer drives it
            said = next((text for severity, text in reversed(self.texts)
                         if severity <= mavlink.MAV_SEVERITY_CRITICAL), "")
            self._taken_over = (f"the vehicle took over: {_mode_name(self._wanted_mode)} -> "
                                f"{_mode_name(mode)}{'' if armed else ', disarmed'}"
                                + (f" ({said})" if said else ""))
            self._in_control = False
        elif (not self._in_control and self._wanted_mode is not None and not self._lost
              and mode == self._wanted_mode and (armed or not self.arm)):
            self._in_control = True
            self._controlled.set()
        self.mode, self.armed = mode, armed
        self._seen.set()

    def _on_command_ack(self, msg: Any) -> None:
        for c in self._pending:
            if c.command == msg.command:
                if msg.result == mavlink.MAV_RESULT_IN_PROGRESS:
                    return
                self._pending.remove(c)
                self.acks_received += 1
                self.ack_latencies.append(time.monotonic() - c.sent_at)
                self.results[c.command] = c.result = msg.result
                if msg.result != mavlink.MAV_RESULT_ACCEPTED:
                    log.warning("the vehicle answered command %d with %s", c.command,
                                _result_name(msg.result))
                c.done.set()
                return

    def _on_attitude(self, msg: Any) -> None:
        self.tel.yaw = msg.yaw

    def _on_local_position_ned(self, msg: Any) -> None:
        tel = self.tel
        tel.t, tel.x, tel.y, tel.z, tel.positioned = msg.time_boot_ms / 1000, msg.x, msg.y, \
            msg.z, True
        self._positioned.set()
        self._control()

    def _on_distance_sensor(self, msg: Any) -> None:
        tel = self.tel
        if not msg.min_distance <= msg.current_distance <= msg.max_distance:
            tel.wall_distance = None  # MAVLink's "nothing detected": max_distance + 1
            return
        q = list(msg.quaternion)
        bearing = 2 * math.atan2(q[3], q[0]) if msg.orientation == 100 and any(q) else 0.0
        tel.wall_distance, tel.wall_bearing = msg.current_distance / 100.0, wrap(bearing)
        normal = tel.yaw + tel.wall_bearing
        tel.wall_point = (tel.x + tel.wall_distance * math.cos(normal),
                          tel.y + tel.wall_distance * math.sin(normal))
        tel.wall_seen_at = msg.time_boot_ms / 1000

    def _on_statustext(self, msg: Any) -> None:
        text = msg.text if isinstance(msg.text, str) else msg.text.decode("utf-8", "replace")
        self.texts.append((msg.severity, text))
        log.info("vehicle says: %s", text)
        if msg.severity <= mavlink.MAV_SEVERITY_CRITICAL:
            for word, alarm in ALARM_TEXTS.items():
                if word in text.lower():
                    self.tel.alarms.add(alarm)

    def _on_scaled_pressure(self, msg: Any) -> None:  # the internal barometer (ArduSub)
        self.tel.temperature, self.tel.pressure = msg.temperature / 100, msg.press_abs / 1000

    # -- the behaviours the adapter runs ------------------------------------------------------
    def _control(self) -> None:
        """Update the active behaviours, pass their events on, send the merged setpoint."""
        tel = self.tel
        target: dict[str, float] = {}
        for name in sorted(self.behaviours, key=lambda n: PRIORITY.index(n)
                           if n in PRIORITY else 99):
            b = self.behaviours[name]
            if not b.active:
                continue
            for dof, value in b.update(tel).items():
                target.setdefault(dof, value)
            self._take_events(b)
        if self.behaviours["Surface"].active or not any(
                self.behaviours[n].active for n in PRIORITY):
            return
        full = {dof: target.get(dof, self._hold.get(dof, getattr(tel, dof)))
                for dof in ("x", "y", "z", "yaw")}
        changed = any(abs(full[d] - self._hold.get(d, math.inf)) > 0.01 for d in full)
        since = tel.t - self._setpoint_at
        if (changed and since >= SETPOINT_PERIOD) or since >= SETPOINT_REFRESH:
            self._hold, self._setpoint_at = full, tel.t
            self._setpoint(full, tel.t)

    def _take_events(self, b: Behaviour) -> None:
        for name, data in b.events:
            self._events.put(EventMessage(self._next_seq_locked(), self._vehicle_time_locked(),
                                          b.name, name, data))
        b.events.clear()

    # -- the clock --------------------------------------------------------------------------------
    def _on_clock(self, t: float) -> None:
        wall = time.monotonic()
        if t <= self._base_t:
            return
        if self._ref is None:
            self._ref = (t, wall)
        elif wall - self._ref[1] >= 0.2:  # the speed over the last fifth of a wall second
            self._speed = (t - self._ref[0]) / (wall - self._ref[1])
            self._ref = (t, wall)
        if not self._lost:
            self._clock_locked(t)

    # -- the Vehicle protocol ---------------------------------------------------------------------
    def send(self, action: ActionMessage) -> None:
        if self.conn is None:
            raise RuntimeError("MavlinkVehicle used outside its 'with' block")
        if self._lost:
            log.warning("link lost: action %s %s not sent", action.kind, action.behaviour)
            return
        self.sent += 1
        name, kind = action.behaviour, action.kind
        if (name, kind) in COMMANDS:
            self.command(COMMANDS[name, kind])
            return
        b = self.behaviours.get(name)
        if b is None:
            if (name, "enable") not in COMMANDS:
                log.warning("no MAVLink mapping for behaviour %s: action dropped", name)
                self.unknown_actions.append(name)
            return
        with self._lock:
            was_surfacing = self.behaviours["Surface"].active
            if kind == "enable":
                b.enable(action.params, self.tel)
            elif kind == "disable":
                b.active = False
            else:
                b.params.update(action.params)
            surfacing = self.behaviours["Surface"].active
            if surfacing and not was_surfacing:
                mode = "SURFACE"
            elif was_surfacing and not surfacing:
                mode = "GUIDED"  # back under the adapter's setpoints, from where it is now
                self._hold = {d: getattr(self.tel, d) for d in ("x", "y", "z", "yaw")}
            elif kind == "enable" and name in PRIORITY and not surfacing and \
                    self.mode != MODES["GUIDED"]:
                mode = "GUIDED"  # e.g. after the vehicle's own failsafe
            else:
                mode = ""
        if mode:  # before the setpoint: ArduSub ignores setpoints outside GUIDED
            self.set_mode(mode)
        with self._lock:
            if kind != "disable":
                self._setpoint_at = -math.inf  # the next position sends the new setpoint
                if self.tel.positioned:
                    self._control()
            self._take_events(b)


def _mode_name(mode: int | None) -> str:
    return MODE_NAMES.get(mode, str(mode)) if mode is not None else "?"


def _result_name(result: int | None) -> str:
    if result is None:
        return "no answer"
    entry = mavlink.enums["MAV_RESULT"].get(result)
    return entry.name if entry is not None else str(result)
