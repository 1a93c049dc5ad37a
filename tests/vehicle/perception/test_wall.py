"""The wall detector and tracker (paper 002 §5) against a simulated MSIS and a known wall.

The beam simulator below is self-contained: a Gaussian beam pattern of width alpha whose rays
meet the wall (a line) at ranges dist / cos(incidence), with an echo that weakens with the
incidence, multiplicative speckle, background noise, near-field clutter of the sonar head,
and optional outlier returns stronger than the wall (fish, debris).
"""

from __future__ import annotations

import math
from collections.abc import Iterator
from dataclasses import dataclass

import numpy as np
import pytest

from vehicle.perception.wall import (
    ALPHA,
    CHI2_1DOF_95,
    CHI2_1DOF_99,
    Pose2D,
    SonarBeam,
    WallDetector,
    WallLine,
    WallTracker,
    echo_range,
    implicit_measurement,
    wrap,
)

BIN = 0.05  # m
N_BINS = 200  # 10 m range
STEP = math.radians(1.8)  # head step: 200 beams a turn
DT = 0.05  # s between beams: a 10 s scan
THRESHOLD, MIN_RANGE = 0.4, 0.5


@dataclass(frozen=True)
class Line:
    rho: float  # world: p . (cos theta, sin theta) = rho
    theta: float

    def distance(self, x: float, y: float) -> float:
        return self.rho - (x * math.cos(self.theta) + y * math.sin(self.theta))


def simulate_beam(rng: np.random.Generator, t: float, pose: Pose2D, bearing: float, wall: Line,
                  outlier_prob: float = 0.0) -> tuple[SonarBeam, float | None]:
    """One beam and the range of the injected outlier (None if none)."""
    ranges = (np.arange(N_BINS) + 0.5) * BIN
    rays = np.linspace(-ALPHA, ALPHA, 15)  # Gaussian beam pattern, full width at half max alpha
    weights = np.exp(-0.5 * (rays / (ALPHA / 2.355)) ** 2)
    weights /= weights.sum()
    incidence = wrap(pose.psi + bearing - wall.theta) + rays
    front = np.abs(incidence) < math.radians(85)
    hit = wall.distance(pose.x, pose.y) / np.cos(incidence[front])
    gain = weights[front] * np.cos(incidence[front]) ** 0.5
    echo = (gain * np.exp(-0.5 * ((ranges[:, None] - hit) / BIN) ** 2)).sum(axis=1)
    bins = echo * rng.gamma(8.0, 1 / 8.0, N_BINS) + rng.rayleigh(0.05, N_BINS)
    bins[ranges < 0.35] += rng.uniform(0.6, 1.2, int((ranges < 0.35).sum()))  # sonar head
    outlier = None
    if rng.random() < outlier_prob:
        i = int(rng.integers(int(MIN_RANGE / BIN) + 1, N_BINS - 1))
        bins[i] += 1.5
        outlier = (i + 0.5) * BIN
    return SonarBeam(t, wrap(bearing), bins, BIN), outlier


def scan(rng: np.random.Generator, wall: Line, pose0: Pose2D, u: float = 0.0, v: float = 0.0,
         r: float = 0.0) -> Iterator[tuple[SonarBeam, Pose2D]]:
    """One 360 deg scan while the vehicle moves at constant body velocities."""
    x, y, psi = pose0.x, pose0.y, pose0.psi
    for i in range(200):
        pose = Pose2D(x, y, psi)
        yield simulate_beam(rng, i * DT, pose, i * STEP, wall)[0], pose
        x += (u * math.cos(psi) - v * math.sin(psi)) * DT
        y += (u * math.sin(psi) + v * math.cos(psi)) * DT
        psi = wrap(psi + r * DT)


def run_scan(rng: np.random.Generator, wall: Line, pose0: Pose2D, **motion: float
             ) -> tuple[WallLine | None, Pose2D, WallDetector]:
    detector = WallDetector(threshold=THRESHOLD, min_range=MIN_RANGE)
    results = [(detector.add_beam(beam, pose), pose) for beam, pose in scan(rng, wall, pose0,
                                                                            **motion)]
    assert all(line is None for line, _ in results[:-1])  # one full turn, one answer
    line, last = results[-1]
    return line, last, detector


WALL = Line(rho=-1.3, theta=math.radians(7.3))  # off the accumulator's grid


@pytest.mark.parametrize("motion", [{}, {"u": 0.05, "v": 0.2, "r": math.radians(0.5)}],
                         ids=["static", "moving"])
