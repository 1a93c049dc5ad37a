"""Wall detection and tracking with the mechanically scanned imaging sonar (paper 002 §5).

The dam wall, vertical and locally planar, is a line in the horizontal plane. A full 360 deg
scan initialises it by Hough voting with the modified sonar model (§5.1, §5.2); an EKF then
tracks it (§5.3-§5.5) from the vehicle's motion, its heading and every new sonar beam.

Frames and conventions (the project's world: the wall is the plane x = 0 and the vehicle works
at x < 0 facing it with yaw 0; angles are measured from +x towards +y, wrapped to (-pi, pi]):

* a line (rho, theta) is the set of points p with p . (cos theta, sin theta) = rho; theta is
  the direction of the wall's normal *from the vehicle towards the wall*, so rho measured from
  the vehicle is its distance to the wall (>= 0);
* the tracker's state is the paper's Eq. (12), x = [V_rho, V_theta, W_theta]: the line in the
  vehicle frame {V} and its orientation in the world {W}, tied by Eq. (13) W_theta = psi +
  V_theta. Hence

      distance to the wall        = V_rho
      heading relative to the wall = psi - W_theta = -V_theta

  (0 when facing the wall perpendicularly, positive when the vehicle has turned towards +y),
  which is what the AchieveHeadDist behaviour reads as ``wall_distance`` / ``wall_heading``.

The sonar head is taken at the vehicle's origin, as the paper does (§5.2); a beam's bearing
is relative to the vehicle's heading.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, NamedTuple, Protocol

import numpy as np
from numpy.typing import ArrayLike, NDArray

from vehicle.world.robot import wrap_angle
from vehicle.sensors.readings import SonarBeam  # one beam of the MSIS (vehicle/sensors/instruments.py)

FloatArray = NDArray[np.float64]

ALPHA = math.radians(3.0)  # §5.1: horizontal aperture of the MiniKing beam
BETA = math.radians(60.0)  # §5.1: largest incidence angle at which a surface still echoes
CHI2_1DOF_95 = 3.841458820694124  # chi-square, d = 1 (Eq. 28), 95 % confidence
CHI2_1DOF_99 = 6.634896601021214  # chi-square, d = 1 (Eq. 28), 99 % confidence
# Not in the paper; plausible for a 0..1 intensity scale and a MiniKing on a small AUV.
THRESHOLD = 0.5  # echo intensity of a "high-intensity" bin
MIN_RANGE = 0.5  # m, near field of the sonar head whose echoes are discarded (§5)


wrap = wrap_angle  # an angle in (-pi, pi]


def angle_residual(a: float, b: float) -> float:
    """a - b for angles, wrapped (the default injectable residual)."""
    return wrap(a - b)


class PlanarPose(Protocol):
    """The navigator's horizontal pose (``behaviours.Perception`` satisfies it)."""

    @property
    def x(self) -> float: ...
    @property
    def y(self) -> float: ...
    @property
    def psi(self) -> float: ...


@dataclass(frozen=True)
class Pose2D:
    x: float  # m, world
    y: float  # m, world
    psi: float  # rad, heading


IDENTITY: NDArray[np.float64] = np.eye(3)  # I of the tracker's state size, never written to
IDENTITY.setflags(write=False)


def echo_range(beam: SonarBeam, threshold: float = THRESHOLD,
               min_range: float = MIN_RANGE) -> float | None:
    """Range (m) of the beam's highest-intensity bin beyond the near field, or None when no bin
    there exceeds the threshold (§5: binarise, discard the sonar head's neighbourhood, take the
    strongest return)."""
    bins = np.asarray(beam.bins, dtype=float)
    first = math.ceil(min_range / beam.bin_size - 0.5)  # first bin centred >= min_range
    if first >= bins.size:
        return None
    i = first + int(np.argmax(bins[first:]))
    return (i + 0.5) * beam.bin_size if bins[i] > threshold else None


@dataclass(frozen=True)
class WallLine:
    """The Hough winner (§5.2): a line in the world frame and its support."""

    rho: float  # m, world: points p with p . (cos theta, sin theta) = rho
    theta: float  # rad, world direction of the normal from the vehicle towards the wall
    votes: int  # votes of the winning accumulator cell
    points: int  # sonar points that voted
    pose: Pose2D  # vehicle pose at the last beam of the scan (the accumulator's origin)

    def distance_from(self, x: float, y: float) -> float:
        """Distance (m) from (x, y) to the line, positive on the vehicle's side."""
        return self.rho - (x * math.cos(self.theta) + y * math.sin(self.theta))


