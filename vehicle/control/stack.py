"""The software control architecture of paper 002 (§3.1, Figure 4), simulated, as one stack.

Robot interface (the simulated Ictineu and its sensors) -> perception (the navigator EKF and
the sonar wall detector and tracker) -> control (the behaviours, the coordinator, the velocity
controller) -> thrusters. Actions from the mission player enable and disable behaviours;
the behaviours' events go back to it. The stack runs in simulated time, one tick of
:data:`DT` seconds at a time, deterministically for a seed.

It is what ``mcl run`` drives by default, through the in-process adapter (it implements the
adapter's ``on_action`` / ``next_time`` / ``due``), and what ``mcl vehicle`` will serve.

It runs one of each registered behaviour (behaviours/registry.py) and names none: what it does
for one it reads of the class (behaviours/base.py) — the device it ``switches`` (the camera
takes images while such a behaviour is enabled), the seabed ``tracker`` it needs, whether it
``surveys`` the wall (the run's figures count the wall tracker's error meanwhile).
"""

from __future__ import annotations

import difflib
import math
from dataclasses import dataclass, field
from typing import Any, Protocol

import numpy as np

import behaviours as bh
from aal.messages import ActionMessage, EventMessage
from behaviours import registry
from behaviours.coordinator import Coordinator

from vehicle.control.controller import VelocityController
from vehicle.perception.navigator import Navigator
from vehicle.world.robot import AREA, Environment, Ictineu, VehicleState, wrap_angle
from vehicle.perception.seabed_vision import SeabedVision
from vehicle.sensors.instruments import Sensors
from vehicle.sensors.readings import (
    CameraImage,
    DepthReading,
    DvlReading,
    HeadingReading,
    HousingReading,
    SonarBeam,
    UsblFix,
)
from vehicle.world.survey import Survey
from vehicle.perception.wall import WallDetector, WallTracker

DT = 0.05  # s, the robot's integration step and the control period
FAULTS = ("leak", "overtemperature", "overpressure", "burial")  # burial: docs/SEABED.md


def parse_fault(text: str) -> tuple[str, float]:
    """'leak@600' -> ("leak", 600.0); ValueError saying what is wrong and what to write."""
    kind, at, seconds = text.partition("@")
    example = f"expected FAULT@SECONDS with FAULT one of {', '.join(FAULTS)}, e.g. leak@600"
    if not at or kind not in FAULTS:
        near = difflib.get_close_matches(kind, FAULTS, n=1, cutoff=0.6)
        hint = f" (did you mean {near[0]}@{seconds or 600}?)" if near and at else ""
        raise ValueError(f"{text}: {example}{hint}")
    try:
        when = float(seconds)
    except ValueError:
        raise ValueError(f"{text}: {seconds!r} is not a number of seconds; {example}") from None
    if not math.isfinite(when):
        raise ValueError(f"{text}: {seconds} is not a finite number of seconds (the fault "
                         f"would never happen); {example}")
    if when < 0:
        raise ValueError(f"{text}: {seconds} s is before the mission starts (mission time "
                         f"counts from 0 at its start); {example}")
    return kind, when


@dataclass
class StackConfig:
    seed: int = 1
    start: tuple[float, float, float, float] = (-6.0, -2.0, 0.3, 0.0)  # x, y, z, yaw (rad)
    current: tuple[float, float, float] = (0.0, 0.02, 0.0)  # m/s, world frame
    wall_curvature: float = 0.0
    floor_depth: float = 12.0
    area: tuple[float, float, float, float] = AREA  # m: x_min, x_max, y_min, y_max (banks)
    faults: list[tuple[str, float]] = field(default_factory=list)  # (kind, mission time)


class Device(Protocol):
    """A device a behaviour switches (``Behaviour.switches``): on while it is enabled."""

    def start(self, t: float) -> None: ...

    def stop(self) -> None: ...


