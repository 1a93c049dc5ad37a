"""What the Ictineu's sensors give (vehicle/sensors/instruments.py): one typed reading per
kind of sensor, the :class:`Sensor` protocol they share, and the :class:`Schedule` of their due
times. Times in s of simulated time; world frame x towards the wall, z down (vehicle/world/robot.py).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Protocol

import numpy as np

from vehicle.world.robot import FloatArray, VehicleState


# --- readings ---------------------------------------------------------------------------------
@dataclass(frozen=True, slots=True)
class DvlReading:
    t: float
    velocity: tuple[float, float, float] | None  # body u, v, w over ground (m/s); None: no lock
    altitude: float  # m above the floor (true)
    bottom_lock: bool


@dataclass(frozen=True, slots=True)
class HeadingReading:
    t: float
    heading: float  # rad, wrapped to (-pi, pi]


@dataclass(frozen=True, slots=True)
class DepthReading:
    t: float
    depth: float  # m


@dataclass(frozen=True, eq=False)
class UsblFix:
    t: float
    position: FloatArray  # world x, y, z (m)
    covariance: FloatArray  # 3 x 3 (m^2), from the Table I accuracies at the measured position
    slant_range: float  # m, measured
    injected_outlier: bool  # simulation truth, not for the navigator


@dataclass(frozen=True, eq=False)
class SonarBeam:
    t: float
    bearing: float  # rad, relative to the vehicle's heading, wrapped
    bins: FloatArray  # echo intensity 0..1 (8-bit steps); bin i: [i, i + 1) * bin_size
    bin_size: float  # m

    def ranges(self) -> FloatArray:
        """Range of each bin's centre (m)."""
        return (np.arange(self.bins.size, dtype=np.float64) + 0.5) * self.bin_size


@dataclass(frozen=True, slots=True)
class WallFootprint:
    """Bounding box of the image on the wall (m) and the range along the optical axis."""

    y_min: float
    y_max: float
    z_min: float
    z_max: float
    distance: float


@dataclass(frozen=True, slots=True)
class CameraImage:
    t: float
    index: int
    footprint: WallFootprint | None  # None: the wall is not (entirely) within visibility
    pose: tuple[float, float, float, float] | None = None  # true x, y, z, yaw (the rendering's)


@dataclass(frozen=True, slots=True)
class HousingReading:
    t: float
    vessel: str
    leak: bool
    temperature: float  # deg C
    pressure: float  # bar


Reading = (DvlReading | HeadingReading | DepthReading | UsblFix | SonarBeam | CameraImage
           | HousingReading)


class Sensor(Protocol):
    rate: float
    schedule: Schedule  # when its next reading is due: sample says None before then

    def sample(self, t: float, truth: VehicleState,
               rng: np.random.Generator) -> Reading | None: ...


class Schedule:
    """Due times t0 + k / rate, counted (no drift from adding periods)."""

    def __init__(self, rate: float, t0: float = 0.0) -> None:
        if rate <= 0.0:
            raise ValueError(f"rate must be > 0 Hz, got {rate}")
        self.rate, self.t0, self.count = rate, t0, 0
        self.next = t0  # the next due time, t0 + count / rate

    def next_time(self) -> float:
        return self.next

    def waiting(self, t: float) -> bool:
        """True if no reading is due at t yet (:meth:`due` would say False)."""
        return t + 1e-9 < self.next

    def due(self, t: float) -> bool:
        """True (and move on to the next due time) if a reading is due at t."""
        if not self.waiting(t):
            self.count += 1
            self.next = self.t0 + self.count / self.rate
            return True
        return False
