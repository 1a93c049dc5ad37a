"""The ASV's forward-looking multibeam sonar and the sonar fix of paper 003 §4.1.

The multibeam is a 2D sensor: it measures the slant range R and the bearing epsilon (relative
to the sonar head, i.e. to the ASV's heading) of an echo, never its depth. The sonar processing
picks one echo as the UUV; near the bottom it can pick clutter instead, and near the mine the
mine itself (paper 003 §3: "near-target operation can result in false detection"). The ASV
sends R, epsilon, its heading and its position in {T}; the UUV computes its horizontal position
with its **own depth at the time of the ping** (eq. 3, :func:`fix_position`)::

    x_UUV = x_ASV + cos(psi_ASV + epsilon) * sqrt(R^2 - z^2)
    y_UUV = y_ASV + sin(psi_ASV + epsilon) * sqrt(R^2 - z^2)

Noise and rates are chosen here (the paper gives none): range 0.1 m, bearing 0.5 deg (1 sigma),
130 deg field of view, 80 m range, a ping every 0.5 s; the fix's covariance grows with the
slant range (:func:`fix_covariance`, "constant or diagonal and increasing with the slant
range"). Clutter is picked in place of the UUV with probability 0.05 when the UUV is within
3 m of the bottom (``clutter@S``: 0.6 within 6 m of the bottom, from S on); from
``falsetarget@S`` on, the mine is picked in place of a UUV within 6 m of it, with probability
0.7.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from vehicle.world.mcm_bodies import BodyState
from vehicle.world.mine_field import MineField

SONAR_HEAD_DEPTH = 0.0  # m: the head at the surface, as eq. 3 assumes (z is the UUV's depth)


@dataclass(frozen=True)
class SonarFix:
    """What the ASV sends the UUV (§4.1): slant range R (m), bearing epsilon (rad, relative to
    the ASV's heading), the ASV's heading psi (rad) and position x, y in {T} (m), and the time
    of the ping on the ASV's clock (s). ``echo`` is the simulation's ground truth of what was
    picked ("uuv", "clutter", "target"), for figures only: it is not sent."""

    range: float
    bearing: float
    heading: float
    x: float
    y: float
    ping: float
    echo: str = "uuv"

    def payload(self) -> dict[str, Any]:
        """The fix as a message's data (six numbers: an acoustic payload of tens of bytes)."""
        return {"R": round(self.range, 3), "epsilon": round(self.bearing, 5),
                "psi": round(self.heading, 5), "x": round(self.x, 3), "y": round(self.y, 3),
                "ping": round(self.ping, 3)}

    @classmethod
    def from_payload(cls, data: dict[str, Any]) -> SonarFix:
        """The fix a message carries; KeyError or ValueError if it is not one."""
        return cls(float(data["R"]), float(data["epsilon"]), float(data["psi"]),
                   float(data["x"]), float(data["y"]), float(data["ping"]))


def fix_position(fix: SonarFix, depth: float) -> tuple[float, float]:
    """Eq. 3: the UUV's horizontal position in {T} from a fix and the UUV's depth at the ping
    (below the sonar head; a slant range shorter than the depth gives the point under the
    ASV)."""
    dz = depth - SONAR_HEAD_DEPTH
    horizontal = math.sqrt(max(fix.range ** 2 - dz ** 2, 0.0))
    angle = fix.heading + fix.bearing
    return fix.x + math.cos(angle) * horizontal, fix.y + math.sin(angle) * horizontal


def fix_covariance(fix: SonarFix, sigma: float = 0.3,
                   per_metre: float = 0.01) -> tuple[tuple[float, float], tuple[float, float]]:
    """The fix's covariance (m^2, x and y): diagonal, growing with the slant range."""
    s = (sigma + per_metre * fix.range) ** 2
    return (s, 0.0), (0.0, s)


@dataclass
class Multibeam:
    """The forward-looking multibeam on the ASV: one detection per ping (or None)."""

    scene: MineField
    rng: np.random.Generator
    period: float = 0.5  # s between pings
    fov: float = math.radians(130.0)
    max_range: float = 80.0
    sigma_range: float = 0.1
    sigma_bearing: float = math.radians(0.5)
    clutter_from: float = math.inf  # s: the clutter@S fault
    false_target_from: float = math.inf  # s: the falsetarget@S fault
    next_ping: float = 0.0

    def due(self, t: float) -> bool:
        return t + 1e-9 >= self.next_ping

    def ping(self, t: float, asv: BodyState, uuv: BodyState,
             origin: tuple[float, float]) -> SonarFix | None:
        """A ping at time t: the echo picked as the UUV, as a fix in {T} (``origin``: {T}'s
        origin in {E}, as the ASV reacquired the mine), or None when nothing is in view."""
        self.next_ping = t + self.period
        echo, point = self.pick(t, uuv)
        dx, dy, dz = point[0] - asv.x, point[1] - asv.y, point[2] - SONAR_HEAD_DEPTH
        bearing = math.remainder(math.atan2(dy, dx) - asv.psi, 2 * math.pi)
        slant = math.sqrt(dx * dx + dy * dy + dz * dz)
        if abs(bearing) > self.fov / 2 or slant > self.max_range:
            return None
        slant += float(self.rng.normal(0.0, self.sigma_range))
        bearing += float(self.rng.normal(0.0, self.sigma_bearing))
        return SonarFix(slant, bearing, asv.psi, asv.x - origin[0], asv.y - origin[1], t, echo)

    def pick(self, t: float, uuv: BodyState) -> tuple[str, tuple[float, float, float]]:
        """Which echo the sonar processing takes for the UUV, and where it is ({E})."""
        scene = self.scene
        tx, ty, tz = scene.target
        near_target = math.hypot(uuv.x - tx, uuv.y - ty) < 6.0
        if t >= self.false_target_from and near_target and self.rng.random() < 0.7:
            return "target", (tx, ty, tz)
        altitude = scene.bottom - uuv.z
        faulty = t >= self.clutter_from
        chance, within = (0.6, 6.0) if faulty else (0.05, 3.0)
        if altitude < within and scene.clutter and self.rng.random() < chance:
            near = sorted(scene.clutter, key=lambda c: math.hypot(c[0] - uuv.x, c[1] - uuv.y))
            cx, cy = near[int(self.rng.integers(0, min(3, len(near))))]
            return "clutter", (cx, cy, scene.bottom)
        return "uuv", (uuv.x, uuv.y, uuv.z)
