"""The expendable UUV's navigation model (paper 003 §4, eq. 2 and the state model printed as a
second "(3)").

State, in the target frame {T} (origin above the target, x north, y east, z down):
``[u, w, r, b, x, y, z, psi, x_c, y_c]`` — surge, heave and yaw rate (body frame), the buoyancy
bias b (weight minus buoyancy, N, added to the heave force), position, heading and the current.

Each controlled degree of freedom follows eq. 2, ``alpha v' + beta(v) v = tau + tau_E`` with
``beta(v) = beta_v + beta_vv |v|`` (the paper writes ``beta_v v + beta_vv |v|`` and then
multiplies by v again: we read the drag as linear plus quadratic, as eq. 3's
``beta_u(u) u`` says). The kinematics: ``x' = u cos psi + x_c``, ``y' = u sin psi + y_c``,
``z' = w``, ``psi' = r``; b and the current are random walks (the printed eq. 3 runs
``psi' = r``, ``x_c' = xi_xc`` and ``y_c' = xi_yc`` together on one line: a printing error).
The input is ``tau = [X, Z, N]`` (surge force, heave force, yaw moment): sway is not
controlled and roll and pitch are passive (§4, assumption 1).

Discretised by Euler at the control loop's step (10 Hz, §4): ``x_k+1 = x_k + dt g(x_k, tau)``,
with the Jacobian ``F = I + dt dg/dx`` for the EKF and the process noise
``Q = diag(q^2) dt`` (q per state, per square-root second: the noise vector of eq. 3, plus a
little on the kinematics for the model's own errors). The parameters are the identified ones
of a small expendable vehicle (the paper identifies them by self-oscillation, [17], and gives
no figures); :class:`UuvModel` carries them so that the simulated vehicle and the navigator
can share them or differ on purpose.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Protocol

import numpy as np
import numpy.typing as npt

FloatArray = npt.NDArray[np.float64]

STATE = ("u", "w", "r", "b", "x", "y", "z", "psi", "x_c", "y_c")
U, W, R, B, X, Y, Z, PSI, XC, YC = range(10)
DIM = len(STATE)


def wrap_angle(a: float) -> float:
    """An angle wrapped to [-pi, pi)."""
    return (a + math.pi) % (2.0 * math.pi) - math.pi


class ProcessModel(Protocol):
    """What the navigator needs of a model: one step, its Jacobian, the process noise."""

    def step(self, x: FloatArray, tau: FloatArray, dt: float) -> FloatArray:
        """The state one step of dt seconds later under the input tau."""
        ...

    def jacobian(self, x: FloatArray, tau: FloatArray, dt: float) -> FloatArray:
        """d step / d x at x."""
        ...

    def noise(self, dt: float) -> FloatArray:
        """The process noise covariance Q of one step."""
        ...


@dataclass(frozen=True)
class UuvModel:
    """Eq. 2 for surge, heave and yaw, with eq. 3's kinematics; SI units (kg, N s/m, ...).

    Defaults: a 30 kg torpedo-shaped vehicle; 25 N of surge force gives about 0.9 m/s."""

    alpha_u: float = 36.0  # mass + added mass in surge, kg
    beta_u: float = 10.0  # linear surge drag, N s/m
    beta_uu: float = 20.0  # quadratic surge drag, N s^2/m^2
    alpha_w: float = 50.0
    beta_w: float = 25.0
    beta_ww: float = 40.0
    alpha_r: float = 4.0  # yaw inertia + added inertia, kg m^2
    beta_r: float = 4.0
    beta_rr: float = 2.0
    # process noise q (1 sigma per square-root second) for u w r b x y z psi x_c y_c
    q: tuple[float, ...] = (0.03, 0.03, 0.02, 0.05, 0.02, 0.02, 0.01, 0.005, 0.003, 0.003)

    def derivative(self, x: FloatArray, tau: FloatArray) -> FloatArray:
        """g(x, tau) = dx/dt of eq. 3 without noise."""
        u, w, r, b = float(x[U]), float(x[W]), float(x[R]), float(x[B])
        psi = float(x[PSI])
        d = np.zeros(DIM)
        d[U] = (-(self.beta_u + self.beta_uu * abs(u)) * u + float(tau[0])) / self.alpha_u
        d[W] = (-(self.beta_w + self.beta_ww * abs(w)) * w + float(tau[1]) + b) / self.alpha_w
        d[R] = (-(self.beta_r + self.beta_rr * abs(r)) * r + float(tau[2])) / self.alpha_r
        d[X] = u * math.cos(psi) + float(x[XC])
        d[Y] = u * math.sin(psi) + float(x[YC])
        d[Z] = w
        d[PSI] = r
        return d

    def step(self, x: FloatArray, tau: FloatArray, dt: float) -> FloatArray:
        nxt: FloatArray = x + dt * self.derivative(x, tau)
        nxt[PSI] = wrap_angle(float(nxt[PSI]))
        return nxt

    def jacobian(self, x: FloatArray, tau: FloatArray, dt: float) -> FloatArray:
        u, w, r, psi = float(x[U]), float(x[W]), float(x[R]), float(x[PSI])
        c, s = math.cos(psi), math.sin(psi)
        G = np.zeros((DIM, DIM))
        # d/dv of (beta_v + beta_vv |v|) v is beta_v + 2 beta_vv |v|
        G[U, U] = -(self.beta_u + 2.0 * self.beta_uu * abs(u)) / self.alpha_u
        G[W, W] = -(self.beta_w + 2.0 * self.beta_ww * abs(w)) / self.alpha_w
        G[W, B] = 1.0 / self.alpha_w
        G[R, R] = -(self.beta_r + 2.0 * self.beta_rr * abs(r)) / self.alpha_r
        G[X, U], G[X, PSI], G[X, XC] = c, -u * s, 1.0
        G[Y, U], G[Y, PSI], G[Y, YC] = s, u * c, 1.0
        G[Z, W] = 1.0
        G[PSI, R] = 1.0
        F: FloatArray = np.eye(DIM) + dt * G
        return F

    def noise(self, dt: float) -> FloatArray:
        Q: FloatArray = np.diag(np.square(np.asarray(self.q, dtype=float)) * dt)
        return Q
