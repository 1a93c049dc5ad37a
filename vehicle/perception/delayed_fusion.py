"""Fusing a measurement that arrives late (paper 003 §4.3): the stored history of the filter and
the two exact ways of bringing a past measurement into the present.

The navigator keeps, for each 100 ms step of the last few seconds, a :class:`Step`: the input
over the step, the Jacobian of the prediction into it, the prior, the measurements applied at
it in order (undelayed first, then delayed ones whose ping fell in that step) with the
innovation and gain each had, and the posterior. A fix pinged at step s and arriving at step k
is put at the end of step s's measurements, then brought to k by one of:

* :func:`repropagate` — "applying the correction in the past and propagating the filter into
  the present": re-run the EKF from s to k from the stored inputs and measurements,
  re-linearising the model at the corrected states (N_s prediction/correction steps).
* :func:`larsen_correct` — Larsen et al. (1998), eq. 5: the correction ``delta_s = K_s (y_s -
  H_s x_s)`` carried to k through ``(I - K'_t H_t) A_t-1``, with K' the gains of the covariance
  that includes the fix. Larsen updates the covariance at s "as if the measurement was
  available", which needs to know at s that a fix will come; on paper 003's one-way link the
  UUV learns of a ping only when its message arrives (and a lost message never does), so the
  covariance is updated when the fix arrives, from the stored covariances, and the correction
  gets a second term ``(K'_t - K_t) nu_t`` for the gains the filter actually used (it is zero
  when the covariance was updated at s, which is eq. 5 exactly). The stored Jacobians A are
  not re-linearised and the states are corrected linearly: on a linear model this equals the
  re-propagation to rounding; on the EKF it is Larsen's approximation (§4.3: the Jacobian
  depends only on heading and surge, which the fix barely changes).

Both leave the history as the filter with the fix would have had it, so that a later fix whose
ping falls between s and k finds the right state.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from vehicle.perception.uuv_model import DIM, PSI, FloatArray, ProcessModel, wrap_angle


@dataclass
class Update:
    """One measurement as applied: y = H x + v, v ~ N(0, R); ``angular`` rows wrap (heading).

    ``innovation`` and ``gain`` are those of the last time it was applied."""

    kind: str  # "compass" | "depth" | "visual" | "fix"
    y: FloatArray
    H: FloatArray
    R: FloatArray
    angular: bool = False
    innovation: FloatArray = field(default_factory=lambda: np.zeros(0))
    gain: FloatArray = field(default_factory=lambda: np.zeros((DIM, 0)))


@dataclass
class Step:
    """The filter at one step: its time, the input over the step ending here, the measured
    depth (None: none), the prediction's Jacobian, prior, measurements and posterior."""

    t: float
    tau: FloatArray
    depth: float | None
    F: FloatArray
    x_prior: FloatArray
    P_prior: FloatArray
    updates: list[Update]
    x: FloatArray
    P: FloatArray


def residual(update: Update, x: FloatArray) -> FloatArray:
    """y - H x, heading rows wrapped to [-pi, pi)."""
    nu: FloatArray = update.y - update.H @ x
    if update.angular:
        nu = (nu + np.pi) % (2.0 * np.pi) - np.pi
    return nu


def joseph(P: FloatArray, K: FloatArray, H: FloatArray, R: FloatArray) -> FloatArray:
    """(I - K H) P (I - K H)^T + K R K^T: the covariance update that stays symmetric and
    positive under rounding."""
    A = np.eye(P.shape[0]) - K @ H
    out: FloatArray = A @ P @ A.T + K @ R @ K.T
    return out


def gain(P: FloatArray, update: Update) -> tuple[FloatArray, FloatArray]:
    """The Kalman gain K = P H^T S^-1 and the innovation covariance S."""
    S: FloatArray = update.H @ P @ update.H.T + update.R
    K: FloatArray = np.asarray(np.linalg.solve(S, update.H @ P).T, dtype=np.float64)  # S^-1 H P, transposed (S symmetric)
    return K, S


def apply(x: FloatArray, P: FloatArray, update: Update) -> tuple[FloatArray, FloatArray]:
    """One sequential EKF correction (eq. 4); records its innovation and gain in ``update``."""
    K, _ = gain(P, update)
    nu = residual(update, x)
    x = x + K @ nu
    x[PSI] = wrap_angle(float(x[PSI]))
    update.innovation, update.gain = nu, K
    return x, joseph(P, K, update.H, update.R)


def mahalanobis2(x: FloatArray, P: FloatArray, update: Update) -> float:
    """nu^T S^-1 nu of the measurement against (x, P): the gate on fixes."""
    _, S = gain(P, update)
    nu = residual(update, x)
    return float(nu @ np.linalg.solve(S, nu))


def repropagate(steps: list[Step], s: int, model: ProcessModel, Q: FloatArray,
                dt: float) -> None:
    """Re-run the filter from step s's prior (all of step s's measurements, the new fix last)
    to the last step, in place."""
    x, P = steps[s].x_prior, steps[s].P_prior
    for i in range(s, len(steps)):
        step = steps[i]
        if i > s:
            step.F = model.jacobian(x, step.tau, dt)
            x = model.step(x, step.tau, dt)
            P = step.F @ P @ step.F.T + Q
            step.x_prior, step.P_prior = x.copy(), P.copy()
        for update in step.updates:
            x, P = apply(x, P, update)
        step.x, step.P = x.copy(), P.copy()


def larsen_correct(steps: list[Step], s: int, Q: FloatArray) -> None:
    """Larsen's correction of the history from step s, whose last update is the new fix, to
    the last step, in place (see the module's docstring)."""
    step = steps[s]
    fix = step.updates[-1]
    x_before, P = step.x, step.P  # step s's posterior before the fix
    x, P = apply(x_before, P, fix)
    d: FloatArray = x - x_before  # delta_s = K_s (y_s - H_s x_s)
    step.x, step.P = x, P
    for i in range(s + 1, len(steps)):
        step = steps[i]
        d = step.F @ d  # the correction carried through A_t-1
        P = step.F @ P @ step.F.T + Q
        step.x_prior = step.x_prior + d
        step.x_prior[PSI] = wrap_angle(float(step.x_prior[PSI]))
        step.P_prior = P.copy()
        for update in step.updates:
            K_new, _ = gain(P, update)
            nu_run = update.innovation
            nu_new = nu_run - update.H @ d  # the innovation the corrected filter sees
            if update.angular:
                nu_new = (nu_new + np.pi) % (2.0 * np.pi) - np.pi
            d = d - K_new @ (update.H @ d) + (K_new - update.gain) @ nu_run
            P = joseph(P, K_new, update.H, update.R)
            update.innovation, update.gain = nu_new, K_new
        x = step.x + d
        x[PSI] = wrap_angle(float(x[PSI]))
        step.x, step.P = x, P.copy()
