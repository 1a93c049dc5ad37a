"""The autopilot of the ArduSub-like vehicle (:mod:`vehicle.servers.ardusub`): its modes, arming,
commands, guided setpoints, failsafes and alarms, on the simulated stack. The link (what
arrives, what is sent, the clock) is :class:`vehicle.servers.ardusub.ArduSubVehicle`'s, which
is this autopilot served over MAVLink.

Commands (:meth:`ArduSubAutopilot.command`, each answered with its MAV_RESULT):
MAV_CMD_DO_SET_MODE (param2 the mode number; SET_MODE messages too, acknowledged with command
11 as ArduPilot does), MAV_CMD_COMPONENT_ARM_DISARM (arming FAILED while an internal
temperature or pressure failsafe is active, unless forced with param2 = 21196),
MAV_CMD_SET_MESSAGE_INTERVAL, GET_MESSAGE_INTERVAL, REQUEST_MESSAGE (the link's streams),
MAV_CMD_IMAGE_START_CAPTURE / IMAGE_STOP_CAPTURE (the stack's behaviours that switch the
camera, ``Behaviour.switches``: StartCamera), MAV_CMD_LOGGING_START / LOGGING_STOP (those that
switch the logs: StartLogs); AUTO and CIRCLE (no mission here) FAILED; any other command
UNSUPPORTED.

Modes (armed; disarmed the vehicle only holds still, an approximation of idle thrusters: every
behaviour that drives a degree of freedom is switched off, whatever its name, :meth:`moving`):
GUIDED and POSHOLD hold the position where they started; in GUIDED SET_POSITION_TARGET_LOCAL_NED
(MAV_FRAME_LOCAL_NED) moves the hold point: position (any of x, y, z; the others kept) and yaw go
to the stack's GoTo behaviour (its own position controller); velocities (vx, vy, vz world, with
yaw or yaw_rate) are held for 3 s of simulated time, as ArduSub's guided velocity timeout.
Setpoints outside GUIDED, or disarmed, or in another frame are ignored (ArduSub does so) and
counted. SURFACE rises to the surface (the stack's Surface behaviour) and stays in SURFACE
there. MANUAL, STABILIZE, ACRO and ALT_HOLD fly MANUAL_CONTROL (x surge, y sway, z 500 neutral,
r yaw rate) as velocity demands (:class:`Velocity`, ArduSub's own behaviour).

Alarms (the stack's housing sensors, faults from ``--inject FAULT@SECONDS``): STATUSTEXT
``LEAK_TEXT`` ("Leak Detected", ArduSub's text), ``TEMPERATURE_TEXT`` or ``PRESSURE_TEXT``
("Internal temperature critical!", "Internal pressure critical!", ArduSub's texts; above
50 degC and 1.5 bar, the stack's Alarms thresholds), severity CRITICAL, at once and every 5 s
of simulated time while it lasts; HEARTBEAT system_status CRITICAL. ArduSub's default leak
action is to warn only: the mission decides (its Alarms task surfaces).

Failsafes, on WALL time (they watch the real link): ground station — no HEARTBEAT from system
255 for ``--gcs-timeout`` s after one has been seen (ArduSub FS_GCS_TIMEOUT) — and pilot input —
no MANUAL_CONTROL for ``--pilot-timeout`` s while armed (FS_PILOT_TIMEOUT). While armed either
switches to SURFACE (ArduSub's FS_GCS_ENABLE = surface) with STATUSTEXT "MYGCS: 255, heartbeat
lost" (WARNING) or "Lost manual control" (CRITICAL), ArduSub's texts. The vehicle stays in
SURFACE until a ground station sets another mode; a failsafe re-arms when its input comes back.
As ArduSub's manual warns, any heartbeat from system 255 counts: MAVProxy routing between player
and vehicle sends its own, so through MAVProxy (without required signing, which rejects its
unsigned heartbeats) the pilot-input failsafe is the one that notices a player gone.
"""

from __future__ import annotations

import logging
import math
import time
from typing import Any

from pymavlink.dialects.v20 import ardupilotmega as mav

import behaviours as bh
from aal.mavlink import (
    GCS_TEXT,
    LEAK_TEXT,
    MODE_NAMES,
    MODES,
    PILOT_TEXT,
    PRESSURE_TEXT,
    TEMPERATURE_TEXT,
)
from aal.messages import ActionMessage
from behaviours.base import clamp, to_degrees, wrap
from vehicle.control.stack import IctineuStack

log = logging.getLogger(__name__)

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

# the commands that switch a device: MAV_CMD -> (action, the device, Behaviour.switches)
DEVICE_COMMANDS = {int(mav.MAV_CMD_IMAGE_START_CAPTURE): ("enable", "camera"),
                   int(mav.MAV_CMD_IMAGE_STOP_CAPTURE): ("disable", "camera"),
                   int(mav.MAV_CMD_LOGGING_START): ("enable", "logs"),
                   int(mav.MAV_CMD_LOGGING_STOP): ("disable", "logs")}


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


