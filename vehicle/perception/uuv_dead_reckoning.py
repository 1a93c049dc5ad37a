"""The UUV's simplest navigator: dead reckoning on the model of eq. 2, reset by fixes.

Between fixes the surge speed is predicted from the thrust by the vehicle's model (paper 003
§4, eq. 3 without noise), the heading and the depth are measured; position integrates
``u cos psi``, ``u sin psi`` (no current estimate). A sonar fix (§4.1) is computed with the
depth the UUV had at the ping (kept in a short history) and moved forward by what the UUV
travelled since (from the stored estimates), so a fix 2 s late is not used as if current; a
camera sighting (§4.2, no delay) sets the position. It is the stand-in for the EKF of
``vehicle/perception/uuv_navigator.py`` (the navigator the stack takes is any object with
this class's methods, :class:`vehicle.control.uuv_stack.Navigation`).
"""

from __future__ import annotations

import bisect
import math
from dataclasses import dataclass, field

from vehicle.sensors.multibeam import SonarFix, fix_position
from vehicle.sensors.uuv_sensors import TargetSighting
from vehicle.world.mcm_bodies import UUV_MODEL, Model

HISTORY = 30.0  # s of stored estimates (fixes come 1.5 to 3 s late)


@dataclass
class DeadReckoning:
    """Position in {T} (m), depth (m), heading (rad), surge and heave speeds (m/s)."""

    x: float
    y: float
    model: Model = UUV_MODEL
    z: float = 0.0
    psi: float = 0.0
    u: float = 0.0
    w: float = 0.0
    r: float = 0.0
    t: float = 0.0
    fixes: int = 0
    history: list[tuple[float, float, float, float]] = field(default_factory=list)  # t,x,y,z

    def predict(self, t: float, tau: tuple[float, float, float]) -> None:
        """Propagate to time t under the thrust demand tau = (X, Z, N)."""
        dt = t - self.t
        if dt <= 0:
            return
        self.u += dt * self.model.surge.acceleration(self.u, tau[0])
        self.x += dt * self.u * math.cos(self.psi)
        self.y += dt * self.u * math.sin(self.psi)
        self.t = t
        self.history.append((t, self.x, self.y, self.z))
        while self.history and self.history[0][0] < t - HISTORY:
            self.history.pop(0)

    def heading(self, t: float, psi: float) -> None:
        self.psi = psi

    def depth(self, t: float, z: float) -> None:
        dt = t - self.t
        if dt > 0:
            self.w = (z - self.z) / max(dt, 0.1)
        self.z = z

    def at(self, t: float) -> tuple[float, float, float, float]:
        """The stored estimate (t, x, y, z) nearest before time t (the present if none)."""
        times = [h[0] for h in self.history]
        i = bisect.bisect_right(times, t) - 1
        return self.history[i] if i >= 0 else (self.t, self.x, self.y, self.z)

    def sonar(self, t: float, fix: SonarFix) -> None:
        """A fix pinged at ``fix.ping``, heard at t: eq. 3 with the depth at the ping, moved
        on by the estimated travel since."""
        then = self.at(fix.ping)
        fx, fy = fix_position(fix, then[3])
        cx, cy = fx - then[1], fy - then[2]  # the correction at the ping, carried to now
        self.x, self.y = self.x + cx, self.y + cy
        self.history = [(ht, hx + cx, hy + cy, hz) if ht >= then[0] else (ht, hx, hy, hz)
                        for ht, hx, hy, hz in self.history]
        self.fixes += 1

    def camera(self, sighting: TargetSighting) -> None:
        self.x, self.y = sighting.x, sighting.y

    def estimate(self) -> tuple[float, float, float, float, float, float, float]:
        """x, y, z, psi, u, w, r."""
        return self.x, self.y, self.z, self.psi, self.u, self.w, self.r
