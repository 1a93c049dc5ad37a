"""The expendable UUV's navigator (paper 003 §4): an EKF at the control loop's 10 Hz over
``[u, w, r, b, x, y, z, psi, x_c, y_c]`` in the target frame {T}, fed by the thrusters' forces,
the compass and the depth sensor every step, the camera near the target (§4.2, without delay)
and the ASV's sonar fixes over the one-way acoustic link (§4.1, about 2 s late).

The model is :class:`~vehicle.perception.uuv_model.UuvModel` (eq. 2-3); the fix geometry and its
covariance are :mod:`vehicle.perception.sonar_fix`. A fix is computed with the UUV's own depth
measured at the ping (the ASV cannot know it), read from the stored history, whatever the
method. Measurements are fused sequentially, undelayed first (§4.3, [9]): the compass and
depth given to :meth:`UuvNavigator.predict`, then the camera's, then the sonar fixes.

Three ways to fuse a late fix (``method``), as compared in §4.3:

* ``"naive"`` — the fix is used as if it were measured now (the state at arrival);
* ``"repropagate"`` — applied at the ping's step and the filter re-run to now from the stored
  inputs and measurements (the exact EKF);
* ``"larsen"`` — Larsen et al. (1998)'s correction, eq. 5 (see
  :mod:`vehicle.perception.delayed_fusion` for how it is done on a one-way link).

A fix whose innovation's Mahalanobis distance exceeds ``gate`` (chi-square, 2 degrees of
freedom) is rejected and counted (§4: the model "helps in smoothing and ignoring false
measurements and outliers"); a fix pinged before the stored history is dropped and counted.

Use: ``nav = UuvNavigator(method="larsen", dt=0.1)``; every step ``nav.predict(t, tau,
compass, depth)`` with tau = [X, Z, N] the forces over the step ending at t; ``nav.visual(t,
rel_xy)`` when the camera sees the target; ``nav.fix(t_ping, R, eps, asv_xy, t_now)`` when a
fix arrives (after that step's predict); ``nav.estimate()`` gives the state and covariance.
Times are the UUV's clock, in seconds.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from vehicle.perception.delayed_fusion import (
    Step,
    Update,
    apply,
    larsen_correct,
    mahalanobis2,
    repropagate,
)
from vehicle.perception.sonar_fix import FixNoise, sonar_fix
from vehicle.perception.uuv_model import (
    DIM,
    PSI,
    XC,
    YC,
    B,
    FloatArray,
    ProcessModel,
    R,
    U,
    UuvModel,
    W,
    X,
    Y,
    Z,
)

METHODS = ("naive", "repropagate", "larsen")
CHI2_2DOF_999 = 13.816  # the 0.999 quantile of chi-square with 2 degrees of freedom


@dataclass(frozen=True)
class SensorNoise:
    """One sigma of the UUV's own sensors: compass (rad), depth (m), camera fix (m)."""

    compass_std: float = math.radians(2.0)
    depth_std: float = 0.05
    visual_std: float = 0.1


def initial_covariance() -> FloatArray:
    """P(0) at release: the UUV knows only roughly where the ASV dropped it."""
    std = np.zeros(DIM)
    std[[U, W, R, B]] = (0.3, 0.1, 0.05, 5.0)
    std[[X, Y, Z, PSI]] = (20.0, 20.0, 0.5, math.pi)
    std[[XC, YC]] = (0.3, 0.3)
    P: FloatArray = np.diag(std ** 2)
    return P


@dataclass(frozen=True)
class FixRecord:
    """What became of the last sonar fix: the position it gave (computed with the depth at
    the ping), its variance per axis, the steps it was late, and whether it was fused."""

    t_ping: float
    t_now: float
    xy: tuple[float, float]
    depth: float
    variance: float
    late_steps: int
    fused: bool
    reason: str  # "" when fused; "gate", "too old"


def rows(*indices: int) -> FloatArray:
    """H selecting the given state components."""
    H = np.zeros((len(indices), DIM))
    for i, j in enumerate(indices):
        H[i, j] = 1.0
    return H


