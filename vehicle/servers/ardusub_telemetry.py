"""The telemetry of the ArduSub-like vehicle (:mod:`vehicle.servers.ardusub`): one method a
MAVLink message, and when each is due (:class:`Streams`, MAV_CMD_SET_MESSAGE_INTERVAL).

Heartbeat. ``type`` MAV_TYPE_SUBMARINE, ``autopilot`` MAV_AUTOPILOT_ARDUPILOTMEGA, ``base_mode``
CUSTOM_MODE_ENABLED | MANUAL_INPUT_ENABLED | STABILIZE_ENABLED (not in MANUAL/ACRO) |
GUIDED_ENABLED (GUIDED) | SAFETY_ARMED (armed); ``custom_mode`` the ArduSub mode number
(STABILIZE 0, ACRO 1, ALT_HOLD 2, AUTO 3, GUIDED 4, CIRCLE 7, SURFACE 9, POSHOLD 16, MANUAL 19;
it boots in MANUAL, disarmed); ``system_status`` STANDBY (disarmed), ACTIVE (armed), CRITICAL
(any failsafe or alarm active).

Telemetry by default (Hz of the simulated clock; changed by MAV_CMD_SET_MESSAGE_INTERVAL, read
by MAV_CMD_GET_MESSAGE_INTERVAL, one sent at once by MAV_CMD_REQUEST_MESSAGE): HEARTBEAT 1,
SYS_STATUS 1, SYSTEM_TIME 1, ATTITUDE 10, LOCAL_POSITION_NED 10, GLOBAL_POSITION_INT 4,
SCALED_PRESSURE (inside the vessel: the housing's pressure and temperature) 1, SCALED_PRESSURE2
(the depth sensor) 4, DISTANCE_SENSOR 5, VFR_HUD 4, BATTERY_STATUS 1. Position and velocity are
the navigator's estimate (paper §4), not the truth. The local NED frame is the simulation's world
frame: x towards the wall (the wall is x = 0, the vehicle works at x < 0), y along the wall,
z depth (down), yaw 0 facing the wall. GLOBAL_POSITION_INT places that origin at
:data:`ORIGIN_LAT`, :data:`ORIGIN_LON` (flat earth).

DISTANCE_SENSOR is the sonar wall tracker (paper §5): id 1, type MAV_DISTANCE_SENSOR_ULTRASOUND,
orientation MAV_SENSOR_ROTATION_CUSTOM (100) with ``quaternion`` the rotation about z from the
body frame to the wall's normal (the bearing of the closest point of the wall relative to the
heading: the heading towards the wall is yaw + that bearing), ``current_distance`` the
perpendicular distance to the wall in cm, ``min_distance`` 30, ``max_distance`` 5000; while the
wall is not tracked ``current_distance`` is 5001 (max + 1: MAVLink's "nothing detected").
"""

from __future__ import annotations

import math
import time
from typing import Any, Protocol

from pymavlink import mavutil

import behaviours as bh
from aal.mavlink import MODES, PRESSURE_TEXT
from aal.signing import SigningState
from behaviours.base import wrap
from vehicle.control.stack import IctineuStack


mav = mavutil.mavlink  # MAVLink 2: ardusub sets MAVLINK20 before importing us

STREAMS = {  # message: default rate, Hz of the simulated clock (ArduSub's usual rates)
    "HEARTBEAT": 1.0, "SYS_STATUS": 1.0, "SYSTEM_TIME": 1.0, "ATTITUDE": 10.0,
    "LOCAL_POSITION_NED": 10.0, "GLOBAL_POSITION_INT": 4.0, "SCALED_PRESSURE": 1.0,
    "SCALED_PRESSURE2": 4.0, "DISTANCE_SENSOR": 5.0, "VFR_HUD": 4.0, "BATTERY_STATUS": 1.0,
}
SONAR_MIN_CM, SONAR_MAX_CM = 30, 5000
ORIGIN_LAT, ORIGIN_LON = 41.9850, 2.6170  # deg: the local frame's origin (near Pasteral dam)
EARTH_RADIUS = 6_378_137.0  # m
WATER_DENSITY = 997.0  # kg/m3, fresh water (ArduSub's default)
SURFACE_PRESSURE_HPA = 1013.25