class WallDetector:
    """Collects a scan's beams with the vehicle pose at each and finds the wall by Hough voting
    with the modified sonar model (§5.1, §5.2).

    Each sonar point (range r along world direction phi from the beam's origin) is an arc of
    aperture alpha (Eq. 9); it votes for every line whose normal theta lies within beta of some
    direction of the arc (Eq. 10), at rho = r cos(theta_arc - theta) (Eq. 11). The accumulator
    is (theta, rho) with world-aligned axes and its origin at the vehicle's position at the last
    beam, so the winner's rho is the distance to the wall at the end of the scan. Each point
    votes at most once per cell.
    """

    def __init__(self, *, threshold: float = THRESHOLD, min_range: float = MIN_RANGE,
                 max_range: float = 10.0, rho_step: float = 0.05,
                 theta_step: float = math.radians(1.0), alpha: float = ALPHA,
                 beta: float = BETA, min_votes: int = 15) -> None:
        self.threshold, self.min_range, self.max_range = threshold, min_range, max_range
        self.rho_step, self.alpha, self.beta, self.min_votes = rho_step, alpha, beta, min_votes
        n_theta = round(2.0 * math.pi / theta_step)
        self.theta_step = 2.0 * math.pi / n_theta
        n_rho = int(max_range / rho_step) + 1
        self.thetas = np.linspace(-math.pi, math.pi, n_theta, endpoint=False)  # cell centres
        self.rhos = np.linspace(0.0, n_rho * rho_step, n_rho, endpoint=False)  # cell centres
        self.accumulator: NDArray[np.int64] = np.zeros((n_theta, self.rhos.size), np.int64)
        self.reset()

    def reset(self) -> None:
        """Start a new scan."""
        self._points: list[tuple[float, float, float, float]] = []  # ox, oy, phi, r (world)
        self._last_pose: Pose2D | None = None
        self._last_bearing: float | None = None
        self._last_step = 0.0
        self.sweep = 0.0  # rad of head rotation covered by this scan's beams

    def add_beam(self, beam: SonarBeam, pose: PlanarPose) -> WallLine | None:
        """Add a beam taken at `pose` (the navigator's, at the beam's time). When the beams
        cover a full turn, vote, start a new scan and return the wall (None if too weak)."""
        if self._last_bearing is not None:
            self._last_step = abs(wrap(beam.bearing - self._last_bearing))
            self.sweep += self._last_step
        self._last_bearing = beam.bearing
        self._last_pose = Pose2D(pose.x, pose.y, pose.psi)
        r = echo_range(beam, self.threshold, self.min_range)
        if r is not None and r <= self.max_range:
            self._points.append((pose.x, pose.y, wrap(pose.psi + beam.bearing), r))
        if self.sweep + self._last_step < 2.0 * math.pi - 1e-9:  # each beam covers one step
            return None
        line = self.detect()
        self.reset()
        return line

    def detect(self) -> WallLine | None:
        """Vote with the points collected so far; the best line, or None below min_votes."""
        self.accumulator[:] = 0
        if not self._points or self._last_pose is None:
            return None
        origin = self._last_pose
        ox, oy, phi, r = (np.array(c)[:, None] for c in zip(*self._points, strict=True))
        th = self.thetas[None, :]
        # incidence of the arc's edges on each candidate normal (Eqs. 9, 10)
        d_lo = phi - self.alpha / 2 - th
        d_lo = d_lo - 2.0 * np.pi * np.round(d_lo / (2.0 * np.pi))
        lo = np.maximum(d_lo, -self.beta)
        hi = np.minimum(d_lo + self.alpha, self.beta)
        seen = lo <= hi
        # Eq. (11) over the admissible part of the arc: rho is largest nearest normal incidence
        rho_max = r * np.cos(np.clip(0.0, lo, np.maximum(lo, hi)))
        rho_min = r * np.cos(np.maximum(np.abs(lo), np.abs(hi)))
        shift = (ox - origin.x) * np.cos(th) + (oy - origin.y) * np.sin(th)  # to the origin
        k_lo = np.rint((rho_min + shift) / self.rho_step).astype(np.int64)
        k_hi = np.rint((rho_max + shift) / self.rho_step).astype(np.int64)
        n_rho = self.rhos.size
        seen &= (k_hi >= 0) & (k_lo < n_rho)
        col = np.broadcast_to(np.arange(self.thetas.size)[None, :], seen.shape)[seen]
        k_lo, k_hi = np.maximum(k_lo[seen], 0), np.minimum(k_hi[seen], n_rho - 1)
        diff = np.zeros((self.thetas.size, n_rho + 1), np.int64)  # votes on rho intervals
        np.add.at(diff, (col, k_lo), 1)
        np.add.at(diff, (col, k_hi + 1), -1)
        self.accumulator[:] = np.cumsum(diff, axis=1)[:, :n_rho]
        j, k = np.unravel_index(int(np.argmax(self.accumulator)), self.accumulator.shape)
        votes = int(self.accumulator[j, k])
        if votes < self.min_votes:
            return None
        theta = float(self.thetas[j])
        rho = float(self.rhos[k]) + origin.x * math.cos(theta) + origin.y * math.sin(theta)
        return WallLine(rho, theta, votes, len(self._points), origin)