class ArduSubAutopilot:
    """ArduSub's modes, arming, commands, setpoints, failsafes and alarms on a simulated stack
    (which gets ArduSub's own :class:`Velocity` beside the registry's behaviours). The link's
    side, :meth:`text` (a STATUSTEXT), is the subclass's."""

    def __init__(self, stack: IctineuStack, *, gcs_timeout: float = 3.0,
                 pilot_timeout: float = 3.0) -> None:
        self.stack = stack
        self.stack.behaviours["Velocity"] = Velocity()
        self.gcs_timeout, self.pilot_timeout = gcs_timeout, pilot_timeout
        self.mode, self.armed = MODES["MANUAL"], False
        self.gcs_heard: float | None = None  # wall (monotonic) time of the last GCS heartbeat
        self.pilot_heard: float | None = None  # ... of the last MANUAL_CONTROL
        self.armed_at = 0.0
        self.failsafe = {"gcs": False, "pilot": False}
        self.alarm_sent: dict[str, float] = {}  # alarm -> simulated time of its last text
        self.counts = {"commands": 0, "setpoints": 0, "setpoints_ignored": 0}
        self._seq = 0

    def text(self, severity: int, text: str, *, repeat: bool = False) -> None:
        """Say ``text`` to the ground station (STATUSTEXT): the link's."""
        raise NotImplementedError

    def moving(self) -> list[str]:
        """The stack's behaviours that move the vehicle (each drives a degree of freedom: the
        registry's and ArduSub's own Velocity), by name: what a change of mode or a disarm
        switches off."""
        return [name for name, b in self.stack.behaviours.items() if b.drives]

    # -- commands, modes and setpoints ----------------------------------------------------------
    def command(self, command: int, p: list[float]) -> int:
        """Carry out one command; its MAV_RESULT (the streams' commands are the link's)."""
        if command == mav.MAV_CMD_DO_SET_MODE:
            return self.set_mode(int(p[1]))
        if command == mav.MAV_CMD_COMPONENT_ARM_DISARM:
            return self.arm(p[0] == 1, force=int(p[1]) == FORCE_ARM)
        if command in DEVICE_COMMANDS:
            kind, device = DEVICE_COMMANDS[command]
            for name, b in self.stack.behaviours.items():
                if b.switches == device and (kind == "enable") != b.active:
                    self.act(kind, name, {})
            return ACCEPTED
        return UNSUPPORTED

    def set_mode(self, number: int) -> int:
        if number not in MODE_NAMES or number in UNAVAILABLE_MODES:
            return FAILED
        log.info("mode %s", MODE_NAMES[number])
        self.mode = number
        self.apply_mode()
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
            self.apply_mode()
        return ACCEPTED

    def apply_mode(self) -> None:
        """Switch the stack's behaviours to what the mode does (nothing moves disarmed)."""
        for name in self.moving():
            if self.stack.behaviours[name].active:
                self.act("disable", name, {})
        if not self.armed:
            return
        p = self.stack.perception()
        if self.mode == MODES["SURFACE"]:
            self.act("enable", "Surface", {})
        elif self.mode in HOLD_MODES:
            self.act("enable", "GoTo", {"x": p.x, "y": p.y, "z": p.z,
                                        "yaw": to_degrees(p.psi), "tolerance": 0.0})
        elif self.mode in PILOT_MODES:
            self.act("enable", "Velocity", {"frame": "body"})

    def pilot(self, x: float, y: float, z: float, r: float) -> None:
        """MANUAL_CONTROL's sticks (x, y, r in -1000..1000; z 0..1000, 500 neutral): velocity
        demands in the pilot's modes, armed."""
        self.pilot_heard = time.monotonic()
        self.failsafe["pilot"] = False
        if self.armed and self.mode in PILOT_MODES:
            sticks = {"vx": x / 1000 * PILOT_SPEED, "vy": y / 1000 * PILOT_SPEED,
                      "vz": -(z - 500) / 500 * PILOT_SPEED, "yaw_rate": r / 1000 * PILOT_YAW_RATE}
            self.act("configure", "Velocity", {"frame": "body", **sticks})

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
                self.act("disable", "GoTo", {})
            self.act("enable", "Velocity", params)
            return
        p = self.stack.perception()
        target = dict(goto.params) if goto.active else {
            "x": p.x, "y": p.y, "z": p.z, "yaw": to_degrees(p.psi)}
        target.update({k: v for k, v, b in zip("xyz", position, bits) if not mask & b})
        if use_yaw:
            target["yaw"] = to_degrees(yaw)
        target["tolerance"] = 0.0
        if self.stack.behaviours["Velocity"].active:
            self.act("disable", "Velocity", {})
        self.act("enable", "GoTo", target)

    def act(self, kind: str, behaviour: str, params: dict[str, Any]) -> None:
        """Enable, disable or configure one of the stack's behaviours, now."""
        self._seq += 1
        t = self.stack.t
        self.stack.on_action(ActionMessage(self._seq, t, "ardusub", MODE_NAMES[self.mode], kind,
                                           behaviour, params), t)

    # -- failsafes and alarms --------------------------------------------------------------------
    def check_failsafes(self, now: float) -> None:
        """The ground station's and the pilot's failsafes at wall time ``now``."""
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

    def check_alarms(self) -> None:
        """Say each alarm on, at once and every :data:`ALARM_REPEAT` s while it lasts."""
        t = self.stack.t
        for text, on in self.alarms().items():
            if not on:
                self.alarm_sent.pop(text, None)
            elif t - self.alarm_sent.get(text, -math.inf) >= ALARM_REPEAT - 1e-9:
                self.text(mav.MAV_SEVERITY_CRITICAL, text, repeat=text in self.alarm_sent)
                self.alarm_sent[text] = t
