"""The simulated Ictineu AUV in four degrees of freedom, and the dam it works in (paper 002 §2.1).

Frame (the project's): the dam wall is the vertical surface x = x_wall(y) = c*y**2 (c = 0: the
plane x = 0); the vehicle works at x < 0; yaw 0 points at the wall (+x); y runs along the wall
(to starboard when facing it); z is depth, positive down, surface z = 0; the reservoir floor is
at z = floor_depth. Body axes: u forward, v starboard, w down, r yaw rate. Angles in radians.

From the paper (§2.1): a 0.8 x 0.5 x 0.5 m open frame of 60 kg in air, practically neutral
(about 0.6 kg positive buoyancy), passively stable in roll and pitch, actuated in surge, sway,
heave and yaw by six thrusters of 22 N each: four horizontal "in a rhombus" (any horizontal
direction plus rotation) and two vertical.

Chosen here (not in the paper), see :class:`IctineuParams`:

* Thruster layout, the rhombus read as thrusters at its four vertices: two surge thrusters at
  body y = -/+0.20 m (port, starboard), two sway thrusters at body x = +/-0.30 m (bow, stern),
  two heave thrusters. Hence at most 44 N in surge, sway and heave and 22 N m in yaw.
  Allocation is the minimum-norm (pseudo-inverse) solution, then each thruster is clipped to
  +/-22 N; thrusters respond instantly.
* Hydrodynamics, per DOF: added mass, linear and quadratic damping (the quadratic terms are
  0.5*rho*Cd*A with the box's faces and Cd of 0.7-0.9 for an open frame), the rigid-body plus
  added-mass Coriolis terms of a diagonal inertia in the horizontal plane, and the net buoyancy.
  Full-thrust speeds: surge 0.65 m/s, sway 0.49 m/s, heave 0.44 m/s (down), yaw 53 deg/s.
* Water current: world frame, constant or a function of time. Hydrodynamic forces act on the
  velocity relative to the water, nu_r = nu - R(psi)^T v_c; for a constant, irrotational current
  M nu_r' + C(nu_r) nu_r + D(nu_r) nu_r = tau holds exactly (Fossen's relative-velocity model).
  The integrated state keeps nu_r; :attr:`Ictineu.state` reports velocities over ground.
* Integration: Heun (RK2) with a fixed sub-step (0.05 s); a white force disturbance per sub-step
  drawn from the generator passed in, so a run is a function of the seed.
* Contact: the hull (its horizontal rectangle, 0.8 x 0.5 m) cannot cross the wall; the vehicle
  is pushed back out along the wall normal, the velocity into the wall is removed, and
  ``wall_contact`` is set. Likewise the floor (``floor_contact``) and the edges of the working
  area (``edge_contact``: the reservoir's banks, x >= x_min and y_min <= y <= y_max); the
  surface stops z at 0. Thrust into a contact does nothing: the vehicle stops there.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np
import numpy.typing as npt

from behaviours.base import wrap

FloatArray = npt.NDArray[np.float64]

GRAVITY = 9.81  # m/s^2


wrap_angle = wrap  # an angle in (-pi, pi]: behaviours/base.py's, the one home of the helper


@dataclass(frozen=True, slots=True)
class VehicleState:
    """Pose in the world frame (m, rad) and body velocities over ground (m/s, rad/s), §4.1."""

    x: float = 0.0
    y: float = 0.0
    z: float = 0.0
    psi: float = 0.0
    u: float = 0.0
    v: float = 0.0
    w: float = 0.0
    r: float = 0.0

    def as_array(self) -> FloatArray:
        """[x y z psi u v w r], the order of the navigator's state vector (eq. 1)."""
        return np.array([self.x, self.y, self.z, self.psi, self.u, self.v, self.w, self.r])

    @classmethod
    def from_array(cls, a: Sequence[float] | FloatArray) -> VehicleState:
        return cls(*(float(e) for e in a[:8]))


AREA = (-60.0, 60.0, -60.0, 60.0)  # m: x_min, x_max, y_min, y_max of the simulated reservoir


