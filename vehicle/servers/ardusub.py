"""The simulated Ictineu served as an ArduSub-like MAVLink 2 vehicle (``mcl vehicle --mavlink``,
whose command line is in ``app/vehicle.py``).

    mcl vehicle --mavlink URL [--speed 10] [--seed 1] [--inject leak@600] [--no-wait]
                [--gcs-timeout 3] [--pilot-timeout 3] [--signing-key FILE]
                [--require-signing] [--log-level WARNING]

``URL`` is written as pymavlink writes it: ``udpout:HOST:PORT`` (send to a ground station
listening there, e.g. ``mcl run ... --vehicle mavlink:udpin:127.0.0.1:14550``), ``udpin:``
or ``udp:HOST:PORT`` (listen), ``tcp:HOST:PORT`` (connect) or ``tcpin:HOST:PORT`` (listen).
A bad URL, an unusable address or an unreadable key file is a one-line error, exit status 2.
Listening (``udpin:``), it sends only to the ground station whose messages it accepted
(:class:`aal.mavlink_udp.PeerUdp`).
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

Commands, modes, guided setpoints, alarms and failsafes: the autopilot's,
:mod:`vehicle.servers.ardusub_autopilot`. Every COMMAND_LONG (or COMMAND_INT) for system 1 gets
a COMMAND_ACK; MAV_CMD_SET_MESSAGE_INTERVAL, GET_MESSAGE_INTERVAL and REQUEST_MESSAGE are
answered here, from the telemetry's streams.

Signing (:mod:`aal.signing`): ``--signing-key FILE`` or ``$MCL_MAVLINK_KEY``
(64 hex digits, or a passphrase hashed as MAVProxy's ``signing setup``) signs everything sent
and rejects badly signed messages; ``--require-signing`` also rejects unsigned ones (except
RADIO_STATUS, as ArduPilot). The counts go out with every HEARTBEAT as NAMED_VALUE_INT
``SIG_OK`` (good signatures), ``SIG_UNSIGN`` (unsigned rejected), ``SIG_BAD`` (bad signatures
rejected), and are printed at exit. The signing timestamp is kept in
``$MCL_STATE_DIR`` (default ``~/.local/state/mcl``), saved every 5 s and at exit. A vehicle
that lost that state refuses every message signed more than 2 s before it started (its clock
at start is the floor, :data:`aal.signing.CLOCK_SKEW`): a captured session cannot be replayed
at it after a restart; the summary counts them ("of them signed before it started").
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

from aal import mavlink_udp, signing  # noqa: E402
from aal.mavlink import GCS_SYSID, MODE_NAMES, MODES, VEHICLE_SYSID, parse_url  # noqa: E402
# the autopilot's texts, as the tests and the docs look them up here
from aal.mavlink import GCS_TEXT as GCS_TEXT  # noqa: E402
from aal.mavlink import LEAK_TEXT as LEAK_TEXT  # noqa: E402
from aal.mavlink import PILOT_TEXT as PILOT_TEXT  # noqa: E402
from vehicle.control.stack import DT, IctineuStack, StackConfig  # noqa: E402

from vehicle.servers.ardusub_autopilot import ACCEPTED, DENIED, FAILED, ArduSubAutopilot  # noqa: E402
from vehicle.servers.ardusub_telemetry import STREAMS, Streams, Telemetry  # noqa: E402

log = logging.getLogger(__name__)
mav = mavutil.mavlink

SYSID, COMPID = VEHICLE_SYSID, mav.MAV_COMP_ID_AUTOPILOT1
MAX_SLEEP = 0.01  # wall s: the loop looks at its inbox at least this often
SAVE_PERIOD = 5.0  # wall s between saves of the signing timestamp
STREAM_COMMANDS = (mav.MAV_CMD_SET_MESSAGE_INTERVAL, mav.MAV_CMD_GET_MESSAGE_INTERVAL,
                   mav.MAV_CMD_REQUEST_MESSAGE)


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


class ArduSubVehicle(ArduSubAutopilot):
    """The simulated stack and its ArduSub-like autopilot behind a MAVLink endpoint. :meth:`run`
    blocks until ``stop`` is set. One reader thread queues what arrives; the loop applies it
    between ticks."""

    def __init__(self, url: str, *, speed: float = 10.0, seed: int = 1,
                 faults: Iterable[tuple[str, float]] = (), gcs_timeout: float = 3.0,
                 pilot_timeout: float = 3.0, wait_for_gcs: bool = True,
                 signing_key: bytes | None = None, require_signing: bool = False,
                 stop: threading.Event | None = None,
                 ready: threading.Event | None = None) -> None:
        if not speed > 0:
            raise ValueError("speed must be positive")
        super().__init__(IctineuStack(StackConfig(seed=seed, faults=list(faults))),
                         gcs_timeout=gcs_timeout, pilot_timeout=pilot_timeout)
        self.url, self.speed = url, float(speed)
        self.wait_for_gcs = wait_for_gcs
        self.signing_key, self.require_signing = signing_key, require_signing
        self.stop = stop or threading.Event()
        self.ready = ready or threading.Event()
        self.streams = Streams(STREAMS)
        self.telemetry = Telemetry(self)
        self.conn: Any = None
        self.signing: signing.SigningState | None = None
        self._inbox: queue.Queue[Any] = queue.Queue()
        self._send_lock = threading.Lock()
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
                self.conn = mavlink_udp.connect(
                    self.url, source_system=SYSID, source_component=COMPID,
                    peer_system=GCS_SYSID)
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
            self.check_failsafes(now)
            if stack.t + DT <= t0 + (now - wall0) * self.speed:  # a tick is due
                for event in stack.due(stack.t + DT):
                    log.debug("stack event %s", event.event)
                self.check_alarms()
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
        self.pilot(msg.x, msg.y, msg.z, msg.r)

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

    # -- the streams' commands (the others are the autopilot's) ---------------------------------
    def command(self, command: int, p: list[float]) -> int:
        """Carry out one command; its MAV_RESULT."""
        if command == mav.MAV_CMD_SET_MESSAGE_INTERVAL:
            ok = self.streams.set(int(p[0]), p[1])
            return ACCEPTED if ok else FAILED
        if command in STREAM_COMMANDS:  # GET_MESSAGE_INTERVAL, REQUEST_MESSAGE
            ok = int(p[0]) in self.streams.ids
            return ACCEPTED if ok else FAILED
        return super().command(command, p)

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
                         f"{c['rejected_bad']} badly signed rejected "
                         f"({self.signing.rejected_old} of them signed before it started)")
        return lines