class Streams:
    """When each telemetry message is due, on the simulated clock; SET_MESSAGE_INTERVAL."""

    def __init__(self, rates: dict[str, float]) -> None:
        self.ids = {getattr(mav, f"MAVLINK_MSG_ID_{name}"): name for name in rates}
        self.default = {name: 1.0 / hz for name, hz in rates.items()}
        self.interval: dict[str, float | None] = dict(self.default)
        self.next = {name: 0.0 for name in rates}

    def set(self, msg_id: int, interval_us: float) -> bool:
        """MAVLink's rule: -1 stops it, 0 restores the default, > 0 sets the interval."""
        name = self.ids.get(msg_id)
        if name is None:
            return False
        if interval_us < 0:
            self.interval[name] = None
        else:
            self.interval[name] = self.default[name] if interval_us == 0 else interval_us / 1e6
        return True

    def get_us(self, msg_id: int) -> int:
        interval = self.interval.get(self.ids.get(msg_id, ""))
        return -1 if interval is None else round(interval * 1e6)

    def due(self, t: float) -> list[str]:
        out = []
        for name, interval in self.interval.items():
            if interval is not None and t + 1e-9 >= self.next[name]:
                out.append(name)
                # keep the cadence, but never send a burst after a pause
                self.next[name] = max(self.next[name] + interval, t + interval / 2)
        return out


class Autopilot(Protocol):
    """What the telemetry reads of the vehicle it reports (:class:`vehicle.servers.ardusub.ArduSubVehicle`),
    so that this module need not import it (that module imports this one)."""

    stack: IctineuStack
    mode: int
    armed: bool
    failsafe: dict[str, bool]
    signing: SigningState | None
    _last_heartbeat: float

    @property
    def time_boot_ms(self) -> int: ...

    def send(self, name: str, *args: Any, **kwargs: Any) -> None: ...

    def alarms(self) -> dict[str, bool]: ...