@dataclass(frozen=True)
class Environment:
    """The reservoir: wall x = wall_curvature*y**2 (m), floor at floor_depth (m), water current,
    and the working area (x_min, x_max, y_min, y_max) in m, whose edges are banks the hull
    cannot cross (the water volume is inside the area, in front of the wall, above the floor).

    ``current`` is the world-frame current (m/s); ``current_fn``, if given, overrides it with a
    slowly varying current of time t (s).
    """

    wall_curvature: float = 0.0
    floor_depth: float = 12.0
    current: tuple[float, float, float] = (0.0, 0.0, 0.0)
    current_fn: Callable[[float], Sequence[float]] | None = field(default=None, compare=False)
    area: tuple[float, float, float, float] = AREA

    def where(self, x: float, y: float, z: float, margin: float = 0.0) -> str | None:
        """None if (x, y, z) is in the water at least ``margin`` m from the wall, the floor and
        the area's edges (and below the surface); else why not, in words."""
        x0, x1, y0, y1 = self.area
        if not (x0 + margin <= x <= x1 - margin and y0 + margin <= y <= y1 - margin):
            return (f"outside the working area (x {x0:g}..{x1:g} m, y {y0:g}..{y1:g} m)")
        if self.distance_to_wall(x, y) < margin:
            return "inside the wall"
        if z > self.floor_depth - margin:
            return f"beyond the floor ({self.floor_depth:g} m)"
        if z < 0.0:
            return "above the surface"
        return None

    def wall_x(self, y: float) -> float:
        """x of the wall surface at along-wall coordinate y (m)."""
        return self.wall_curvature * y * y

    def current_at(self, t: float) -> tuple[float, float, float]:
        """World-frame water velocity at time t (m/s)."""
        if self.current_fn is None:
            return self.current
        cx, cy, cz = self.current_fn(t)
        return (float(cx), float(cy), float(cz))

    def wall_foot(self, x: float, y: float) -> float:
        """The along-wall coordinate of the wall point nearest to (x, y) (Newton, a few steps)."""
        c = self.wall_curvature
        if c == 0.0:
            return y
        t = y
        for _ in range(8):  # minimise (x - c t^2)^2 + (y - t)^2 over t
            g = 2.0 * c * t * (c * t * t - x) + t - y
            dg = 2.0 * c * (3.0 * c * t * t - x) + 1.0
            if dg <= 0.0:
                break
            step = g / dg
            t -= step
            if abs(step) < 1e-12:
                break
        return t

    def wall_normal(self, y_wall: float) -> tuple[float, float]:
        """Unit horizontal normal of the wall at y_wall, pointing from the water into the wall."""
        ny = -2.0 * self.wall_curvature * y_wall
        n = math.hypot(1.0, ny)
        return (1.0 / n, ny / n)

    def distance_to_wall(self, x: float, y: float) -> float:
        """Horizontal distance from (x, y) to the wall (m): positive on the water side."""
        t = self.wall_foot(x, y)
        d = math.hypot(x - self.wall_x(t), y - t)
        return d if x <= self.wall_x(y) else -d

    def ray_to_wall(self, origin: Sequence[float], direction: Sequence[float]) -> float | None:
        """Distance along a ray (unit ``direction``) to the wall, or None if it misses.

        Solves x0 + s*dx = c*(y0 + s*dy)**2 for the nearest s > 0; the hit must lie in the water
        column (0 <= z <= floor_depth).
        """
        x0, y0, z0 = origin[0], origin[1], origin[2]
        dx, dy, dz = direction[0], direction[1], direction[2]
        c = self.wall_curvature
        a = c * dy * dy
        b = 2.0 * c * y0 * dy - dx
        k = c * y0 * y0 - x0
        roots: list[float] = []
        if abs(a) < 1e-12:
            if b != 0.0:
                roots.append(-k / b)
        else:
            disc = b * b - 4.0 * a * k
            if disc >= 0.0:
                q = -0.5 * (b + math.copysign(math.sqrt(disc), b))
                roots.append(q / a)
                if q != 0.0:
                    roots.append(k / q)
        hits = [s for s in roots if s > 1e-9 and 0.0 <= z0 + s * dz <= self.floor_depth]
        return min(hits) if hits else None


@dataclass(frozen=True)
class IctineuParams:
    """Physical constants of the simulated Ictineu (SI units; 4-tuples are surge, sway, heave, yaw)."""

    mass: float = 60.0  # kg in air, §2.1
    inertia_z: float = 4.5  # kg m^2: the 60 kg, 0.8 x 0.5 m box, m(a^2 + b^2)/12
    added_mass: tuple[float, float, float, float] = (30.0, 45.0, 60.0, 2.5)  # kg, kg m^2
    linear_damping: tuple[float, float, float, float] = (10.0, 15.0, 20.0, 5.0)  # N s/m, N m s
    quadratic_damping: tuple[float, float, float, float] = (90.0, 150.0, 180.0, 20.0)  # N s2/m2
    net_buoyancy: float = 0.6 * GRAVITY  # N upwards: "approx. 0.6 kg of positive buoyancy", §2.1
    thrust_max: float = 22.0  # N per thruster (Seabotix SBT150), §2.1
    surge_arm: float = 0.20  # m, |body y| of the two surge thrusters
    sway_arm: float = 0.30  # m, |body x| of the two sway thrusters
    half_length: float = 0.40  # m, §2.1: 0.8 x 0.5 x 0.5 m
    half_width: float = 0.25  # m
    half_height: float = 0.25  # m
    dt: float = 0.05  # s, integration sub-step
    disturbance_std: tuple[float, float, float, float] = (0.5, 0.5, 0.5, 0.1)  # N, N m

    def inertia(self) -> tuple[float, float, float, float]:
        """Diagonal of M = M_RB + M_A (kg, kg, kg, kg m^2)."""
        m, a = self.mass, self.added_mass
        return (m + a[0], m + a[1], m + a[2], self.inertia_z + a[3])

    def allocation_matrix(self) -> FloatArray:
        """B with tau = B f: rows surge, sway, heave, yaw; columns the six thrusters
        (surge port, surge starboard, sway bow, sway stern, heave fore, heave aft)."""
        a, b = self.surge_arm, self.sway_arm
        return np.array([
            [1.0, 1.0, 0.0, 0.0, 0.0, 0.0],
            [0.0, 0.0, 1.0, 1.0, 0.0, 0.0],
            [0.0, 0.0, 0.0, 0.0, 1.0, 1.0],
            [a, -a, b, -b, 0.0, 0.0],  # N = x F_y - y F_x
        ])


