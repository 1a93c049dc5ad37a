"""The navigator: an EKF over [x y z psi u v w r] (paper 002 §4).

State (eq. 1): world position and heading, body velocities over ground. System model (eq. 3):
four-DOF constant velocity, the accelerations n = [n_u n_v n_w n_r] white noise (eq. 4-5)
integrated into velocity (n t) and position (n t^2 / 2, through the heading for x and y);
here n is white with variance accel_std^2 / t over a step of t seconds, so that Q does not
depend on how often ``predict`` is called (the paper leaves Q's values to experiment).
Measurements (eq. 6-7), each a direct, linear observation of part of the state: DVL (u v w),
pressure (z), MRU-FOG heading (psi, residual wrapped), USBL (x y z with its full covariance).
Initialisation (§4.2, eq. 2): position and its covariance from the first buoy fix, heading from
the compass, velocities zero with some uncertainty.

USBL fixes pass the individual compatibility test (the Mahalanobis test of eq. 28, with which
§7 discards buoy outliers): D^2 = y^T S^-1 y must be below the chi-square value of the chosen
confidence for 3 degrees of freedom, else the fix is rejected and counted.

Staying bounded (not in the paper): the constant-velocity model's small accelerations hold while
the DVL measures velocity; without bottom lock (on or near the floor, or too high above it)
the velocity is unobserved and the vehicle's real accelerations (up to 0.5 m/s^2) would soon
make every fix fail the gate and the estimate run away. So after :meth:`dvl_lost` the
prediction uses ``unaided_accel_std`` until the next DVL update, and after ``reacquire_after``
consecutive rejected fixes that agree with one another (successive fixes within
``reacquire_jump`` m) the navigator takes the last one as a new first fix (§4.2: position and
its covariance from the fix, the velocity's uncertainty widened), counted in ``usbl_reacquired``.

Shaped like filterpy: ``predict(dt)``, ``update_*(z, R=None)``; inspectable ``x``, ``P``,
``x_prior``/``P_prior``, ``x_post``/``P_post``, the last innovation ``y``, its covariance
``S``, gain ``K`` and ``mahalanobis``. The heading residual and the state's heading wrap are
injectable functions. Units: m, rad, s.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from vehicle.world.robot import FloatArray, wrap_angle
from vehicle.sensors.instruments import (
    DEPTH_STD,
    DVL_ACCURACY,
    DVL_NOISE_FLOOR,
    HEADING_STD,
    USBL_ANGLE_STD,
    USBL_RANGE_FRACTION,
    dvl_std,
    usbl_covariance,
)

# chi-square quantiles for 3 degrees of freedom (a USBL fix)
CHI2_3DOF: dict[float, float] = {0.95: 7.815, 0.99: 11.345, 0.999: 16.266}

X, Y, Z, PSI, U, V, W, R = range(8)


def angle_residual(a: FloatArray, b: FloatArray) -> FloatArray:
    """a - b with the difference wrapped to (-pi, pi] (for heading innovations)."""
    d = np.asarray(a, dtype=np.float64) - np.asarray(b, dtype=np.float64)
    wrapped: FloatArray = (d + np.pi) % (2.0 * np.pi) - np.pi
    return wrapped


def plain_residual(a: FloatArray, b: FloatArray) -> FloatArray:
    d: FloatArray = np.asarray(a, dtype=np.float64) - np.asarray(b, dtype=np.float64)
    return d


@dataclass(frozen=True)
class NavigatorNoise:
    """Process noise (eq. 5, set empirically in the paper) and the sensors' figures used when an
    update is called without R (Table I)."""

    # n of eq. 3-5: 1 sigma of each acceleration averaged over one second (m/s^2, rad/s^2);
    # tuned on the simulated survey (tests/vehicle/perception/test_navigator.py): NEES about half its dimension
    accel_std: tuple[float, float, float, float] = (0.05, 0.05, 0.05, 0.02)
    # the same without the DVL: what the thrusters can do (44 N on 90-120 kg, 8.8 N m)
    unaided_accel_std: tuple[float, float, float, float] = (0.3, 0.3, 0.3, 0.05)
    dvl_accuracy: float = DVL_ACCURACY
    dvl_floor: float = DVL_NOISE_FLOOR  # m/s
    depth_std: float = DEPTH_STD  # m
    heading_std: float = HEADING_STD  # rad
    usbl_angle_std: float = USBL_ANGLE_STD  # rad
    usbl_range_fraction: float = USBL_RANGE_FRACTION


class Navigator:
    """EKF of §4. ``x`` (8,), ``P`` (8, 8) are the current estimate and its covariance."""

    dim_x = 8

    def __init__(self, x0: npt.ArrayLike, P0: npt.ArrayLike, noise: NavigatorNoise | None = None,
                 *, transceiver: npt.ArrayLike | None = None, gate_confidence: float = 0.99,
                 gate_threshold: float | None = None, reacquire_after: int = 5,
                 reacquire_jump: float = 2.0,
                 residual_heading: Callable[[FloatArray, FloatArray], FloatArray] = angle_residual,
                 wrap_heading: Callable[[float], float] = wrap_angle) -> None:
        self.x: FloatArray = np.array(x0, dtype=float).reshape(8)
        self.P: FloatArray = np.array(P0, dtype=float).reshape(8, 8)
        self.noise = noise or NavigatorNoise()
        self.transceiver = None if transceiver is None else np.asarray(transceiver, dtype=float)
        self.gate_threshold = (CHI2_3DOF[gate_confidence] if gate_threshold is None
                               else gate_threshold)
        self.residual_heading = residual_heading
        self.wrap_heading = wrap_heading
        self.x[PSI] = wrap_heading(float(self.x[PSI]))
        self.Q: FloatArray = np.zeros((8, 8))  # last discrete process noise G Q G^T
        self.F: FloatArray = np.eye(8)  # last Jacobian of eq. 3
        self.y: FloatArray = np.zeros(0)  # last innovation
        self.S: FloatArray = np.zeros((0, 0))  # its covariance
        self.K: FloatArray = np.zeros((8, 0))  # last gain
        self.mahalanobis = 0.0  # sqrt(D^2) of the last USBL fix tested
        self.usbl_accepted = 0
        self.usbl_rejected = 0
        self.usbl_reacquired = 0  # times the estimate was reset to a fix (see above)
        self.reacquire_after, self.reacquire_jump = reacquire_after, reacquire_jump
        self.velocity_aided = True  # False from dvl_lost() to the next DVL update
        self._rejected_run: list[FloatArray] = []  # consecutive rejected fixes
        self.x_prior, self.P_prior = self.x.copy(), self.P.copy()
        self.x_post, self.P_post = self.x.copy(), self.P.copy()

    @classmethod
    def from_first_fix(cls, position: npt.ArrayLike, position_cov: npt.ArrayLike,
                       heading: float, noise: NavigatorNoise | None = None,
                       velocity_std: tuple[float, float, float, float] = (0.1, 0.1, 0.1, 0.05),
                       *, transceiver: npt.ArrayLike | None = None,
                       gate_confidence: float = 0.99) -> Navigator:
        """§4.2, eq. 2: x(0) = [x_U y_U z_U psi_C 0 0 0 0], P(0) block-diagonal with the fix's
        full covariance, the compass variance and the velocity variances."""
        noise = noise or NavigatorNoise()
        x0 = np.zeros(8)
        x0[:3], x0[PSI] = np.asarray(position, dtype=float), heading
        P0 = np.zeros((8, 8))
        P0[:3, :3] = np.asarray(position_cov, dtype=float)
        P0[PSI, PSI] = noise.heading_std**2
        P0[4:, 4:] = np.diag(np.square(velocity_std))
        return cls(x0, P0, noise, transceiver=transceiver, gate_confidence=gate_confidence)

    # --- prediction (eq. 3) -------------------------------------------------------------------
    def predict(self, dt: float) -> None:
        """Propagate the state dt seconds with the constant-velocity model."""
        if dt < 0.0:
            raise ValueError(f"dt must be >= 0, got {dt}")
        x, t = self.x, dt
        # the state as Python floats: the same arithmetic as numpy's scalars, at less cost
        _, _, _, psi, u, v, w, r = x.tolist()
        c, s = math.cos(psi), math.sin(psi)
        F = IDENTITY.copy()
        F[X, PSI], F[X, U], F[X, V] = -(u * s + v * c) * t, c * t, -s * t
        F[Y, PSI], F[Y, U], F[Y, V] = (u * c - v * s) * t, s * t, c * t
        F[Z, W] = F[PSI, R] = t
        h = 0.5 * t * t  # the accelerations' effect on position: n t^2 / 2
        G = np.zeros((8, 4))
        G[X, 0], G[X, 1] = h * c, -h * s
        G[Y, 0], G[Y, 1] = h * s, h * c
        G[Z, 2] = G[PSI, 3] = h
        G[U, 0] = G[V, 1] = G[W, 2] = G[R, 3] = t
        # n is white: averaged over a step of t seconds its variance is accel_std^2 / t, so
        # that the uncertainty added over a stretch of time does not depend on how often
        # predict is called (with a fixed variance per step it would).
        accel = self.noise.accel_std if self.velocity_aided else self.noise.unaided_accel_std
        var = np.square(accel) / t if t > 0.0 else np.zeros(4)
        self.Q = G @ np.diag(var) @ G.T
        self.F = F
        x_new = x.copy()
        x_new[X] += (u * c - v * s) * t
        x_new[Y] += (u * s + v * c) * t
        x_new[Z] += w * t
        x_new[PSI] = self.wrap_heading(psi + r * t)
        self.x = x_new
        self.P = F @ self.P @ F.T + self.Q
        self.x_prior, self.P_prior = self.x.copy(), self.P.copy()

    # --- updates (eq. 6-7) --------------------------------------------------------------------
    def update_dvl(self, z: npt.ArrayLike, R: npt.ArrayLike | None = None) -> None:
        """Body velocities u, v, w (m/s). R defaults to Table I's 0.2 % with the noise floor,
        diagonal; pass the full R of the DVL's beam geometry (§4.4) where it is known."""
        zz = np.asarray(z, dtype=float).reshape(3)
        if R is None:
            R = np.diag(dvl_std(zz, self.noise.dvl_accuracy, self.noise.dvl_floor) ** 2)
        self.velocity_aided = True
        self._update(zz, _rows(U, V, W), R, plain_residual)

    def dvl_lost(self) -> None:
        """The DVL has no bottom lock: predict with the unaided accelerations until it has."""
        self.velocity_aided = False

    def update_depth(self, z: float, R: npt.ArrayLike | None = None) -> None:
        """Depth from the pressure sensor (m)."""
        R = self.noise.depth_std**2 if R is None else R
        self._update(np.array([z], dtype=float), _rows(Z), R, plain_residual)

    def update_heading(self, z: float, R: npt.ArrayLike | None = None) -> None:
        """Heading from the MRU-FOG (rad); the innovation is wrapped by ``residual_heading``."""
        R = self.noise.heading_std**2 if R is None else R
        self._update(np.array([z], dtype=float), _rows(PSI), R, self.residual_heading)

    def update_usbl(self, z: npt.ArrayLike, R: npt.ArrayLike | None = None) -> bool:
        """A buoy fix of x, y, z (m) with its full covariance R; False if the individual
        compatibility test rejects it (the estimate is then left untouched)."""
        zz = np.asarray(z, dtype=float).reshape(3)
        if R is None:
            if self.transceiver is None:
                raise ValueError("update_usbl needs R, or a transceiver position to compute it")
            R = usbl_covariance(self.transceiver, zz, self.noise.usbl_angle_std,
                                self.noise.usbl_range_fraction)
        H = _rows(X, Y, Z)
        RR = np.asarray(R, dtype=float).reshape(3, 3)
        y = zz - H @ self.x
        S = H @ self.P @ H.T + RR
        d2 = float(y @ np.linalg.solve(S, y))  # squared Mahalanobis distance, eq. 28
        self.mahalanobis = math.sqrt(d2)
        if d2 > self.gate_threshold:
            self.y, self.S = y, S
            self.usbl_rejected += 1
            run = self._rejected_run
            if run and float(np.linalg.norm(zz - run[-1])) > self.reacquire_jump:
                run.clear()  # not the same story: an outlier among them
            run.append(zz)
            if len(run) >= self.reacquire_after:
                self._reacquire(zz, RR)
            return False
        self._rejected_run.clear()
        self._update(zz, H, RR, plain_residual)
        self.usbl_accepted += 1
        return True

    def _reacquire(self, z: FloatArray, R: FloatArray) -> None:
        """Start again from the fix z (§4.2): the estimate had left the vehicle behind."""
        self._rejected_run.clear()
        self.usbl_reacquired += 1
        self.x[:3] = z
        P = self.P.copy()
        P[:3, :] = 0.0
        P[:, :3] = 0.0
        P[:3, :3] = R
        speed_var = np.square(self.noise.unaided_accel_std[:3])  # m/s after a second of it
        for i, j in ((U, 0), (V, 1), (W, 2)):
            P[i, :] = P[:, i] = 0.0
            P[i, i] = max(float(self.P[i, i]), float(speed_var[j]))
        self.P = P
        self.x_post, self.P_post = self.x.copy(), self.P.copy()

    def _update(self, z: FloatArray, H: FloatArray, R: npt.ArrayLike,
                residual: Callable[[FloatArray, FloatArray], FloatArray]) -> None:
        RR = np.atleast_2d(np.asarray(R, dtype=float))
        P = self.P
        self.y = residual(z, H @ self.x)
        self.S = H @ P @ H.T + RR
        if self.S.shape == (1, 1):  # one measurement: what solve gives, without its calls
            self.K = (H @ P).T * (1.0 / float(self.S[0, 0]))  # P H^T S^-1
        else:
            self.K = np.asarray(np.linalg.solve(self.S, H @ P).T, dtype=np.float64)
        self.x = self.x + self.K @ self.y
        self.x[PSI] = self.wrap_heading(float(self.x[PSI]))
        # Joseph form, P = (I - K H) P (I - K H)^T + K R K^T: symmetric and positive
        # semi-definite for any gain, unlike (I - K H) P which loses both to round-off.
        I_KH = IDENTITY - self.K @ H
        self.P = I_KH @ P @ I_KH.T + self.K @ RR @ self.K.T
        self.x_post, self.P_post = self.x.copy(), self.P.copy()


IDENTITY: FloatArray = np.eye(8)  # I of the state's size, never written to
IDENTITY.setflags(write=False)


@functools.cache
def _rows(*indices: int) -> FloatArray:
    """H selecting the given state elements (made once for each, and never written to)."""
    H = np.zeros((len(indices), 8))
    for i, j in enumerate(indices):
        H[i, j] = 1.0
    H.setflags(write=False)
    return H