class Telemetry:
    """The messages of one vehicle, sent through its serialised ``send``."""

    def __init__(self, vehicle: Autopilot) -> None:
        self.v = vehicle

    def send(self, name: str) -> None:
        """Send the stream ``name`` (``"LOCAL_POSITION_NED"``) now."""
        getattr(self, name.lower())()

    def heartbeat(self) -> None:
        self.v._last_heartbeat = time.monotonic()
        base = mav.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED | mav.MAV_MODE_FLAG_MANUAL_INPUT_ENABLED
        if self.v.mode not in (MODES["MANUAL"], MODES["ACRO"]):
            base |= mav.MAV_MODE_FLAG_STABILIZE_ENABLED
        if self.v.mode == MODES["GUIDED"]:
            base |= mav.MAV_MODE_FLAG_GUIDED_ENABLED
        if self.v.armed:
            base |= mav.MAV_MODE_FLAG_SAFETY_ARMED
        critical = any(self.v.failsafe.values()) or any(self.v.alarms().values())
        status = (mav.MAV_STATE_CRITICAL if critical else
                  mav.MAV_STATE_ACTIVE if self.v.armed else mav.MAV_STATE_STANDBY)
        self.v.send("heartbeat", mav.MAV_TYPE_SUBMARINE, mav.MAV_AUTOPILOT_ARDUPILOTMEGA, base,
                  self.v.mode, status)
        if self.v.signing is not None:
            for name, value in (("SIG_OK", self.v.signing.accepted_signed),
                                ("SIG_UNSIGN", self.v.signing.rejected_unsigned),
                                ("SIG_BAD", self.v.signing.rejected_bad)):
                self.v.send("named_value_int", self.v.time_boot_ms, name.encode(), value)

    def sys_status(self) -> None:
        sensors = (mav.MAV_SYS_STATUS_SENSOR_3D_GYRO | mav.MAV_SYS_STATUS_SENSOR_3D_ACCEL
                   | mav.MAV_SYS_STATUS_SENSOR_3D_MAG | mav.MAV_SYS_STATUS_SENSOR_ABSOLUTE_PRESSURE
                   | mav.MAV_SYS_STATUS_SENSOR_MOTOR_OUTPUTS | mav.MAV_SYS_STATUS_AHRS
                   | mav.MAV_SYS_STATUS_SENSOR_BATTERY)
        health = sensors
        if self.v.alarms()[PRESSURE_TEXT]:
            health &= ~mav.MAV_SYS_STATUS_SENSOR_ABSOLUTE_PRESSURE
        volts, amps, remaining = self.battery()
        self.v.send("sys_status", sensors, sensors, health, 200, volts, amps, remaining,
                  0, 0, 0, 0, 0, 0)

    def battery(self) -> tuple[int, int, int]:
        """mV, cA, % of a 4S pack that lasts about two hours."""
        remaining = max(0.0, 100.0 - self.v.stack.t / 72.0)
        return int(14000 + 20 * remaining), 500 if self.v.armed else 50, int(remaining)

    def system_time(self) -> None:
        self.v.send("system_time", int(time.time() * 1e6), self.v.time_boot_ms)

    def attitude(self) -> None:
        p = self.v.stack.perception()
        self.v.send("attitude", self.v.time_boot_ms, 0.0, 0.0, wrap(p.psi), 0.0, 0.0, p.r)

    def world_velocity(self, p: bh.Perception) -> tuple[float, float, float]:
        c, s = math.cos(p.psi), math.sin(p.psi)
        return c * p.u - s * p.v, s * p.u + c * p.v, p.w

    def local_position_ned(self) -> None:
        p = self.v.stack.perception()
        self.v.send("local_position_ned", self.v.time_boot_ms, p.x, p.y, p.z,
                  *self.world_velocity(p))

    def global_position_int(self) -> None:
        p = self.v.stack.perception()
        lat = ORIGIN_LAT + math.degrees(p.x / EARTH_RADIUS)
        lon = ORIGIN_LON + math.degrees(p.y / (EARTH_RADIUS * math.cos(math.radians(ORIGIN_LAT))))
        vx, vy, vz = (int(round(v * 100)) for v in self.world_velocity(p))
        hdg = int(round(math.degrees(p.psi) * 100)) % 36000
        self.v.send("global_position_int", self.v.time_boot_ms, int(round(lat * 1e7)),
                  int(round(lon * 1e7)), int(round(-p.z * 1000)), int(round(-p.z * 1000)),
                  vx, vy, vz, hdg)

    def scaled_pressure(self) -> None:
        h = self.v.stack.housing
        self.v.send("scaled_pressure", self.v.time_boot_ms, float(h["pressure"]) * 1000.0, 0.0,
                  int(round(float(h["temperature"]) * 100)))

    def scaled_pressure2(self) -> None:
        depth = max(0.0, self.v.stack.robot.state.z)  # the pressure sensor reads the true depth
        hpa = SURFACE_PRESSURE_HPA + WATER_DENSITY * 9.80665 * depth / 100.0
        self.v.send("scaled_pressure2", self.v.time_boot_ms, hpa, 0.0, 1500)

    def distance_sensor(self) -> None:
        p = self.v.stack.perception()
        if p.wall_distance is None or p.wall_heading is None:
            distance, bearing = SONAR_MAX_CM + 1, 0.0
        else:
            distance = int(round(min(max(p.wall_distance * 100, SONAR_MIN_CM), SONAR_MAX_CM)))
            bearing = -p.wall_heading  # wall_heading is the heading relative to the normal
        q = [math.cos(bearing / 2), 0.0, 0.0, math.sin(bearing / 2)]
        self.v.send("distance_sensor", self.v.time_boot_ms, SONAR_MIN_CM, SONAR_MAX_CM, distance,
                  mav.MAV_DISTANCE_SENSOR_ULTRASOUND, 1, mav.MAV_SENSOR_ROTATION_CUSTOM, 255,
                  0.0, 0.0, q, 0)

    def vfr_hud(self) -> None:
        p = self.v.stack.perception()
        heading = int(round(math.degrees(p.psi))) % 360
        self.v.send("vfr_hud", math.hypot(p.u, p.v), math.hypot(p.u, p.v), heading, 0, -p.z, -p.w)

    def battery_status(self) -> None:
        volts, amps, remaining = self.battery()
        cells = [volts] + [65535] * 9
        self.v.send("battery_status", 0, mav.MAV_BATTERY_FUNCTION_ALL, mav.MAV_BATTERY_TYPE_LIPO,
                  32767, cells, amps, -1, -1, remaining)
