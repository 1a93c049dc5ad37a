"""The velocity controller (paper 002 §3.1, Figure 4): body velocity setpoints to thrust.

A PI controller per degree of freedom on the navigator's velocity estimates, with a
feed-forward of the linear damping and anti-windup by clamping the integral. The output is the
body force/torque demand (tau_u, tau_v, tau_w, tau_r) for the thruster allocation.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from behaviours import DOFS
from behaviours.base import clamp


@dataclass
class Gains:
    kp: float
    ki: float
    feed: float  # linear damping feed-forward (N per m/s, or N m per rad/s)
    limit: float  # largest demand (N or N m)


DEFAULT_GAINS = {
    "x": Gains(kp=120.0, ki=20.0, feed=30.0, limit=44.0),   # two surge thrusters
    "y": Gains(kp=120.0, ki=20.0, feed=40.0, limit=22.0),   # one sway thruster
    "z": Gains(kp=150.0, ki=25.0, feed=40.0, limit=44.0),   # two heave thrusters
    "yaw": Gains(kp=20.0, ki=4.0, feed=5.0, limit=8.8),     # surge pair, 0.2 m lever arm
}


@dataclass
class VelocityController:
    gains: dict[str, Gains] = field(default_factory=lambda: dict(DEFAULT_GAINS))
    integral: dict[str, float] = field(default_factory=lambda: {d: 0.0 for d in DOFS})

    def update(self, setpoints: dict[str, float], velocity: dict[str, float],
               dt: float) -> dict[str, float]:
        """Thrust demand per degree of freedom for one control step of dt seconds."""
        tau = {}
        for dof in DOFS:
            g = self.gains[dof]
            error = setpoints.get(dof, 0.0) - velocity.get(dof, 0.0)
            i = self.integral[dof] + g.ki * error * dt
            i = clamp(i, g.limit)  # anti-windup
            self.integral[dof] = i
            demand = g.feed * setpoints.get(dof, 0.0) + g.kp * error + i
            tau[dof] = clamp(demand, g.limit)
        return tau

    def reset(self) -> None:
        self.integral = {d: 0.0 for d in DOFS}
