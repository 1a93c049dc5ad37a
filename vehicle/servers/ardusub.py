"""The simulated Ictineu served as an ArduSub-like MAVLink 2 vehicle (``mcl vehicle --mavlink``,
whose command line is in ``app/vehicle.py``).

    mcl vehicle --mavlink URL [--speed 10] [--seed 1] [--inject leak@600] [--no-wait]
                [--gcs-timeout 3] [--pilot-timeout 3] [--signing-key FILE]
                [--require-signing] [--log-level WARNING]

``URL`` is written as pymavlink writes it: ``udpout:HOST:PORT`` (send to a ground station
listening there, e.g. ``mcl run ... --vehicle mavlink:udpin:127.0.0.1:14550``), ``udpin:``
or ``udp:HOST:PORT`` (listen), ``tcp:HOST:PORT`` (connect) or ``tcpin:HOST:PORT`` (listen).
A bad URL, an unusable address or an unreadable key file is a one-line error, exit status 2.
When ready the vehicle prints ``vehicle auv ready on URL``; on SIGTERM or SIGINT it stops and
prints its survey summary (path length, wall area imaged, against the simulation's truth), its
command counts and, with signing, its signing counts.

Identity. MAVLink 2 only, dialect ardupilotmega; system 1, component 1 (AUTOPILOT1). The ground
station it obeys is system 255 (ArduSub's ``SYSID_MYGCS``).

Time. The simulated clock starts at the first HEARTBEAT from the ground station (at once with
``--no-wait``) and then runs at ``--speed`` times wall time, one stack tick (``DT`` = 0.05 s) at
a time, as ``mcl vehicle --zenoh`` does (:mod:`vehicle.servers.zenoh_server`). Every ``time_boot_ms``
carries the simulated clock (ms since it started), so a ground station follows the vehicle's
clock; telemetry rates are rates of that clock (as ArduPilot's SITL with a speed-up), at most one
message of each kind per tick. HEARTBEAT also goes out at least once per wall second (also while
the clock waits for a ground station). A stack tick costs about 0.5 ms here, so the vehicle
keeps up with ``--speed`` up to about 40 on a 2-core machine shared with the player; asked for
more, its clock falls behind wall time x speed (the player follows the clock it sends).

Heartbeat, telemetry (rates, frames) and the sonar wall as DISTANCE_SENSOR: see
:mod:`vehicle.servers.ardusub_telemetry`.

Commands. Every COMMAND_LONG (or COMMAND_INT) for system 1 gets a COMMAND_ACK: MAV_CMD_DO_SET_MODE
(param2 the mode number; SET_MODE messages too, acknowledged with command 11 as ArduPilot does),
MAV_CMD_COMPONENT_ARM_DISARM (arming FAILED while an internal temperature or pressure failsafe is
active, unless forced with param2 = 21196), MAV_CMD_SET_MESSAGE_INTERVAL, GET_MESSAGE_INTERVAL,
REQUEST_MESSAGE, MAV_CMD_IMAGE_START_CAPTURE / IMAGE_STOP_CAPTURE (the camera, the stack's
StartCamera), MAV_CMD_LOGGING_START / LOGGING_STOP (the stack's StartLogs); AUTO and CIRCLE (no
mission here) FAILED; any other command UNSUPPORTED.

Modes (armed; disarmed the vehicle only holds still, an approximation of idle thrusters):
GUIDED and POSHOLD hold the position where they started; in GUIDED SET_POSITION_TARGET_LOCAL_NED
(MAV_FRAME_LOCAL_NED) moves the hold point: position (any of x, y, z; the others kept) and yaw go
to the stack's GoTo behaviour (its own position controller); velocities (vx, vy, vz world, with
yaw or yaw_rate) are held for 3 s of simulated time, as ArduSub's guided velocity timeout.
Setpoints outside GUIDED, or disarmed, or in another frame are ignored (ArduSub does so) and
counted. SURFACE rises to the surface (the stack's Surface behaviour) and stays in SURFACE
there. MANUAL, STABILIZE, ACRO and ALT_HOLD fly MANUAL_CONTROL (x surge, y sway, z 500 neutral,
r yaw rate) as velocity demands.

Alarms (the stack's housing sensors, faults from ``--inject FAULT@SECONDS``): STATUSTEXT
:data:`LEAK_TEXT` ("Leak Detected", ArduSub's text), :data:`TEMPERATURE_TEXT` or
:data:`PRESSURE_TEXT` ("Internal temperature critical!", "Internal pressure critical!", ArduSub's
texts; above 50 degC and 1.5 bar, the stack's Alarms thresholds), severity CRITICAL, at once and
every 5 s of simulated time while it lasts; HEARTBEAT system_status CRITICAL. ArduSub's default
leak action is to warn only: the mission decides (its Alarms task surfaces).

Failsafes, on WALL time (they watch the real link): ground station — no HEARTBEAT from system
255 for ``--gcs-timeout`` s after one has been seen (ArduSub FS_GCS_TIMEOUT) — and pilot input —
no MANUAL_CONTROL for ``--pilot-timeout`` s while armed (FS_PILOT_TIMEOUT). While armed either
switches to SURFACE (ArduSub's FS_GCS_ENABLE = surface) with STATUSTEXT "MYGCS: 255, heartbeat
lost" (WARNING) or "Lost manual control" (CRITICAL), ArduSub's texts. The vehicle stays in
SURFACE until a ground station sets another mode; a failsafe re-arms when its input comes back.
As ArduSub's manual warns, any heartbeat from system 255 counts: MAVProxy routing between player
and vehicle sends its own, so through MAVProxy (without required signing, which rejects its
unsigned heartbeats) the pilot-input failsafe is the one that notices a player gone.

Signing (:mod:`aal.signing`): ``--signing-key FILE`` or ``$MCL_MAVLINK_KEY``
(64 hex digits, or a passphrase hashed as MAVProxy's ``signing setup``) signs everything sent
and rejects badly signed messages; ``--require-signing`` also rejects unsigned ones (except
RADIO_STATUS, as ArduPilot). The counts go out with every HEARTBEAT as NAMED_VALUE_INT
``SIG_OK`` (good signatures), ``SIG_UNSIGN`` (unsigned rejected), ``SIG_BAD`` (bad signatures
rejected), and are printed at exit. The signing timestamp is kept in
``$MCL_STATE_DIR`` (default ``~/.local/state/mcl``), saved every 5 s and at exit.
"""