class IctineuStack:
    """The whole simulated vehicle stack behind the AAL."""

    simulated = True

    def __init__(self, config: StackConfig | None = None):
        self.config = config or StackConfig()
        cfg = self.config
        rng = np.random.default_rng(cfg.seed)
        robot_rng, sensor_rng, nav_rng = rng.spawn(3)
        self.env = Environment(wall_curvature=cfg.wall_curvature, floor_depth=cfg.floor_depth,
                               current=cfg.current, area=cfg.area)
        x, y, z, yaw = cfg.start
        self.robot = Ictineu(VehicleState(x, y, z, yaw, 0.0, 0.0, 0.0, 0.0), rng=robot_rng,
                             env=self.env)
        self.sensors = Sensors(self.env, sensor_rng)
        self.seabed = SeabedVision(seed=cfg.seed)  # the downward camera and line trackers
        for kind, at in cfg.faults:
            if kind not in FAULTS:
                raise ValueError(f"unknown fault {kind!r}: one of {', '.join(FAULTS)}")
            if kind == "burial":
                self.seabed.bury(at)
                continue
            self.sensors.housings[-1].inject(kind, at)  # type: ignore[arg-type]
        # the navigator starts from a noisy first fix (§4.2)
        first = np.array([x, y, z]) + nav_rng.normal(0.0, 0.3, 3)
        self.navigator = Navigator.from_first_fix(first, np.eye(3) * 0.3**2, yaw,
                                                  transceiver=self.sensors.usbl.transceiver)
        self.nav_t = 0.0
        self.detector = WallDetector()
        self.tracker: WallTracker | None = None
        self.behaviours: dict[str, bh.Behaviour] = {cls.name: cls()  # one of each registered
                                                    for cls in registry.behaviours()}
        self.devices: dict[str, Device] = {"camera": self.sensors.camera}  # no logger here
        self.coordinator = Coordinator()
        self.controller = VelocityController()
        self.t = 0.0
        self.housing = {"leak": False, "temperature": 20.0, "pressure": 1.0}
        self.altitude: float | None = None  # m, the DVL's last; None without bottom lock
        self._events: list[EventMessage] = []
        self._seq = 0
        self.survey = Survey(self.env)
        self.images: Any = None  # an ImageRecorder when the run keeps its images (mcl run)
        self.unknown_actions: list[str] = []
        self._owners: dict[str, str] = {}  # degree of freedom -> the behaviour driving it

    # -- the adapter's side -------------------------------------------------------------------
    def on_action(self, action: ActionMessage, now: float) -> None:
        b = self.behaviours.get(action.behaviour)
        if b is None:
            self.unknown_actions.append(action.behaviour)
            return
        device = self.devices.get(b.switches)
        if action.kind == "enable":
            b.initialise(action.params, self.t)
            if device is not None:
                device.start(self.t)
        elif action.kind == "disable":
            b.terminate(self.t)
            if device is not None:
                device.stop()
        else:
            b.configure(action.params, self.t)

    def next_time(self) -> float:
        return self.t + DT

    def due(self, t: float) -> list[EventMessage]:
        """Run ticks up to time t, stopping early at the first tick that raises events."""
        for _ in range(int((t - self.t) / DT + 1e-6) + 1):
            if self.t + DT > t + 1e-9:
                break
            self.tick()
            if self._events:
                break
        out, self._events = self._events, []
        return out

    # -- one tick ---------------------------------------------------------------------------------
    def tick(self) -> None:
        truth = self.robot.state
        for reading in self.sensors.sample(self.t, truth):
            self._perceive(reading)
        self._predict_to(self.t)
        p = self.perception()
        active = [b for b in self.behaviours.values() if b.active]  # on for the whole tick
        p = self.seabed.perceive(self.t, truth, p, [b.tracker for b in active if b.tracker])
        responses = {}
        for b in active:
            responses[b.name] = b.update(p)
            for name, data in b.take_events():
                self._events.append(EventMessage(self._seq, self.t, b.name, name, data))
                self._seq += 1
        setpoints = self.coordinator.merge(responses)
        owners = dict(self.coordinator.last_owner)
        for dof in self._owners.keys() - owners.keys():
            # freed: forget the thrust the last owner's integral built up (pressed against the
            # floor or the wall, it would keep pushing there after the behaviour is disabled)
            self.controller.integral[dof] = 0.0
        self._owners = owners
        velocity = {"x": p.u, "y": p.v, "z": p.w, "yaw": p.r}
        tau = self.controller.update(setpoints, velocity, DT)
        after = self.robot.step(DT, (tau["x"], tau["y"], tau["z"], tau["yaw"]))  # its state
        self.t += DT
        self.survey.record(self.t, after, self.navigator, self.tracker,
                           surveying=any(b.surveys for b in active))

    def surveying(self) -> bh.Behaviour | None:
        """The enabled behaviour that surveys the wall (``Behaviour.surveys``), if any."""
        return next((b for b in self.behaviours.values() if b.active and b.surveys), None)

    def _predict_to(self, t: float) -> None:
        if t > self.nav_t:
            self.navigator.predict(t - self.nav_t)
            if self.tracker is not None:
                u, v, r = (float(self.navigator.x[i]) for i in (4, 5, 7))
                self.tracker.predict(t - self.nav_t, u, v, r)
            self.nav_t = t

    def _perceive(self, reading: Any) -> None:
        self._predict_to(reading.t)
        match reading:
            case DvlReading(velocity=velocity, altitude=altitude):
                self.altitude = altitude if velocity is not None else None
                if velocity is not None:
                    self.navigator.update_dvl(velocity)
                else:
                    self.navigator.dvl_lost()
            case HeadingReading(heading=heading):
                self.navigator.update_heading(heading)
                if self.tracker is not None:
                    self.tracker.update_heading(heading, math.radians(0.5) ** 2)
            case DepthReading(depth=depth):
                self.navigator.update_depth(depth)
            case UsblFix():
                accepted = self.navigator.update_usbl(reading.position, reading.covariance)
                self.survey.usbl(reading, accepted)
            case SonarBeam():
                self._sonar(reading)
            case CameraImage():
                self.survey.image(reading)
                if self.images is not None:  # vehicle.sensors.camera.ImageRecorder: render, write
                    self.images.from_stack(self, reading)
            case HousingReading():
                self.housing = {"leak": self.housing["leak"] or reading.leak,
                                "temperature": reading.temperature,
                                "pressure": reading.pressure}

    def _sonar(self, beam: SonarBeam) -> None:
        if self.tracker is None:  # the pose only for the detector: the tracker needs none
            line = self.detector.add_beam(beam, self._pose())
            if line is not None:
                sigma_psi = math.sqrt(float(self.navigator.P[3, 3]))
                self.tracker = WallTracker.from_detection(line, sigma_psi=sigma_psi)
        else:
            self.tracker.update_beam(beam)

    def _pose(self) -> bh.Perception:
        x, y, z, psi = (float(self.navigator.x[i]) for i in range(4))
        return bh.Perception(self.t, x, y, z, psi)

    def perception(self) -> bh.Perception:
        n = self.navigator.x
        wall_d = wall_h = wall_n = None
        if self.tracker is not None:
            wall_d = self.tracker.distance_to_wall().value
            wall_h = self.tracker.relative_heading().value
            wall_n = float(self.tracker.x[2])
        return bh.Perception(self.t, float(n[0]), float(n[1]), float(n[2]),
                             wrap_angle(float(n[3])), float(n[4]), float(n[5]), float(n[6]),
                             float(n[7]), wall_distance=wall_d, wall_heading=wall_h,
                             wall_normal=wall_n, altitude=self.altitude, area=self.env.area,
                             leak=bool(self.housing["leak"]),
                             temperature=float(self.housing["temperature"]),
                             pressure=float(self.housing["pressure"]))
