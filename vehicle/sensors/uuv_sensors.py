"""The UUV's own sensors (paper 003 §2, §4.2): a compass, a depth sensor and a camera. It has
no positioning sensor: where it is comes from the ASV's fixes and, near the mine, the camera.

The camera looks forward and down (15 deg below the bow, an 80 deg cone); it sees the mine when
it lies within the water's visibility and in the cone, and the video processing then gives the
UUV's horizontal position relative to the mine, i.e. in {T} (§4.2: "directly in the mine-centric
coordinate frame"), at 4 Hz ("3-5 Hz"), without delay, with an error growing with the distance
(2 cm + 3 % of it, 1 sigma). Compass 1 deg and depth 5 cm (1 sigma), at 10 Hz.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from vehicle.world.mcm_bodies import BodyState
from vehicle.world.mine_field import MINE_HEIGHT, MineField

CAMERA_TILT = math.radians(15.0)  # below the bow
CAMERA_CONE = math.radians(40.0)  # half-angle


@dataclass(frozen=True)
class TargetSighting:
    """The camera's measurement: the UUV's position in {T} relative to the mine it sees (m),
    with its standard deviation (m), at time t (s)."""

    t: float
    x: float
    y: float
    sigma: float


def sees(scene: MineField, uuv: BodyState) -> bool:
    """Whether the mine (its middle, half its height below its top) is in the camera's cone
    and within the visibility."""
    tx, ty, tz = scene.target
    dx, dy, dz = tx - uuv.x, ty - uuv.y, tz + MINE_HEIGHT / 2 - uuv.z
    distance = math.sqrt(dx * dx + dy * dy + dz * dz)
    if distance > scene.visibility:
        return False
    if distance < 0.3:
        return True
    # the camera's axis: the bow's direction tilted down by CAMERA_TILT
    ax = math.cos(CAMERA_TILT) * math.cos(uuv.psi)
    ay = math.cos(CAMERA_TILT) * math.sin(uuv.psi)
    az = math.sin(CAMERA_TILT)
    cosine = (ax * dx + ay * dy + az * dz) / distance
    return cosine >= math.cos(CAMERA_CONE)


@dataclass
class UuvSensors:
    """Compass, depth and camera, sampled at their rates from the ground truth."""

    scene: MineField
    rng: np.random.Generator
    sigma_heading: float = math.radians(1.0)
    sigma_depth: float = 0.05
    camera_period: float = 0.25
    next_frame: float = 0.0

    def heading(self, uuv: BodyState) -> float:
        return math.remainder(uuv.psi + float(self.rng.normal(0.0, self.sigma_heading)),
                              2 * math.pi)

    def depth(self, uuv: BodyState) -> float:
        return uuv.z + float(self.rng.normal(0.0, self.sigma_depth))

    def camera(self, t: float, uuv: BodyState) -> TargetSighting | None:
        """A frame at its rate: the mine's sighting, or None (no frame due, or not seen)."""
        if t + 1e-9 < self.next_frame:
            return None
        self.next_frame = t + self.camera_period
        if not sees(self.scene, uuv):
            return None
        x, y = self.scene.in_target_frame(uuv.x, uuv.y)
        sigma = 0.02 + 0.03 * self.scene.distance_to_target(uuv.x, uuv.y, uuv.z)
        return TargetSighting(t, x + float(self.rng.normal(0.0, sigma)),
                              y + float(self.rng.normal(0.0, sigma)), sigma)