from __future__ import annotations

import contextlib
import io
import logging
import math
import os
import queue
import socket
import threading
import time
from collections.abc import Callable, Iterable
from typing import Any

os.environ["MAVLINK20"] = "1"  # before pymavlink picks its dialect: MAVLink 2 only

from pymavlink import mavutil  # noqa: E402

import behaviours as bh  # noqa: E402
from aal import signing  # noqa: E402
from aal.mavlink import (  # noqa: E402
    GCS_SYSID,
    GCS_TEXT,
    LEAK_TEXT,
    MODE_NAMES,
    MODES,
    PILOT_TEXT,
    PRESSURE_TEXT,
    TEMPERATURE_TEXT,
    VEHICLE_SYSID,
    parse_url,
)
from aal.messages import ActionMessage  # noqa: E402
from behaviours.base import clamp, to_degrees, wrap  # noqa: E402
from vehicle.control.stack import DT, IctineuStack, StackConfig  # noqa: E402

from vehicle.servers.ardusub_telemetry import STREAMS, Streams, Telemetry  # noqa: E402

log = logging.getLogger(__name__)
mav = mavutil.mavlink

SYSID, COMPID = VEHICLE_SYSID, mav.MAV_COMP_ID_AUTOPILOT1
ACCEPTED, DENIED, FAILED, UNSUPPORTED = (int(mav.MAV_RESULT_ACCEPTED), int(mav.MAV_RESULT_DENIED),
                                         int(mav.MAV_RESULT_FAILED),
                                         int(mav.MAV_RESULT_UNSUPPORTED))