def test_detector_finds_the_wall_in_one_scan(motion: dict[str, float]) -> None:
    rng = np.random.default_rng(1)
    line, last, _ = run_scan(rng, WALL, Pose2D(-4.9, 1.2, math.radians(12)), **motion)
    assert line is not None and line.votes >= 30
    assert abs(wrap(line.theta - WALL.theta)) < math.radians(1.5)
    assert abs(line.distance_from(last.x, last.y) - WALL.distance(last.x, last.y)) < 0.10
    assert abs(line.rho - WALL.rho) < 0.10


def test_detector_needs_the_pose_of_every_beam() -> None:
    """A scan turning at 3 deg/s voted once with each beam's pose and once as if the vehicle
    had stood at its last pose: only the first finds the wall, with far more votes."""
    rng = np.random.default_rng(1)
    beams = list(scan(rng, WALL, Pose2D(-4.9, 1.2, math.radians(12)), u=0.05, v=0.2,
                      r=math.radians(3)))
    moving = WallDetector(threshold=THRESHOLD, min_range=MIN_RANGE)
    frozen = WallDetector(threshold=THRESHOLD, min_range=MIN_RANGE)
    last = beams[-1][1]
    good = [moving.add_beam(beam, pose) for beam, pose in beams][-1]
    bad = [frozen.add_beam(beam, last) for beam, _ in beams][-1]
    assert good is not None and bad is not None
    assert abs(good.rho - WALL.rho) < 0.10 and abs(wrap(good.theta - WALL.theta)) < 0.02
    assert abs(bad.rho - WALL.rho) > 0.10 and bad.votes < 0.7 * good.votes


def test_no_wall_no_line() -> None:
    rng = np.random.default_rng(2)
    line, _, detector = run_scan(rng, Line(rho=50.0, theta=0.0), Pose2D(0.0, 0.0, 0.0))
    assert line is None and detector.sweep == 0.0  # and a new scan has begun


def test_hough_agrees_with_a_least_squares_fit() -> None:
    """Cross-check: a total least-squares line through the thresholded points (numpy SVD)."""
    rng = np.random.default_rng(3)
    pose0 = Pose2D(-2.2, 0.0, math.radians(-5))
    beams = list(scan(rng, WALL, pose0, v=0.1))
    detector = WallDetector(threshold=THRESHOLD, min_range=MIN_RANGE)
    line = [detector.add_beam(b, p) for b, p in beams][-1]
    assert line is not None
    points = []
    for beam, pose in beams:
        r = echo_range(beam, THRESHOLD, MIN_RANGE)
        if r is not None:
            phi = pose.psi + beam.bearing
            points.append((pose.x + r * math.cos(phi), pose.y + r * math.sin(phi)))
    p = np.array(points)
    centre = p.mean(axis=0)
    normal = np.linalg.svd(p - centre)[2][-1]
    if normal @ (centre - np.array([pose0.x, pose0.y])) < 0:  # from the vehicle to the wall
        normal = -normal
    assert len(points) >= 40
    assert abs(wrap(math.atan2(normal[1], normal[0]) - line.theta)) < math.radians(1.5)
    assert abs(float(centre @ normal) - line.rho) < 0.08


def test_implicit_measurement_jacobians_match_finite_differences() -> None:
    x, z = np.array([2.0, 0.3, 0.1]), np.array([2.4, 0.1])
    h, H1, H2G = implicit_measurement(x, *z)
    e = 1e-6
    for i in range(3):
        dx = np.eye(3)[i] * e
        assert (implicit_measurement(x + dx, *z)[0] - h) / e == pytest.approx(H1[0, i], abs=1e-5)
    for i in range(2):
        dz = np.eye(2)[i] * e
        assert (implicit_measurement(x, *(z + dz))[0] - h) / e == pytest.approx(H2G[0, i],
                                                                               abs=1e-5)