def allocate(tau: Sequence[float], params: IctineuParams,
             pinv: FloatArray | None = None,
             B: FloatArray | None = None) -> tuple[FloatArray, FloatArray]:
    """Thruster forces (N, each clipped to +/-thrust_max) for a demand (tau_u, tau_v, tau_w, tau_r)
    in N and N m, and the body force/torque they actually produce. ``pinv``: B's pseudo-inverse,
    and ``B`` the allocation matrix, if already computed."""
    B = params.allocation_matrix() if B is None else B
    f = (np.linalg.pinv(B) if pinv is None else pinv) @ np.asarray(tau, dtype=float)
    np.minimum(np.maximum(f, -params.thrust_max, out=f), params.thrust_max, out=f)  # the clip
    return f, B @ f


class Ictineu:
    """The simulated vehicle: ``step(dt, tau)`` advances it under a force/torque demand."""

    def __init__(self, state: VehicleState, params: IctineuParams | None = None,
                 rng: np.random.Generator | None = None, env: Environment | None = None,
                 t0: float = 0.0) -> None:
        self.params = params or IctineuParams()
        self.env = env or Environment()
        self.rng = rng if rng is not None else np.random.default_rng(0)
        self.t = t0
        self._M = self.params.inertia()
        self._B = self.params.allocation_matrix()  # params are frozen: made once
        self._disturbance_std = np.asarray(self.params.disturbance_std, dtype=float)
        self._disturbed = bool(self._disturbance_std.any())  # a white force each sub-step
        self._pinv: FloatArray = np.asarray(np.linalg.pinv(self._B),
                                            dtype=np.float64)
        self.thrust: FloatArray = np.zeros(6)  # N, last allocation
        self.tau_applied: FloatArray = np.zeros(4)  # N, N m, after saturation
        self.wall_contact = False  # during the last step()
        self.floor_contact = False
        self.edge_contact = False  # with an edge of the working area
        self.collisions = 0  # number of times the hull came into contact with the wall
        self._touching = False
        cx, cy, cz = self.env.current_at(t0)
        c, s = math.cos(state.psi), math.sin(state.psi)
        self._s = [state.x, state.y, state.z, wrap_angle(state.psi),
                   state.u - (c * cx + s * cy), state.v - (-s * cx + c * cy), state.w - cz,
                   state.r]  # pose and velocity relative to the water
        self._enforce_limits()

    @property
    def collided(self) -> bool:
        """Did the hull touch the wall, the floor or an edge of the area during the last step?"""
        return self.wall_contact or self.floor_contact or self.edge_contact

    @property
    def state(self) -> VehicleState:
        """True pose and body velocities over ground at time ``t``."""
        x, y, z, psi, ur, vr, wr, r = self._s
        cx, cy, cz = self.env.current_at(self.t)
        c, s = math.cos(psi), math.sin(psi)
        return VehicleState(x, y, z, psi, ur + c * cx + s * cy, vr - s * cx + c * cy, wr + cz, r)

    @property
    def relative_velocity(self) -> tuple[float, float, float, float]:
        """Body velocities through the water (m/s, rad/s)."""
        return (self._s[4], self._s[5], self._s[6], self._s[7])

    def step(self, dt: float, tau: Sequence[float]) -> VehicleState:
        """Advance dt seconds (in sub-steps of at most params.dt) holding the demand tau."""
        if dt < 0.0:
            raise ValueError(f"dt must be >= 0, got {dt}")
        f, applied = allocate(tau, self.params, self._pinv, self._B)
        self.thrust, self.tau_applied = f, applied
        self.wall_contact = self.floor_contact = self.edge_contact = False
        n = max(1, math.ceil(dt / self.params.dt - 1e-9)) if dt > 0.0 else 0
        h = dt / n if n else 0.0
        ta = (float(applied[0]), float(applied[1]), float(applied[2]), float(applied[3]))
        sd = self._disturbance_std
        for _ in range(n):
            d = (self.rng.normal(0.0, 1.0, 4) * sd).tolist() if self._disturbed else [0.0] * 4
            forces = (ta[0] + d[0], ta[1] + d[1], ta[2] + d[2], ta[3] + d[3])
            s0 = self._s
            k1 = self._derivative(s0, forces, self.t)
            s1 = [a + h * b for a, b in zip(s0, k1)]
            k2 = self._derivative(s1, forces, self.t + h)
            self._s = [a + 0.5 * h * (b + c) for a, b, c in zip(s0, k1, k2)]
            self._s[3] = wrap_angle(self._s[3])
            self.t += h
            self._enforce_limits()
        return self.state

    def _derivative(self, s: list[float], tau: tuple[float, float, float, float],
                    t: float) -> list[float]:
        """d/dt of [x y z psi u_r v_r w_r r]: kinematics plus M nu_r' = tau - C nu_r - D nu_r - g."""
        _, _, _, psi, ur, vr, wr, r = s
        cx, cy, cz = self.env.current_at(t)
        c, sn = math.cos(psi), math.sin(psi)
        m11, m22, m33, m44 = self._M
        lin, quad = self.params.linear_damping, self.params.quadratic_damping
        du = (tau[0] + m22 * vr * r - (lin[0] + quad[0] * abs(ur)) * ur) / m11
        dv = (tau[1] - m11 * ur * r - (lin[1] + quad[1] * abs(vr)) * vr) / m22
        dw = (tau[2] - self.params.net_buoyancy - (lin[2] + quad[2] * abs(wr)) * wr) / m33
        dr = (tau[3] - (m22 - m11) * ur * vr - (lin[3] + quad[3] * abs(r)) * r) / m44
        return [c * ur - sn * vr + cx, sn * ur + c * vr + cy, wr + cz, r, du, dv, dw, dr]

    def _enforce_limits(self) -> None:
        """Keep the hull out of the wall, the floor and the area's edges, and below the surface."""
        x, y, z, psi, ur, vr, wr, r = self._s
        cx, cy, cz = self.env.current_at(self.t)
        c, s = math.cos(psi), math.sin(psi)
        vx, vy, vz = c * ur - s * vr + cx, s * ur + c * vr + cy, wr + cz
        p = self.params
        hit_wall = hit_floor = hit_edge = moved = False
        for _ in range(3):  # the push is along the local normal: repeat for a curved wall
            foot = self.env.wall_foot(x, y)
            nx, ny = self.env.wall_normal(foot)
            a = psi - math.atan2(ny, nx)
            extent = p.half_length * abs(math.cos(a)) + p.half_width * abs(math.sin(a))
            d = self.env.distance_to_wall(x, y)
            if d >= extent - 1e-12:
                break
            hit_wall = moved = True
            x, y = x - nx * (extent - d), y - ny * (extent - d)
            vn = vx * nx + vy * ny
            if vn > 0.0:
                vx, vy = vx - vn * nx, vy - vn * ny
        ax0, ax1, ay0, ay1 = self.env.area  # the banks: axis-aligned, the hull's extent on each
        ex = p.half_length * abs(c) + p.half_width * abs(s)
        ey = p.half_length * abs(s) + p.half_width * abs(c)
        if x < ax0 + ex or x > ax1 - ex:
            x = min(max(x, ax0 + ex), ax1 - ex)
            vx = max(vx, 0.0) if x <= ax0 + ex else min(vx, 0.0)
            hit_edge = moved = True
        if y < ay0 + ey or y > ay1 - ey:
            y = min(max(y, ay0 + ey), ay1 - ey)
            vy = max(vy, 0.0) if y <= ay0 + ey else min(vy, 0.0)
            hit_edge = moved = True
        z_max = self.env.floor_depth - p.half_height
        if z > z_max:
            z, vz, hit_floor, moved = z_max, min(vz, 0.0), True, True
        if z < 0.0:
            z, vz, moved = 0.0, max(vz, 0.0), True
        if moved:
            ur = c * (vx - cx) + s * (vy - cy)
            vr = -s * (vx - cx) + c * (vy - cy)
            self._s = [x, y, z, psi, ur, vr, vz - cz, r]
        if hit_wall and not self._touching:
            self.collisions += 1
        self._touching = hit_wall
        self.wall_contact = self.wall_contact or hit_wall
        self.floor_contact = self.floor_contact or hit_floor
        self.edge_contact = self.edge_contact or hit_edge