PILOT_MODES = {MODES[m] for m in ("MANUAL", "STABILIZE", "ACRO", "ALT_HOLD")}
HOLD_MODES = {MODES["GUIDED"], MODES["POSHOLD"]}
UNAVAILABLE_MODES = {MODES["AUTO"], MODES["CIRCLE"]}  # no mission, no circle here
FORCE_ARM = 21196  # param2 of MAV_CMD_COMPONENT_ARM_DISARM that skips the arming checks

ALARM_REPEAT = 5.0  # simulated s between repeats of an alarm's STATUSTEXT
MAX_TEMPERATURE = 50.0  # degC (FS_TEMP_MAX; the stack's Alarms default)
MAX_PRESSURE = 1.5  # bar inside the vessel (FS_PRESS_MAX; the stack's Alarms default)

GUIDED_VELOCITY_TIMEOUT = 3.0  # simulated s a velocity setpoint lasts
PILOT_SPEED, PILOT_YAW_RATE = 0.4, 0.3  # m/s and rad/s at full stick
MAX_SLEEP = 0.01  # wall s: the loop looks at its inbox at least this often
SAVE_PERIOD = 5.0  # wall s between saves of the signing timestamp
MOTION = ("GoTo", "WallInspection", "AchieveHeadDist", "Surface", "Velocity")


class Velocity(bh.Behaviour):
    """Velocity demands from outside the stack: guided velocity setpoints (world frame, for a
    few seconds) or the pilot's sticks (body frame). ArduSub's own, so not in the task library."""

    name = "Velocity"
    drives = ("x", "y", "z", "yaw")

    def on_update(self, p: bh.Perception) -> bh.Response:
        since = self.param("t", p.t)
        if "timeout" in self.params and p.t - since > self.param("timeout", 0.0):
            return bh.Response({dof: 0.0 for dof in bh.DOFS})
        vx, vy, vz = (self.param(k, 0.0) for k in ("vx", "vy", "vz"))
        if self.params.get("frame") == "world":  # world x, y into the body frame
            c, s = math.cos(p.psi), math.sin(p.psi)
            vx, vy = c * vx + s * vy, -s * vx + c * vy
        if "yaw" in self.params:  # hold a heading rather than a rate
            rate = clamp(0.4 * wrap(self.angle("yaw", 0.0) - p.psi), 0.3)
        else:
            rate = self.param("yaw_rate", 0.0)
        return bh.Response({"x": vx, "y": vy, "z": vz, "yaw": rate})


def check_url(url: str) -> str:
    """The URL if pymavlink can use it and its host resolves; ValueError saying why not."""
    try:
        _, host, port = parse_url(url)
    except ValueError as exc:
        raise ValueError(f"--mavlink {exc} (e.g. udpout:127.0.0.1:14550)") from None
    try:
        socket.getaddrinfo(host, port)
    except OSError as exc:
        raise ValueError(f"--mavlink {url!r}: host {host!r}: {exc.strerror or exc}") from None
    return url