def test_one_sonar_update_by_hand() -> None:
    """Facing the wall (V_theta = 0), a point straight ahead at 2.1 m, the line at 2.0 m:
    h = 2.0 - 2.1 = -0.1; H_M1 = [1, 0, 0]; H_M2 G = [-1, 0] so R_line = sigma_r^2 = 0.01;
    S = 0.04 + 0.01 = 0.05; K = [0.8, 0, 0]; D^2 = 0.01 / 0.05 = 0.2;
    rho = 2.0 - 0.8 * (-0.1) = 2.08; P_rho = 0.04 * 0.01 / 0.05 = 0.008; the angles untouched."""
    P0 = np.diag([0.04, 0.01, 0.02])
    f = WallTracker([2.0, 0.0, 0.0], P0)
    assert f.update_point(2.1, 0.0, np.diag([0.01, 0.0004]))
    assert f.S[0, 0] == pytest.approx(0.05) and f.mahalanobis == pytest.approx(0.2)
    assert f.K[:, 0] == pytest.approx([0.8, 0.0, 0.0])
    assert f.x == pytest.approx([2.08, 0.0, 0.0])
    assert f.P == pytest.approx(np.diag([0.008, 0.01, 0.02]))
    assert (f.n_accepted, f.n_rejected) == (1, 0)


def test_one_oblique_sonar_update_by_hand() -> None:
    """The same with V_theta = 0.1 and a point at bearing 0.3, every term written out."""
    rho, th, rp, tp, sr2, st2 = 2.0, 0.1, 2.05, 0.3, 0.0025, 0.0007
    P0 = np.array([[0.04, 0.0, 0.0], [0.0, 0.01, 0.01], [0.0, 0.01, 0.03]])
    xp, yp = rp * math.cos(tp), rp * math.sin(tp)
    h = rho - xp * math.cos(th) - yp * math.sin(th)
    a = xp * math.sin(th) - yp * math.cos(th)  # dh/dV_theta
    # dh/drho_p = -cos(tp - th), dh/dtheta_p = -rp sin(th - tp)
    r_line = math.cos(tp - th) ** 2 * sr2 + (rp * math.sin(th - tp)) ** 2 * st2
    S = 0.04 + a * a * 0.01 + r_line
    K = np.array([0.04, a * 0.01, a * 0.01]) / S
    f = WallTracker([rho, th, 0.3], P0)
    assert f.update_point(rp, tp, np.diag([sr2, st2]))
    assert f.S[0, 0] == pytest.approx(S)
    assert f.K[:, 0] == pytest.approx(K)
    assert f.x == pytest.approx(np.array([rho, th, 0.3]) - K * h)
    H = np.array([1.0, a, 0.0])
    assert f.P == pytest.approx(P0 - np.outer(K, H @ P0))  # Joseph = simple form at optimal K


def test_heading_update_by_hand() -> None:
    """psi = W_theta - V_theta (Eq. 13): H = [0, -1, 1]; across the +-pi seam the residual
    is wrapped: predicted 3.1 - (-0.1) -> -3.083..., measured -3.1: y = -0.0168..."""
    P0 = np.array([[0.04, 0.0, 0.0], [0.0, 0.01, 0.01], [0.0, 0.01, 0.03]])
    f = WallTracker([2.0, -0.1, 3.1], P0)
    f.update_heading(-3.1, 0.0001)
    y = wrap(-3.1 - wrap(3.1 + 0.1))
    S = 0.01 + 0.03 - 2 * 0.01 + 0.0001  # var(W) + var(V) - 2 cov + R
    K = np.array([0.0, 0.01 - 0.01, 0.03 - 0.01]) / S
    assert f.y[0] == pytest.approx(y) and abs(y) < 0.02
    assert f.S[0, 0] == pytest.approx(S)
    assert f.x == pytest.approx([2.0, -0.1, wrap(3.1 + K[2] * y)])


def test_chi_square_constants() -> None:
    stats = pytest.importorskip("scipy.stats")
    assert stats.chi2.ppf(0.95, 1) == pytest.approx(CHI2_1DOF_95)
    assert stats.chi2.ppf(0.99, 1) == pytest.approx(CHI2_1DOF_99)


def test_gate_rejects_points_off_the_line() -> None:
    f = WallTracker([1.5, 0.05, 0.05], np.diag([0.01**2, math.radians(1) ** 2,
                                                 math.radians(1) ** 2]))
    R = np.diag([BIN**2, (ALPHA / 2) ** 2])
    x0 = f.x.copy()
    for bearing in np.radians([-40, -10, 0, 15, 45]):
        on_wall = 1.5 / math.cos(bearing - 0.05)
        assert not f.update_point(on_wall - 0.6, bearing, R)  # a fish in front of the wall
        assert not f.update_point(on_wall + 1.0, bearing, R)  # a return behind it
    assert f.x == pytest.approx(x0) and (f.n_accepted, f.n_rejected) == (0, 10)
    assert not f.update_point(1.5, math.radians(100), R) and f.n_unseen == 1  # beyond beta
    assert f.update_point(1.5 / math.cos(0.3 - 0.05) + 0.01, 0.3, R)
    assert f.n_accepted == 1