class Estimate(NamedTuple):
    value: float
    std: float


class WallTracker:
    """EKF on the wall line (§5.2-§5.5), state x = [V_rho (m), V_theta (rad), W_theta (rad)].

    After each call the prior (x_prior, P_prior), the innovation y, its covariance S, the gain
    K and the squared Mahalanobis distance of the last sonar point (mahalanobis) are left for
    inspection, filterpy style. Angles' residuals go through `residual` (wrapped by default).
    """

    def __init__(self, x: ArrayLike, P: ArrayLike, *, Q: ArrayLike | None = None,
                 gate: float = CHI2_1DOF_99, threshold: float = THRESHOLD,
                 min_range: float = MIN_RANGE, alpha: float = ALPHA, beta: float = BETA,
                 residual: Callable[[float, float], float] = angle_residual) -> None:
        self.x: FloatArray = np.array(x, dtype=float).reshape(3)
        self.P: FloatArray = np.array(P, dtype=float).reshape(3, 3)
        # §5.3: white noise for the perturbations of the (otherwise static) line, per second:
        # 2 cm/sqrt(s) in distance, 0.5 deg/sqrt(s) in relative angle, 0.05 deg/sqrt(s) for the
        # wall's world orientation (a gently curved wall turns slowly as the vehicle moves along).
        default_q = np.diag([0.02**2, math.radians(0.5) ** 2, math.radians(0.05) ** 2])
        self.Q: FloatArray = default_q if Q is None else np.array(Q, dtype=float).reshape(3, 3)
        self.gate, self.threshold, self.min_range = gate, threshold, min_range
        self.alpha, self.beta, self.residual = alpha, beta, residual
        self.x_prior, self.P_prior = self.x.copy(), self.P.copy()
        self.y = np.zeros(1)
        self.S = np.zeros((1, 1))
        self.K = np.zeros((3, 1))
        self.mahalanobis = 0.0  # D^2 of the last sonar point (Eq. 28)
        self.n_accepted = 0  # sonar points that passed the gate
        self.n_rejected = 0  # sonar points the gate refused
        self.n_unseen = 0  # sonar points beyond the incidence limit beta: not the wall

    @classmethod
    def from_detection(cls, line: WallLine, pose: PlanarPose | None = None, *,
                       sigma_psi: float, sigma_rho: float = 0.05,
                       sigma_theta: float = math.radians(1.0), **kwargs: Any) -> WallTracker:
        """Initialise from the Hough winner seen from `pose` (default: the scan's last pose)
        (Eqs. 12-15). sigma_rho and sigma_theta are the accumulator's resolution (§5.2),
        sigma_psi the navigator's heading uncertainty (rad)."""
        pose = line.pose if pose is None else pose
        v_theta = wrap(line.theta - pose.psi)
        x = [line.distance_from(pose.x, pose.y), v_theta, wrap(line.theta)]
        s2 = sigma_theta**2
        P = [[sigma_rho**2, 0.0, 0.0], [0.0, s2, s2], [0.0, s2, s2 + sigma_psi**2]]  # Eq. (15)
        return cls(x, P, **kwargs)

    def predict(self, dt: float, u: float = 0.0, v: float = 0.0, r: float = 0.0,
                Q: ArrayLike | None = None) -> None:
        """Move the vehicle for dt seconds at body velocities u (surge, m/s), v (sway, m/s),
        r (yaw rate, rad/s) from the navigator; the wall stays put in the world (§5.3)."""
        rho, v_theta, w_theta = self.x.tolist()  # Python floats: numpy's scalars' arithmetic
        half = 0.5 * r * dt  # displacement in the old vehicle frame, mid-interval heading
        dx = (u * math.cos(half) - v * math.sin(half)) * dt
        dy = (u * math.sin(half) + v * math.cos(half)) * dt
        c, s = math.cos(v_theta), math.sin(v_theta)
        self.x = np.array([rho - dx * c - dy * s, wrap(v_theta - r * dt), w_theta])
        F = IDENTITY.copy()
        F[0, 1] = dx * s - dy * c
        Qk = (self.Q if Q is None else np.asarray(Q, dtype=float)) * dt
        self.P = F @ self.P @ F.T + Qk
        self.x_prior, self.P_prior = self.x.copy(), self.P.copy()

    def update_heading(self, psi: float, R: float) -> None:
        """The heading sensor sees psi = W_theta - V_theta (Eqs. 13, 18, 19); R in rad^2."""
        H = np.array([[0.0, -1.0, 1.0]])
        self.y = np.array([self.residual(psi, self.x[2] - self.x[1])])
        self._correct(H, self.y, np.array([[R]]))

    def update_point(self, rho_p: float, theta_p: float, R: ArrayLike) -> bool:
        """A sonar point at range rho_p (m) and bearing theta_p (rad, vehicle frame) as an
        implicit measurement of a point on the line (§5.5); R is the covariance of
        (rho_p, theta_p). True if it passed the Mahalanobis gate and updated the line."""
        if abs(self.residual(theta_p, self.x[1])) > self.beta + self.alpha / 2:
            self.n_unseen += 1  # the modified sonar model cannot see the wall there (§5.1)
            return False
        h, H1, H2G = implicit_measurement(self.x, rho_p, theta_p)
        R_line = H2G @ np.asarray(R, dtype=float).reshape(2, 2) @ H2G.T  # Eq. (28), 2nd term
        self.y = np.array([-h])  # the measurement says h = 0 (Eq. 25)
        S = H1 @ self.P @ H1.T + R_line
        # Eq. (28): y S^-1 y with S of one row, as np.linalg.solve works it out (y times 1/S)
        self.mahalanobis = float(self.y[0] * (self.y[0] * (1.0 / float(S[0, 0]))))
        if self.mahalanobis >= self.gate:
            self.n_rejected += 1
            self.S = S
            return False
        self.n_accepted += 1
        self._correct(H1, self.y, R_line)  # Eqs. (30)-(32)
        return True

    def update_beam(self, beam: SonarBeam, R: ArrayLike | None = None) -> bool | None:
        """Update with the beam's highest-intensity bin, if any (None when it has none). R
        defaults to one bin in range and half the aperture in bearing."""
        rho_p = echo_range(beam, self.threshold, self.min_range)
        if rho_p is None:
            return None
        if R is None:
            R = np.diag([beam.bin_size**2, (self.alpha / 2) ** 2])
        return self.update_point(rho_p, beam.bearing, R)

    def _correct(self, H: FloatArray, y: FloatArray, R: FloatArray) -> None:
        PHT = self.P @ H.T
        self.S = H @ PHT + R
        # S^-1: 1/S for the one row of every measurement here, as np.linalg.inv gives it
        self.K = (PHT * (1.0 / float(self.S[0, 0])) if self.S.shape == (1, 1)
                  else PHT @ np.linalg.inv(self.S))
        x = self.x + self.K @ y
        self.x = np.array([x[0], wrap(x[1]), wrap(x[2])])
        # Joseph form, P = (I - KH) P (I - KH)' + K R K': stays symmetric and positive
        # definite where the paper's Eq. (32), P = (I - KH) P, can lose both to round-off.
        I_KH = IDENTITY - self.K @ H
        self.P = I_KH @ self.P @ I_KH.T + self.K @ R @ self.K.T

    def distance_to_wall(self) -> Estimate:
        """Distance from the vehicle to the wall (m) and its standard deviation."""
        return Estimate(float(self.x[0]), math.sqrt(self.P[0, 0]))

    def relative_heading(self) -> Estimate:
        """Heading relative to the wall's normal, psi - W_theta = -V_theta (rad), and its
        standard deviation; 0 when facing the wall perpendicularly."""
        return Estimate(wrap(-float(self.x[1])), math.sqrt(self.P[1, 1]))


def implicit_measurement(x: FloatArray, rho_p: float,
                         theta_p: float) -> tuple[float, FloatArray, FloatArray]:
    """h(x, z) = V_rho - x_p cos V_theta - y_p sin V_theta (Eqs. 24, 27) with its Jacobians
    H_M1 = dh/dx (1x3) and H_M2 G = dh/dp dg/dz (1x2, Eq. 29)."""
    c, s = math.cos(x[1]), math.sin(x[1])
    xp, yp = rho_p * math.cos(theta_p), rho_p * math.sin(theta_p)
    h = float(x[0] - xp * c - yp * s)
    H1 = np.array([[1.0, xp * s - yp * c, 0.0]])
    H2 = np.array([[-c, -s]])
    G = np.array([[math.cos(theta_p), -rho_p * math.sin(theta_p)],
                  [math.sin(theta_p), rho_p * math.cos(theta_p)]])
    return h, H1, H2 @ G
