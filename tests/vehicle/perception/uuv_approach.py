"""A light ground truth for the UUV's navigator: a straight-line approach to the target of
paper 003 with the ASV's fixes over a delayed, lossy one-way link (for the tests and
bench/bench_uuv_navigator.py; the full world and vehicles are vehicle/world/'s).

The UUV is released at ``start`` in {T} (target at the origin), holds ``hold_depth`` until the
ASV acquires it (``acquired_at``), then runs at constant surge force towards the target,
descending to ``target_depth`` in proportion to the distance covered (the line of §2). It is
steered by its true position — the navigator is not in the loop, so the three fusion methods
see one and the same run. The ASV holds station at ``asv_xy`` with its sonar at the surface;
from ``acquired_at`` it pings every ``fix_period`` s; each fix reaches the UUV after a delay
drawn in ``delay`` (whole 100 ms steps) unless lost with probability ``loss``. Within
``visibility`` m of the target the camera gives the position at ``visual_period``.

``exact=True`` is the filter's own model: the truth stepped by ``UuvModel.step`` with noise
drawn from its Q, and fixes whose position error is exactly the navigator's declared variance
(for the consistency test); otherwise the truth integrates at 50 Hz with its own small force
noise and the fixes come from noisy range and bearing (for the bench).
"""

from __future__ import annotations

import math
import random
from dataclasses import dataclass, field

import numpy as np

from vehicle.perception.sonar_fix import FixNoise
from vehicle.perception.uuv_model import PSI, XC, YC, B, FloatArray, UuvModel, W, X, Y, Z
from vehicle.perception.uuv_model import R as YAW_RATE
from vehicle.perception.uuv_model import wrap_angle
from vehicle.perception.uuv_navigator import SensorNoise, UuvNavigator, initial_covariance


@dataclass(frozen=True)
class Approach:
    """The scenario (SI units; times in s)."""

    start: tuple[float, float] = (-30.0, 10.0)
    hold_depth: float = 2.0
    target_depth: float = 12.0
    surge_force: float = 25.0  # N: about 0.9 m/s
    current: tuple[float, float] = (0.08, -0.06)
    buoyancy_bias: float = 2.0  # N, heavier than water
    asv_xy: tuple[float, float] = (-4.0, 6.0)
    acquired_at: float = 6.0
    fix_period: float = 2.0
    delay: tuple[float, float] = (1.5, 2.5)
    loss: float = 0.0
    visibility: float = 3.0
    visual_period: float = 0.2
    arrive_within: float = 1.0  # m: the run ends this close to the target (horizontally)
    duration: float = 90.0
    dt: float = 0.1


@dataclass(frozen=True)
class FixMessage:
    """A sonar fix as it reaches the UUV."""

    t_ping: float
    t_now: float
    slant_range: float
    bearing: float
    asv_xy: tuple[float, float]


@dataclass
class Tick:
    """One 100 ms step of the run: what the UUV's navigator is given, and the truth."""

    t: float
    tau: FloatArray
    compass: float
    depth: float
    truth: FloatArray
    visual: tuple[float, float] | None = None
    fixes: list[FixMessage] = field(default_factory=list)


@dataclass
class Run:
    """A simulated approach: the ticks, and the fixes sent and lost."""

    ticks: list[Tick]
    sent: int = 0
    lost: int = 0


def control(x: FloatArray, a: Approach, t: float, depth0: float) -> FloatArray:
    """Line of sight to the target from the true state; depth hold, then the descent."""
    heading = math.atan2(-float(x[Y]), -float(x[X]))
    N = 6.0 * wrap_angle(heading - float(x[PSI])) - 4.0 * float(x[YAW_RATE])
    if t < a.acquired_at:
        z_ref, X_force = a.hold_depth, 0.0
    else:
        covered = 1.0 - math.hypot(float(x[X]), float(x[Y])) / depth0
        z_ref = a.hold_depth + (a.target_depth - a.hold_depth) * min(max(covered, 0.0), 1.0)
        X_force = a.surge_force
    Z_force = 60.0 * (z_ref - float(x[Z])) - 40.0 * float(x[W]) - a.buoyancy_bias
    return np.array([X_force, max(min(Z_force, 30.0), -30.0), max(min(N, 5.0), -5.0)])


def initial_truth(a: Approach, rng: np.random.Generator, exact: bool) -> FloatArray:
    x = np.zeros(10)
    x[X], x[Y], x[Z] = a.start[0], a.start[1], a.hold_depth
    x[PSI] = math.atan2(-a.start[1], -a.start[0])
    x[B], x[XC], x[YC] = a.buoyancy_bias, a.current[0], a.current[1]
    if exact:  # drawn from the navigator's prior around its initial guess
        x = guess(a) + np.linalg.cholesky(initial_covariance()) @ rng.standard_normal(10)
        x[PSI] = wrap_angle(float(x[PSI]))
        x[Z] = abs(float(x[Z]))
    return x


def guess(a: Approach) -> FloatArray:
    """The navigator's x0: released at the ASV's estimate of the start, heading to the target."""
    x = np.zeros(10)
    x[X], x[Y], x[Z] = a.start[0], a.start[1], a.hold_depth
    x[PSI] = math.atan2(-a.start[1], -a.start[0])
    return x