def truth(t: float) -> tuple[float, float, float, float, float, float]:
    """Vehicle along the dam wall (x = 0): x, y, psi and body velocities u, v, r."""
    w_d, w_psi = 2 * math.pi / 60, 2 * math.pi / 45
    x, vx = -(1.5 + 0.4 * math.sin(w_d * t)), -0.4 * w_d * math.cos(w_d * t)  # 1.1 .. 1.9 m
    y, vy = 0.1 * t, 0.1
    psi, r = math.radians(4) * math.sin(w_psi * t), math.radians(4) * w_psi * math.cos(w_psi * t)
    c, s = math.cos(psi), math.sin(psi)
    return x, y, psi, c * vx + s * vy, -s * vx + c * vy, r


def track_along_the_wall(seed: int, outlier_prob: float
                         ) -> tuple[WallTracker, np.ndarray, np.ndarray, list[float]]:
    """Detect on the first scan, then track for 150 s; distance and heading errors and the
    ranges (off the wall) of the outliers injected in front of the vehicle. The navigator's
    compass and DVL are noisy and biased."""
    rng = np.random.default_rng(seed)
    wall = Line(0.0, 0.0)
    sigma_psi, sigma_v, sigma_r = math.radians(1.0), 0.01, math.radians(0.2)
    psi_bias, u_bias = math.radians(1.0), 0.01
    detector = WallDetector(threshold=THRESHOLD, min_range=MIN_RANGE)
    tracker: WallTracker | None = None
    d_err, h_err, outliers = [], [], []
    for k in range(3000):
        t = k * DT
        x, y, psi, u, v, r = truth(t)
        beam, outlier = simulate_beam(rng, t, Pose2D(x, y, psi), k * STEP, wall, outlier_prob)
        psi_meas = psi + psi_bias + rng.normal(0, sigma_psi)
        if tracker is None:
            line = detector.add_beam(beam, Pose2D(x, y, psi_meas))
            if line is not None:
                tracker = WallTracker.from_detection(line, Pose2D(x, y, psi_meas),
                                                     sigma_psi=sigma_psi, threshold=THRESHOLD,
                                                     min_range=MIN_RANGE)
            continue
        tracker.predict(DT, u + u_bias + rng.normal(0, sigma_v), v + rng.normal(0, sigma_v),
                        r + rng.normal(0, sigma_r))
        tracker.update_heading(psi_meas, sigma_psi**2)
        tracker.update_beam(beam)
        if outlier is not None and abs(wrap(beam.bearing + psi)) < math.radians(55):
            outliers.append(outlier - (-x) / math.cos(beam.bearing + psi))
        d_err.append(tracker.distance_to_wall().value - (-x))
        h_err.append(wrap(tracker.relative_heading().value - psi))
    assert tracker is not None
    return tracker, np.array(d_err), np.array(h_err), outliers


@pytest.mark.parametrize("seed", [4, 5])
def test_tracker_accuracy_along_the_wall(seed: int) -> None:
    tracker, d_err, h_err, _ = track_along_the_wall(seed, outlier_prob=0.0)
    assert len(d_err) > 2700
    assert math.sqrt(np.mean(d_err**2)) < 0.10  # m, the project's target
    assert math.degrees(math.sqrt(np.mean(h_err**2))) < 2.0  # deg, the project's target
    d, h = tracker.distance_to_wall(), tracker.relative_heading()
    assert 0.0 < d.std < 0.10 and 0.0 < h.std < math.radians(2)
    assert tracker.n_accepted > 850  # of ~930 beams that saw the wall


def test_tracker_gates_outliers_along_the_wall() -> None:
    """10 % of the beams carry a return stronger than the wall at a random range: the ones
    well off the wall and in view are refused, and the accuracy holds."""
    tracker, d_err, h_err, outliers = track_along_the_wall(6, outlier_prob=0.1)
    far = [o for o in outliers if abs(o) > 0.5]
    assert len(far) > 50
    assert tracker.n_rejected >= 0.9 * len(far)
    assert tracker.n_rejected < len(outliers) + 0.05 * tracker.n_accepted  # few good ones lost
    assert math.sqrt(np.mean(d_err**2)) < 0.10
    assert math.degrees(math.sqrt(np.mean(h_err**2))) < 2.0
