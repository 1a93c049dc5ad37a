"""The ASV's and the UUV's dynamics: paper 003's eq. 2 per degree of freedom.

Each controlled degree of freedom v (surge u, heave w, yaw rate r) obeys
``alpha * dv/dt + beta(v) * v = tau + tau_E`` with ``beta(v) = beta_v + beta_vv * |v|``; the
heave's external force is the buoyancy bias b (weight minus buoyancy, N, + down), and the
current (m/s, {E}) carries the vehicle over ground (eq. 3's kinematics: ``x' = u cos psi +
x_c``, ``y' = u sin psi + y_c``). Sway is not controlled (the UUV is "uncontrollable in sway");
roll and pitch are passively stable. The UUV's parameters are those of the navigator's model
(vehicle/perception/uuv_model.py), the ASV's are chosen here for a small catamaran (the paper
identifies them by self-oscillation and gives none).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from vehicle.perception.uuv_model import UuvModel


@dataclass(frozen=True)
class Dof:
    """One degree of freedom of eq. 2: inertia ``alpha`` (kg or kg m^2), damping
    ``beta_v + beta_vv |v|``, and the largest force the thrusters give (``limit``)."""

    alpha: float
    beta_v: float
    beta_vv: float
    limit: float

    def acceleration(self, v: float, tau: float, external: float = 0.0) -> float:
        """dv/dt under the demand ``tau`` (clipped to the limit) and an external force."""
        tau = max(-self.limit, min(self.limit, tau))
        return (tau + external - (self.beta_v + self.beta_vv * abs(v)) * v) / self.alpha


@dataclass(frozen=True)
class Model:
    """A vehicle's surge, heave and yaw (eq. 2 each) and its buoyancy bias (N, + down)."""

    surge: Dof
    heave: Dof
    yaw: Dof
    bias: float = 0.0


def uuv_model(model: UuvModel | None = None, bias: float = -1.5) -> Model:
    """The simulated UUV: the parameters the navigator's model has (one source, W6's
    :class:`UuvModel`), 30 N, 25 N and 4 N m of thrust at most, ``bias`` N of weight minus
    buoyancy (-1.5: 1.5 N light, it rises when idle)."""
    m = model or UuvModel()
    return Model(surge=Dof(m.alpha_u, m.beta_u, m.beta_uu, 30.0),
                 heave=Dof(m.alpha_w, m.beta_w, m.beta_ww, 25.0),
                 yaw=Dof(m.alpha_r, m.beta_r, m.beta_rr, 4.0), bias=bias)


UUV_MODEL = uuv_model()
ASV_MODEL = Model(surge=Dof(150.0, 30.0, 80.0, 120.0), heave=Dof(1.0, 1.0, 0.0, 0.0),
                  yaw=Dof(40.0, 30.0, 40.0, 40.0))


@dataclass
class BodyState:
    """Ground truth of one vehicle in {E}: position (m, z down), heading (rad), body
    velocities through the water (u surge, w heave m/s, r yaw rate rad/s)."""

    x: float
    y: float
    z: float
    psi: float
    u: float = 0.0
    w: float = 0.0
    r: float = 0.0


@dataclass
class Body:
    """A vehicle moving by eq. 2 under thrust demands (X, Z, N), with process noise."""

    model: Model
    state: BodyState
    rng: np.random.Generator
    surface_only: bool = False  # the ASV: z stays 0
    bottom: float = math.inf  # m, the seabed's depth: the hull rests on it
    noise: tuple[float, float, float] = (0.5, 0.5, 0.05)  # N, N, N m
    on_bottom: bool = False

    def step(self, dt: float, tau: tuple[float, float, float],
             current: tuple[float, float]) -> None:
        """Advance dt seconds under the demand ``tau`` = (X, Z, N) and the current."""
        s, m = self.state, self.model
        ex = self.rng.normal(0.0, self.noise[0])
        ez = self.rng.normal(0.0, self.noise[1])
        en = self.rng.normal(0.0, self.noise[2])
        u = s.u + dt * m.surge.acceleration(s.u, tau[0], ex)
        r = s.r + dt * m.yaw.acceleration(s.r, tau[2], en)
        w = 0.0 if self.surface_only else s.w + dt * m.heave.acceleration(s.w, tau[1],
                                                                          m.bias + ez)
        x = s.x + dt * (u * math.cos(s.psi) + current[0])
        y = s.y + dt * (u * math.sin(s.psi) + current[1])
        z = s.z + dt * w
        self.on_bottom = z >= self.bottom
        if self.on_bottom:  # resting on the seabed: the bottom holds it (and friction)
            z, w, u = self.bottom, min(w, 0.0), 0.0
            x, y = s.x, s.y
        if z < 0.0:
            z, w = 0.0, max(w, 0.0)
        psi = math.remainder(s.psi + dt * r, 2 * math.pi)
        self.state = replace(s, x=x, y=y, z=z, psi=psi, u=u, w=w, r=r)