def simulate(a: Approach, seed: int, *, exact: bool = False,
             model: UuvModel | None = None, fix_noise: FixNoise | None = None,
             sensors: SensorNoise | None = None) -> Run:
    """One approach, seeded: the navigator's inputs every step and the true state."""
    model, fix_noise = model or UuvModel(), fix_noise or FixNoise()
    sensors = sensors or SensorNoise()
    rng, coin = np.random.default_rng(seed), random.Random(seed)
    x = initial_truth(a, rng, exact)
    depth0 = math.hypot(float(x[X]), float(x[Y]))
    Qchol: FloatArray = np.asarray(np.linalg.cholesky(model.noise(a.dt)), dtype=np.float64)
    run, pending = Run([]), []
    tau = np.zeros(3)
    steps = round(a.duration / a.dt)
    for k in range(steps + 1):
        t = k * a.dt
        if k > 0:  # the force chosen at the last step, held over this one
            x = truth_step(x, tau, a, model, rng, Qchol, exact)
        tick = Tick(t, tau, wrap_angle(float(x[PSI]) + sensors.compass_std * rng.standard_normal()),
                    float(x[Z]) + sensors.depth_std * rng.standard_normal(), x.copy())
        if t >= a.acquired_at and (k - round(a.acquired_at / a.dt)) % round(a.fix_period / a.dt) == 0:
            run.sent += 1
            msg = ping(x, t, tick.depth, a, fix_noise, rng, exact)
            if coin.random() < a.loss:
                run.lost += 1
            else:
                late = round(coin.uniform(*a.delay) / a.dt)
                pending.append((k + late, msg))
        tick.fixes = [m for due, m in pending if due == k]
        tick.fixes = [FixMessage(m.t_ping, t, m.slant_range, m.bearing, m.asv_xy)
                      for m in tick.fixes]
        pending = [(due, m) for due, m in pending if due != k]
        if math.hypot(float(x[X]), float(x[Y])) < a.visibility and k % round(a.visual_period / a.dt) == 0:
            s = sensors.visual_std
            tick.visual = (float(x[X]) + s * rng.standard_normal(),
                           float(x[Y]) + s * rng.standard_normal())
        run.ticks.append(tick)
        tau = control(x, a, t, depth0)
        if t >= a.acquired_at and math.hypot(float(x[X]), float(x[Y])) < a.arrive_within:
            break
    return run


def truth_step(x: FloatArray, tau: FloatArray, a: Approach, model: UuvModel,
               rng: np.random.Generator, Qchol: FloatArray, exact: bool) -> FloatArray:
    """The true state one step later."""
    if exact:
        nxt = model.step(x, tau, a.dt) + Qchol @ rng.standard_normal(10)
        nxt[PSI] = wrap_angle(float(nxt[PSI]))
        return nxt
    h = a.dt / 5
    for _ in range(5):  # 50 Hz, with a little force noise the model does not know
        force = tau + rng.normal(0.0, (1.0, 1.0, 0.2))
        x = x + h * model.derivative(x, force)
    x[PSI] = wrap_angle(float(x[PSI]))
    return x


def ping(x: FloatArray, t: float, depth_read: float, a: Approach, noise: FixNoise,
         rng: np.random.Generator, exact: bool) -> FixMessage:
    """The ASV's sonar fix of the UUV at x: slant range, absolute bearing, its position."""
    dx, dy = float(x[X]) - a.asv_xy[0], float(x[Y]) - a.asv_xy[1]
    if exact:  # the position error is exactly N(0, variance I); depth as the UUV reads it
        R0 = math.sqrt(dx * dx + dy * dy + depth_read * depth_read)
        e = math.sqrt(noise.variance(R0)) * rng.standard_normal(2)
        hx, hy = dx + e[0], dy + e[1]
        return FixMessage(t, t, math.sqrt(hx * hx + hy * hy + depth_read * depth_read),
                          math.atan2(hy, hx), a.asv_xy)
    slant = math.sqrt(dx * dx + dy * dy + float(x[Z]) ** 2) + noise.range_std * rng.standard_normal()
    bearing = math.atan2(dy, dx) + noise.bearing_std * rng.standard_normal()
    asv = (a.asv_xy[0] + noise.asv_std * rng.standard_normal(),
           a.asv_xy[1] + noise.asv_std * rng.standard_normal())
    # the ASV reports where its own navigation puts it; the sonar measured from the true spot
    return FixMessage(t, t, slant, bearing, asv)


def navigate(run: Run, nav: UuvNavigator) -> tuple[FloatArray, FloatArray]:
    """Feed the run to the navigator; the estimates (n, 10) and covariances (n, 10, 10)."""
    xs, Ps = [], []
    for tick in run.ticks:
        nav.predict(tick.t, tick.tau, tick.compass, tick.depth)
        if tick.visual is not None:
            nav.visual(tick.t, tick.visual)
        for m in tick.fixes:
            nav.fix(m.t_ping, m.slant_range, m.bearing, m.asv_xy, m.t_now)
        x, P = nav.estimate()
        xs.append(x)
        Ps.append(P)
    return np.array(xs), np.array(Ps)


def errors(run: Run, xs: FloatArray) -> FloatArray:
    """The state error per step, heading wrapped."""
    truth = np.array([tick.truth for tick in run.ticks])
    e: FloatArray = xs - truth
    e[:, PSI] = (e[:, PSI] + np.pi) % (2.0 * np.pi) - np.pi
    return e