class UuvNavigator:
    """The EKF of §4 with one of the three delayed-fusion methods (see the module)."""

    def __init__(self, method: str = "repropagate", dt: float = 0.1, *,
                 model: ProcessModel | None = None, x0: npt.ArrayLike | None = None,
                 P0: npt.ArrayLike | None = None, fix_noise: FixNoise | None = None,
                 sensors: SensorNoise | None = None, history: float = 10.0,
                 gate: float | None = CHI2_2DOF_999, sonar_depth: float = 0.0) -> None:
        if method not in METHODS:
            raise ValueError(f"unknown fusion method {method!r}: use one of {', '.join(METHODS)}")
        if dt <= 0.0:
            raise ValueError(f"the step dt must be > 0 s, got {dt}")
        self.method, self.dt = method, dt
        self.model: ProcessModel = model or UuvModel()
        self.Q = self.model.noise(dt)
        self.fix_noise = fix_noise or FixNoise()
        self.sensors = sensors or SensorNoise()
        self.history_steps = max(1, round(history / dt))
        self.gate, self.sonar_depth = gate, sonar_depth
        self.x0_given = x0 is not None
        self.x0: FloatArray = (np.zeros(DIM) if x0 is None
                               else np.array(x0, dtype=float).reshape(DIM))
        self.P0: FloatArray = (initial_covariance() if P0 is None
                               else np.array(P0, dtype=float).reshape(DIM, DIM))
        self.steps: list[Step] = []
        self.fixes_fused = 0
        self.fixes_gated = 0
        self.fixes_too_old = 0
        self.last_fix: FixRecord | None = None

    # --- the loop ----------------------------------------------------------------------------
    @property
    def t(self) -> float:
        """The time of the current step (nan before the first predict)."""
        return self.steps[-1].t if self.steps else math.nan

    def estimate(self) -> tuple[FloatArray, FloatArray]:
        """The current state and its covariance (copies)."""
        if not self.steps:
            return self.x0.copy(), self.P0.copy()
        return self.steps[-1].x.copy(), self.steps[-1].P.copy()

    def predict(self, t: float, tau: Sequence[float] | FloatArray, compass: float | None,
                depth: float | None) -> None:
        """Advance to time t under the forces tau = [X, Z, N] (held over the steps since the
        last call), then fuse the compass (rad) and depth (m) read at t (None: no reading)."""
        force = np.asarray(tau, dtype=float).reshape(3)
        if not self.steps:
            self.start(t, force, compass, depth)
        else:
            n = round((t - self.steps[-1].t) / self.dt)
            for _ in range(n):
                self.advance(force)
        step = self.steps[-1]
        if depth is not None:
            step.depth = depth
            self.correct(step, Update("depth", np.array([depth]), rows(Z),
                                      np.array([[self.sensors.depth_std ** 2]])))
        if compass is not None:
            self.correct(step, Update("compass", np.array([compass]), rows(PSI),
                                      np.array([[self.sensors.compass_std ** 2]]), angular=True))

    def start(self, t: float, tau: FloatArray, compass: float | None,
              depth: float | None) -> None:
        """The first step: x0, or without it the heading and depth of the first readings."""
        x = self.x0.copy()
        if not self.x0_given:
            x[PSI] = 0.0 if compass is None else compass
            x[Z] = 0.0 if depth is None else depth
        self.steps.append(Step(t, tau, None, np.eye(DIM), x.copy(), self.P0.copy(), [],
                               x, self.P0.copy()))

    def advance(self, tau: FloatArray) -> None:
        """One prediction step of dt (eq. 3), stored; the history keeps its last seconds."""
        last = self.steps[-1]
        F = self.model.jacobian(last.x, tau, self.dt)
        x = self.model.step(last.x, tau, self.dt)
        P = F @ last.P @ F.T + self.Q
        self.steps.append(Step(last.t + self.dt, tau, None, F, x.copy(), P.copy(), [], x, P))
        if len(self.steps) > self.history_steps + 1:
            del self.steps[0]

    def correct(self, step: Step, update: Update) -> None:
        """Apply an update to the current step and record it there."""
        step.x, step.P = apply(step.x, step.P, update)
        step.updates.append(update)

    # --- the camera (§4.2) --------------------------------------------------------------------
    def visual(self, t: float, rel_xy: Sequence[float], std: float | None = None) -> None:
        """The camera's fix: the UUV's (x, y) relative to the target, i.e. in {T}, measured
        at t without delay (applied at the current step); std defaults to the camera's."""
        if not self.steps:
            raise ValueError("visual() before the first predict(): the navigator has no time yet")
        sigma = self.sensors.visual_std if std is None else std
        self.correct(self.steps[-1], Update("visual", np.asarray(rel_xy, dtype=float).reshape(2),
                                            rows(X, Y), np.eye(2) * sigma ** 2))

    # --- the sonar fix (§4.1, §4.3) -----------------------------------------------------------
    def fix(self, t_ping: float, R: float, eps: float, asv_xy: Sequence[float], t_now: float,
            *, asv_heading: float | None = None) -> bool:
        """A sonar fix pinged at t_ping and received at t_now: slant range R (m), bearing eps
        (rad; absolute, or in the sonar head when ``asv_heading`` is given: psi_ASV + eps) and
        the ASV's (x, y) in {T} at the ping. Fused at once by the chosen method; True if fused."""
        if not self.steps:
            raise ValueError("fix() before the first predict(): the navigator has no time yet")
        bearing = eps if asv_heading is None else asv_heading + eps
        s = round((t_ping - self.steps[0].t) / self.dt)
        late = len(self.steps) - 1 - s
        if s < 0:
            self.fixes_too_old += 1
            self.last_fix = FixRecord(t_ping, t_now, (math.nan, math.nan), math.nan, math.nan,
                                      late, False, "too old")
            return False
        s = min(s, len(self.steps) - 1)
        ping = self.steps[s]
        depth = (ping.depth if ping.depth is not None else float(ping.x[Z])) - self.sonar_depth
        xy = sonar_fix(R, bearing, (float(asv_xy[0]), float(asv_xy[1])), depth)
        variance = self.fix_noise.variance(R)
        update = Update("fix", np.array(xy), rows(X, Y), np.eye(2) * variance)
        at = self.steps[-1] if self.method == "naive" else ping
        if self.gate is not None and mahalanobis2(at.x, at.P, update) > self.gate:
            self.fixes_gated += 1
            self.last_fix = FixRecord(t_ping, t_now, xy, depth, variance, late, False, "gate")
            return False
        if self.method == "naive":
            self.correct(at, update)
        elif self.method == "repropagate":
            ping.updates.append(update)
            repropagate(self.steps, s, self.model, self.Q, self.dt)
        else:
            ping.updates.append(update)
            larsen_correct(self.steps, s, self.Q)
        self.fixes_fused += 1
        self.last_fix = FixRecord(t_ping, t_now, xy, depth, variance, late, True, "")
        return True