class ArduSubVehicle:
    """The simulated stack behind an ArduSub-like MAVLink endpoint. :meth:`run` blocks until
    ``stop`` is set. One reader thread queues what arrives; the loop applies it between ticks."""

    def __init__(self, url: str, *, speed: float = 10.0, seed: int = 1,
                 faults: Iterable[tuple[str, float]] = (), gcs_timeout: float = 3.0,
                 pilot_timeout: float = 3.0, wait_for_gcs: bool = True,
                 signing_key: bytes | None = None, require_signing: bool = False,
                 stop: threading.Event | None = None,
                 ready: threading.Event | None = None) -> None:
        if not speed > 0:
            raise ValueError("speed must be positive")
        self.url, self.speed = url, float(speed)
        self.gcs_timeout, self.pilot_timeout = gcs_timeout, pilot_timeout
        self.wait_for_gcs = wait_for_gcs
        self.signing_key, self.require_signing = signing_key, require_signing
        self.stop = stop or threading.Event()
        self.ready = ready or threading.Event()
        self.stack = IctineuStack(StackConfig(seed=seed, faults=list(faults)))
        self.stack.behaviours["Velocity"] = Velocity()
        self.streams = Streams(STREAMS)
        self.telemetry = Telemetry(self)
        self.mode, self.armed = MODES["MANUAL"], False
        self.conn: Any = None
        self.signing: signing.SigningState | None = None
        self._inbox: queue.Queue[Any] = queue.Queue()
        self._send_lock = threading.Lock()
        self._seq = 0
        self.gcs_heard: float | None = None  # wall (monotonic) time of the last GCS heartbeat
        self.pilot_heard: float | None = None  # ... of the last MANUAL_CONTROL
        self.armed_at = 0.0
        self.failsafe = {"gcs": False, "pilot": False}
        self.alarm_sent: dict[str, float] = {}  # alarm -> simulated time of its last text
        self.counts = {"commands": 0, "setpoints": 0, "setpoints_ignored": 0}
        self._last_heartbeat = -math.inf  # wall

    # -- sending (serialised) -------------------------------------------------------------------
    def send(self, name: str, *args: Any, **kwargs: Any) -> None:
        """Send one message (``name`` as in pymavlink's ``<name>_send``)."""
        with self._send_lock:
            getattr(self.conn.mav, f"{name}_send")(*args, **kwargs)

    def text(self, severity: int, text: str, *, repeat: bool = False) -> None:
        log.log(logging.INFO if repeat else logging.WARNING, "STATUSTEXT %s", text)
        self.send("statustext", severity, text.encode("ascii")[:50])

    def ack(self, command: int, result: int, target: tuple[int, int] = (GCS_SYSID, 0)) -> None:
        self.send("command_ack", command, result, 0, 0, target[0], target[1])

    @property
    def time_boot_ms(self) -> int:
        return int(round(self.stack.t * 1000))

    # -- the run ----------------------------------------------------------------------------------
    def run(self) -> None:
        chatter = io.StringIO()  # pymavlink prints its retries; keep stdout for our lines
        try:
            with contextlib.redirect_stdout(chatter):
                self.conn = mavutil.mavlink_connection(
                    self.url, source_system=SYSID, source_component=COMPID,
                    dialect="ardupilotmega")
        finally:
            log.debug("pymavlink: %s", chatter.getvalue().strip())
        try:
            if self.signing_key is not None:
                self.signing = signing.enable(
                    self.conn, self.signing_key, require=self.require_signing, link_id=0,
                    timestamp_file=signing.default_timestamp_file(self.signing_key, "vehicle"))
            reader = threading.Thread(target=self._read, name="mavlink-reader", daemon=True)
            reader.start()
            self.ready.set()
            log.info("vehicle ready on %s", self.url)
            try:
                self._loop()
            finally:
                self.stop.set()
                reader.join(timeout=2.0)
                if self.signing is not None:
                    with self._send_lock:
                        self.signing.save()
        finally:
            self.conn.close()

    def _read(self) -> None:
        """The reader thread: every message received goes into the inbox, nothing else."""
        while not self.stop.is_set():
            try:
                msg = self.conn.recv_match(blocking=True, timeout=0.05)
            except (OSError, mavutil.mavlink.MAVError) as exc:
                log.warning("receive failed: %s", exc)
                self.stop.wait(0.05)
                continue
            if msg is not None and msg.get_type() != "BAD_DATA":
                self._inbox.put(msg)

    def _loop(self) -> None:
        stack = self.stack
        next_save = time.monotonic() + SAVE_PERIOD
        while not self.stop.is_set():  # paused at t = 0 until a ground station is heard
            self._handle_inbox()
            self._heartbeat_floor()
            if self.gcs_heard is not None or not self.wait_for_gcs:
                break
            self.stop.wait(MAX_SLEEP)
        wall0, t0 = time.monotonic(), stack.t
        while not self.stop.is_set():
            self._handle_inbox()
            now = time.monotonic()
            self._check_failsafes(now)
            if stack.t + DT <= t0 + (now - wall0) * self.speed:  # a tick is due
                for event in stack.due(stack.t + DT):
                    log.debug("stack event %s", event.event)
                self._check_alarms()
                for name in self.streams.due(stack.t):
                    self.telemetry.send(name)
            else:
                due_at = wall0 + (stack.t + DT - t0) / self.speed
                time.sleep(min(MAX_SLEEP, max(0.0, due_at - now)))
            self._heartbeat_floor()
            if self.signing is not None and now >= next_save:
                with self._send_lock:
                    self.signing.save()
                next_save = now + SAVE_PERIOD

    def _heartbeat_floor(self) -> None:
        if time.monotonic() - self._last_heartbeat >= 1.0:
            self.telemetry.send("HEARTBEAT")

    # -- what arrives ---------------------------------------------------------------------------
    def _handle_inbox(self) -> None:
        while True:
            try:
                msg = self._inbox.get_nowait()
            except queue.Empty:
                return
            handler = self._handlers.get(msg.get_type())
            if handler is not None:
                handler(self, msg)

    def _on_heartbeat(self, msg: Any) -> None:
        if msg.get_srcSystem() == GCS_SYSID and msg.type == mav.MAV_TYPE_GCS:
            self.gcs_heard = time.monotonic()
            if self.failsafe["gcs"]:
                log.warning("ground station is back")
            self.failsafe["gcs"] = False

    def _on_manual_control(self, msg: Any) -> None:
        if msg.target != SYSID:
            return
        self.pilot_heard = time.monotonic()
        self.failsafe["pilot"] = False
        if self.armed and self.mode in PILOT_MODES:
            sticks = {"vx": msg.x / 1000 * PILOT_SPEED, "vy": msg.y / 1000 * PILOT_SPEED,
                      "vz": -(msg.z - 500) / 500 * PILOT_SPEED,
                      "yaw_rate": msg.r / 1000 * PILOT_YAW_RATE}
            self._action("configure", "Velocity", {"frame": "body", **sticks})

    def _on_set_mode(self, msg: Any) -> None:
        if msg.target_system != SYSID:
            return
        result = self.set_mode(msg.custom_mode)
        self.ack(mav.MAVLINK_MSG_ID_SET_MODE, result, (msg.get_srcSystem(), msg.get_srcComponent()))

    def _on_command(self, msg: Any) -> None:
        if msg.target_system not in (0, SYSID) or msg.target_component not in (0, COMPID):
            return
        self.counts["commands"] += 1
        params = [msg.param1, msg.param2, msg.param3, msg.param4]
        try:
            result = self.command(msg.command, params)
        except (ValueError, OverflowError):  # NaN or out-of-range parameters
            result = DENIED
        self.ack(msg.command, result, (msg.get_srcSystem(), msg.get_srcComponent()))
        if msg.command == mav.MAV_CMD_REQUEST_MESSAGE and result == ACCEPTED:
            self.telemetry.send(self.streams.ids[int(params[0])])
        if msg.command == mav.MAV_CMD_GET_MESSAGE_INTERVAL and result == ACCEPTED:
            self.send("message_interval", int(params[0]), self.streams.get_us(int(params[0])))

    def _on_setpoint(self, msg: Any) -> None:
        if msg.target_system != SYSID:
            return
        self.counts["setpoints"] += 1
        if not (self.armed and self.mode == MODES["GUIDED"]
                and msg.coordinate_frame == mav.MAV_FRAME_LOCAL_NED):
            self.counts["setpoints_ignored"] += 1  # as ArduSub: only in GUIDED, armed
            return
        self.guided_setpoint(msg.type_mask, (msg.x, msg.y, msg.z), (msg.vx, msg.vy, msg.vz),
                             msg.yaw, msg.yaw_rate)

    _handlers: dict[str, Callable[[ArduSubVehicle, Any], None]] = {
        "HEARTBEAT": _on_heartbeat, "MANUAL_CONTROL": _on_manual_control,
        "SET_MODE": _on_set_mode, "COMMAND_LONG": _on_command, "COMMAND_INT": _on_command,
        "SET_POSITION_TARGET_LOCAL_NED": _on_setpoint,
    }

    # -- commands, modes and setpoints ----------------------------------------------------------
    def command(self, command: int, p: list[float]) -> int:
        """Carry out one command; its MAV_RESULT."""
        if command == mav.MAV_CMD_DO_SET_MODE:
            return self.set_mode(int(p[1]))
        if command == mav.MAV_CMD_COMPONENT_ARM_DISARM:
            return self.arm(p[0] == 1, force=int(p[1]) == FORCE_ARM)
        if command == mav.MAV_CMD_SET_MESSAGE_INTERVAL:
            ok = self.streams.set(int(p[0]), p[1])
            return ACCEPTED if ok else FAILED
        if command in (mav.MAV_CMD_GET_MESSAGE_INTERVAL, mav.MAV_CMD_REQUEST_MESSAGE):
            ok = int(p[0]) in self.streams.ids
            return ACCEPTED if ok else FAILED
        switches = {mav.MAV_CMD_IMAGE_START_CAPTURE: ("enable", "StartCamera"),
                    mav.MAV_CMD_IMAGE_STOP_CAPTURE: ("disable", "StartCamera"),
                    mav.MAV_CMD_LOGGING_START: ("enable", "StartLogs"),
                    mav.MAV_CMD_LOGGING_STOP: ("disable", "StartLogs")}
        if command in switches:
            kind, behaviour = switches[command]
            if (kind == "enable") != self.stack.behaviours[behaviour].active:
                self._action(kind, behaviour, {})
            return ACCEPTED
        return UNSUPPORTED

    def set_mode(self, number: int) -> int:
        if number not in MODE_NAMES or number in UNAVAILABLE_MODES:
            return FAILED
        log.info("mode %s", MODE_NAMES[number])
        self.mode = number
        self._apply_mode()
        return ACCEPTED

    def arm(self, arm: bool, *, force: bool = False) -> int:
        if arm and not self.armed:
            h = self.stack.housing
            if not force and (h["temperature"] > MAX_TEMPERATURE or h["pressure"] > MAX_PRESSURE):
                return FAILED  # ArduSub's arming checks
            self.armed_at = time.monotonic()
            self.failsafe["pilot"] = False
        if arm != self.armed:
            self.armed = arm
            self._apply_mode()
        return ACCEPTED

    def _apply_mode(self) -> None:
        """Switch the stack's behaviours to what the mode does (nothing moves disarmed)."""
        for name in MOTION:
            if self.stack.behaviours[name].active:
                self._action("disable", name, {})
        if not self.armed:
            return
        p = self.stack.perception()
        if self.mode == MODES["SURFACE"]:
            self._action("enable", "Surface", {})
        elif self.mode in HOLD_MODES:
            self._action("enable", "GoTo", {"x": p.x, "y": p.y, "z": p.z,
                                            "yaw": to_degrees(p.psi), "tolerance": 0.0})
        elif self.mode in PILOT_MODES:
            self._action("enable", "Velocity", {"frame": "body"})

    def guided_setpoint(self, mask: int, position: tuple[float, float, float],
                        velocity: tuple[float, float, float], yaw: float,
                        yaw_rate: float) -> None:
        """SET_POSITION_TARGET_LOCAL_NED in GUIDED: a position (GoTo) or a velocity."""
        bits = mav.POSITION_TARGET_TYPEMASK_X_IGNORE, mav.POSITION_TARGET_TYPEMASK_Y_IGNORE, \
            mav.POSITION_TARGET_TYPEMASK_Z_IGNORE
        vbits = mav.POSITION_TARGET_TYPEMASK_VX_IGNORE, mav.POSITION_TARGET_TYPEMASK_VY_IGNORE, \
            mav.POSITION_TARGET_TYPEMASK_VZ_IGNORE
        use_yaw = not mask & mav.POSITION_TARGET_TYPEMASK_YAW_IGNORE
        use_rate = not mask & mav.POSITION_TARGET_TYPEMASK_YAW_RATE_IGNORE
        values = [*position, *velocity, yaw, yaw_rate]
        if not all(math.isfinite(v) for v in values):
            self.counts["setpoints_ignored"] += 1
            return
        goto = self.stack.behaviours["GoTo"]
        if all(mask & b for b in bits) and not all(mask & b for b in vbits):
            params: dict[str, Any] = {"frame": "world", "t": self.stack.t,
                                      "timeout": GUIDED_VELOCITY_TIMEOUT}
            params.update({k: v for k, v, b in zip(("vx", "vy", "vz"), velocity, vbits)
                           if not mask & b})
            if use_yaw:
                params["yaw"] = to_degrees(yaw)
            elif use_rate:
                params["yaw_rate"] = yaw_rate
            if goto.active:
                self._action("disable", "GoTo", {})
            self._action("enable", "Velocity", params)
            return
        p = self.stack.perception()
        target = dict(goto.params) if goto.active else {
            "x": p.x, "y": p.y, "z": p.z, "yaw": to_degrees(p.psi)}
        target.update({k: v for k, v, b in zip("xyz", position, bits) if not mask & b})
        if use_yaw:
            target["yaw"] = to_degrees(yaw)
        target["tolerance"] = 0.0
        if self.stack.behaviours["Velocity"].active:
            self._action("disable", "Velocity", {})
        self._action("enable", "GoTo", target)

    def _action(self, kind: str, behaviour: str, params: dict[str, Any]) -> None:
        self._seq += 1
        t = self.stack.t
        self.stack.on_action(ActionMessage(self._seq, t, "ardusub", MODE_NAMES[self.mode], kind,
                                           behaviour, params), t)

    # -- failsafes and alarms --------------------------------------------------------------------
    def _check_failsafes(self, now: float) -> None:
        gcs, pilot = self.gcs_heard, max(self.pilot_heard or 0.0, self.armed_at)
        if gcs is not None and not self.failsafe["gcs"] and now - gcs > self.gcs_timeout:
            self.failsafe["gcs"] = True
            self.text(mav.MAV_SEVERITY_WARNING, GCS_TEXT)
            if self.armed:
                self.set_mode(MODES["SURFACE"])
        if self.armed and not self.failsafe["pilot"] and now - pilot > self.pilot_timeout:
            self.failsafe["pilot"] = True
            self.text(mav.MAV_SEVERITY_CRITICAL, PILOT_TEXT)
            self.set_mode(MODES["SURFACE"])

    def alarms(self) -> dict[str, bool]:
        h = self.stack.housing
        return {LEAK_TEXT: bool(h["leak"]), TEMPERATURE_TEXT: h["temperature"] > MAX_TEMPERATURE,
                PRESSURE_TEXT: h["pressure"] > MAX_PRESSURE}

    def _check_alarms(self) -> None:
        t = self.stack.t
        for text, on in self.alarms().items():
            if not on:
                self.alarm_sent.pop(text, None)
            elif t - self.alarm_sent.get(text, -math.inf) >= ALARM_REPEAT - 1e-9:
                self.text(mav.MAV_SEVERITY_CRITICAL, text, repeat=text in self.alarm_sent)
                self.alarm_sent[text] = t

    # -- the end --------------------------------------------------------------------------------
    def summary(self) -> list[str]:
        """What the run did, against the simulation's truth, for the operator."""
        s = self.stack.survey.summary()
        lines = [f"vehicle auv stopped after {self.stack.t:.1f} s of simulated time "
                 f"({self.counts['commands']} commands, {self.counts['setpoints']} setpoints, "
                 f"{self.counts['setpoints_ignored']} ignored)",
                 f"  path {s['path_length_m']} m; wall imaged {s['wall_area_imaged_m2']} m² in "
                 f"{s['images']} images, {100 * s['share_seen_twice']:.0f} % of it in two or more",
                 f"  navigator error {s['navigator_rms_m']} m RMS (USBL fixes {s['usbl_fixes']}, "
                 f"{s['usbl_rejected']} rejected)"]
        on = sorted(n for n, b in self.stack.behaviours.items() if b.active)
        lines.append(f"  behaviours on at exit: {', '.join(on) or 'none'} "
                     f"(mode {MODE_NAMES.get(self.mode, self.mode)}, "
                     f"{'armed' if self.armed else 'disarmed'})")
        if self.signing is not None:
            c = self.signing.counts()
            lines.append(f"  signing: {c['signed']} signed accepted, {c['unsigned']} unsigned "
                         f"accepted, {c['rejected_unsigned']} unsigned rejected, "
                         f"{c['rejected_bad']} badly signed rejected")
        return lines
