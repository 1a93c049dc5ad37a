"""The EKF navigator (vehicle/perception/navigator.py, paper 002 §4).

Driven with the simulated Ictineu and its sensors along a lawnmower survey in front of the
wall and checked against ground truth (accuracy, USBL outliers gated, NEES); cross-checked
against a textbook Kalman filter written here for the linear sub-problem of a known, constant
heading, and against hand computations of one update and of eq. 3.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
import pytest

from vehicle.perception.navigator import CHI2_3DOF, Navigator, NavigatorNoise
from vehicle.world.robot import Environment, Ictineu, VehicleState, wrap_angle
from vehicle.sensors.instruments import Sensors, Usbl, usbl_covariance
from vehicle.sensors.readings import DepthReading, DvlReading, HeadingReading, UsblFix

CHI2_8DOF_99 = 20.090


# --- the survey -------------------------------------------------------------------------------
def lawnmower(y0: float = 3.0, y1: float = 15.0, leg: float = 1.5, top: float = 2.0,
              bottom: float = 7.0, standoff: float = 1.5) -> list[tuple[float, float, float]]:
    """Vertical legs in front of the wall, ``leg`` apart, as in §7's survey."""
    points, y, down = [], y0, True
    while y <= y1 + 1e-9:
        a, b = (top, bottom) if down else (bottom, top)
        points += [(-standoff, y, a), (-standoff, y, b)]
        y, down = y + leg, not down
    return points


def pd(s: VehicleState, goal: tuple[float, float, float]) -> tuple[float, float, float, float]:
    """A hand-written PD controller on the true state: position in the body frame, yaw to 0."""
    ex, ey, ez = goal[0] - s.x, goal[1] - s.y, goal[2] - s.z
    c, sn = math.cos(s.psi), math.sin(s.psi)
    return (40.0 * (c * ex + sn * ey) - 60.0 * s.u, 40.0 * (-sn * ex + c * ey) - 60.0 * s.v,
            40.0 * ez - 60.0 * s.w + 5.9, 20.0 * wrap_angle(-s.psi) - 10.0 * s.r)


@dataclass
class Survey:
    t: list[float] = field(default_factory=list)
    error: list[np.ndarray] = field(default_factory=list)  # truth - estimate, heading wrapped
    nees: list[float] = field(default_factory=list)
    min_eig: float = math.inf
    asymmetry: float = 0.0
    outliers: int = 0
    outliers_rejected: int = 0
    good: int = 0
    good_rejected: int = 0
    usbl_position_nees: list[float] = field(default_factory=list)
    nav: Navigator | None = None


def fly(seed: int, outlier_probability: float, dt: float = 0.05) -> Survey:
    env = Environment(floor_depth=12.0, current=(0.0, 0.05, 0.0))
    rng = np.random.default_rng(seed)
    robot_rng, sensor_rng = rng.spawn(2)
    goals = lawnmower()
    robot = Ictineu(VehicleState(-1.5, 3.0, 2.0, 0.0), rng=robot_rng, env=env)
    sensors = Sensors(env, sensor_rng, usbl=Usbl(outlier_probability=outlier_probability))
    nav: Navigator | None = None
    out, k, t_nav = Survey(), 0, 0.0
    while k < len(goals):
        s = robot.state
        if math.dist((s.x, s.y, s.z), goals[k]) < 0.2:
            k += 1
            continue
        truth = robot.step(dt, pd(s, goals[k]))
        for reading in sensors.sample(robot.t, truth):
            if nav is None:  # §4.2: start from the first (clean) buoy fix and the compass
                if isinstance(reading, UsblFix) and not reading.injected_outlier:
                    nav = Navigator.from_first_fix(reading.position, reading.covariance,
                                                   truth.psi + math.radians(0.3))
                    t_nav = robot.t
                continue
            if not isinstance(reading, (DvlReading, DepthReading, HeadingReading, UsblFix)):
                continue
            nav.predict(robot.t - t_nav)
            t_nav = robot.t
            if isinstance(reading, DvlReading) and reading.velocity is not None:
                nav.update_dvl(reading.velocity)
            elif isinstance(reading, DepthReading):
                nav.update_depth(reading.depth)
            elif isinstance(reading, HeadingReading):
                nav.update_heading(reading.heading)
            elif isinstance(reading, UsblFix):
                e = truth.as_array()[:3] - nav.x[:3]
                accepted = nav.update_usbl(reading.position, reading.covariance)
                if reading.injected_outlier:
                    out.outliers += 1
                    out.outliers_rejected += not accepted
                else:
                    out.good += 1
                    out.good_rejected += not accepted
                    if accepted:
                        e = truth.as_array()[:3] - nav.x[:3]
                        out.usbl_position_nees.append(float(e @ np.linalg.solve(nav.P[:3, :3],
                                                                                 e)))
        if nav is not None and t_nav == robot.t:  # the estimate is for now
            e = truth.as_array() - nav.x
            e[3] = wrap_angle(e[3])
            out.t.append(robot.t)
            out.error.append(e)
            out.nees.append(float(e @ np.linalg.solve(nav.P, e)))
            out.min_eig = min(out.min_eig, float(np.linalg.eigvalsh(nav.P).min()))
            out.asymmetry = max(out.asymmetry, float(np.abs(nav.P - nav.P.T).max()))
    out.nav = nav
    return out


@pytest.fixture(scope="module")
def survey() -> Survey:
    return fly(seed=11, outlier_probability=0.1)


def test_horizontal_rms_error_with_usbl_is_under_half_a_metre(survey: Survey) -> None:
    e = np.array(survey.error)
    assert survey.t[-1] > 120.0  # nine 5 m legs and the moves between them
    horizontal = np.sqrt(np.mean(e[:, 0] ** 2 + e[:, 1] ** 2))
    assert horizontal < 0.5
    assert horizontal < 0.1  # measured about 0.02 m
    assert np.sqrt(np.mean(e[:, 2] ** 2)) < 0.05
    assert np.degrees(np.sqrt(np.mean(e[:, 3] ** 2))) < 0.5


def test_usbl_outliers_are_gated_out(survey: Survey) -> None:
    nav = survey.nav
    assert nav is not None
    assert survey.outliers >= 10
    assert survey.outliers_rejected / survey.outliers >= 0.9
    assert survey.good_rejected / survey.good <= 0.03
    assert nav.usbl_rejected == survey.outliers_rejected + survey.good_rejected
    assert nav.usbl_accepted + nav.usbl_rejected == survey.outliers + survey.good


def test_the_filter_is_consistent(survey: Survey) -> None:
    nees = np.array(survey.nees)
    assert 0.25 * 8 < nees.mean() < 1.5 * 8  # the CV model is rough: conservative on average
    assert np.mean(nees > CHI2_8DOF_99) < 0.05
    position = np.array(survey.usbl_position_nees)
    assert 0.3 * 3 < position.mean() < 2.0 * 3


def test_joseph_form_keeps_p_symmetric_and_positive(survey: Survey) -> None:
    assert survey.asymmetry < 1e-12 and survey.min_eig > 0.0


def test_the_default_three_percent_outliers() -> None:
    run = fly(seed=12, outlier_probability=0.03)
    assert run.outliers_rejected == run.outliers and run.good_rejected <= 0.03 * run.good
    e = np.array(run.error)
    assert np.sqrt(np.mean(e[:, 0] ** 2 + e[:, 1] ** 2)) < 0.5


# --- cross-checks -----------------------------------------------------------------------------
class TextbookKF:
    """x' = F x + w, z = H x + v for [x y z u v w] with the heading known and constant:
    position += R(psi) velocity dt; white acceleration of density q per axis (Q from the
    model: a held over dt with variance q/dt). Standard form update, no Joseph."""

    def __init__(self, x: np.ndarray, P: np.ndarray, psi: float, q: np.ndarray) -> None:
        self.x, self.P, self.q = x.copy(), P.copy(), q
        c, s = math.cos(psi), math.sin(psi)
        self.Rot = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])

    def predict(self, dt: float) -> None:
        F = np.block([[np.eye(3), dt * self.Rot], [np.zeros((3, 3)), np.eye(3)]])
        G = np.vstack([0.5 * dt * dt * self.Rot, dt * np.eye(3)])
        self.x = F @ self.x
        self.P = F @ self.P @ F.T + G @ np.diag(self.q / dt) @ G.T

    def update(self, z: np.ndarray, H: np.ndarray, R: np.ndarray) -> None:
        S = H @ self.P @ H.T + R
        K = self.P @ H.T @ np.linalg.inv(S)
        self.x = self.x + K @ (z - H @ self.x)
        self.P = (np.eye(6) - K @ H) @ self.P


def test_with_a_known_constant_heading_the_ekf_is_a_textbook_kalman_filter() -> None:
    rng = np.random.default_rng(21)
    psi = math.radians(20.0)
    acc = (0.05, 0.07, 0.04, 0.0)  # no yaw acceleration: the heading stays known
    x0 = np.array([-2.0, 4.0, 3.0, psi, 0.1, -0.05, 0.02, 0.0])
    P0 = np.zeros((8, 8))
    A = rng.normal(size=(6, 6))
    P6 = A @ A.T * 0.01 + np.eye(6) * 0.01
    keep = [0, 1, 2, 4, 5, 6]
    P0[np.ix_(keep, keep)] = P6
    nav = Navigator(x0, P0, NavigatorNoise(accel_std=acc), gate_threshold=1e9)
    kf = TextbookKF(x0[keep], P6, psi, np.square(acc[:3]))
    b = np.array([-8.0, 7.5, 1.0])
    for step in range(300):
        dt = float(rng.uniform(0.02, 0.5))
        nav.predict(dt)
        kf.predict(dt)
        kind = step % 4
        if kind == 0:
            z, R = rng.normal([0.1, -0.05, 0.02], 0.01), np.diag([1e-4, 2e-4, 3e-4])
            nav.update_dvl(z, R)
            kf.update(z, np.eye(6)[3:], R)
        elif kind == 1:
            z1 = float(rng.normal(3.0, 0.1))
            nav.update_depth(z1, 0.03**2)
            kf.update(np.array([z1]), np.eye(6)[2:3], np.array([[0.03**2]]))
        elif kind == 2:
            z = rng.normal(nav.x[:3], 0.1)
            R = usbl_covariance(b, z)
            nav.update_usbl(z, R)
            kf.update(z, np.eye(6)[:3], R)
        else:
            nav.update_heading(psi + 0.01, 1e-4)  # P on psi is 0: no gain, nothing changes
        assert nav.x[keep] == pytest.approx(kf.x, abs=1e-9)
        assert nav.P[np.ix_(keep, keep)] == pytest.approx(kf.P, abs=1e-9)
        assert nav.x[3] == pytest.approx(psi, abs=1e-15) and np.all(nav.P[3] == 0.0)


def start(P_pos: float = 0.03, P_xu: float = 0.0) -> Navigator:
    x0 = np.array([-1.0, 2.0, 3.0, 0.0, 0.2, 0.0, 0.0, 0.0])
    P0 = np.diag([P_pos, P_pos, P_pos, 1e-4, 0.01, 0.01, 0.01, 1e-4])
    P0[0, 4] = P0[4, 0] = P_xu
    return Navigator(x0, P0)


def test_one_usbl_update_by_hand() -> None:
    nav = start(P_xu=0.01)
    R = np.diag([0.01, 0.01, 0.01])
    assert nav.update_usbl([-0.9, 1.8, 3.0], R)
    # S = P_pos + R = 0.04 I; y = (0.1, -0.2, 0); D^2 = (0.01 + 0.04) / 0.04 = 1.25
    assert nav.y == pytest.approx([0.1, -0.2, 0.0])
    assert nav.S == pytest.approx(0.04 * np.eye(3))
    assert nav.mahalanobis == pytest.approx(math.sqrt(1.25))
    # K on position 0.03 / 0.04 = 0.75; on u through P_xu: 0.01 / 0.04 = 0.25
    assert nav.K[:3] == pytest.approx(0.75 * np.eye(3))
    assert nav.K[4] == pytest.approx([0.25, 0.0, 0.0])
    assert nav.x[:3] == pytest.approx([-1.0 + 0.075, 2.0 - 0.15, 3.0])
    assert nav.x[4] == pytest.approx(0.2 + 0.025)
    # P+ = P - K S K^T: 0.03 - 0.75^2 0.04 = 0.0075; P_uu: 0.01 - 0.25^2 0.04 = 0.0075
    assert nav.P[0, 0] == pytest.approx(0.0075) and nav.P[1, 1] == pytest.approx(0.0075)
    assert nav.P[4, 4] == pytest.approx(0.0075)
    # P_xu: 0.01 - 0.75 * 0.04 * 0.25 = 0.0025
    assert nav.P[0, 4] == pytest.approx(0.0025) and nav.P[4, 0] == pytest.approx(0.0025)


def test_an_incompatible_fix_is_rejected_and_counted() -> None:
    nav = start()
    x, P = nav.x.copy(), nav.P.copy()
    # 1 m off: D^2 = 1 / 0.04 = 25 > 11.345, the 99 % chi-square value for 3 dof
    assert not nav.update_usbl([0.0, 2.0, 3.0], np.diag([0.01, 0.01, 0.01]))
    assert nav.mahalanobis == pytest.approx(5.0)
    assert np.array_equal(nav.x, x) and np.array_equal(nav.P, P)
    assert (nav.usbl_rejected, nav.usbl_accepted) == (1, 0)
    scipy_stats = pytest.importorskip("scipy.stats")
    for confidence, value in CHI2_3DOF.items():
        assert value == pytest.approx(scipy_stats.chi2.ppf(confidence, 3), abs=1e-3)


def test_usbl_covariance_defaults_from_the_transceiver() -> None:
    b = (-8.0, 7.5, 1.0)
    nav = Navigator(start().x, start().P, transceiver=b)
    z = np.array([-1.0, 2.05, 3.0])
    nav.update_usbl(z)
    assert nav.S - start().P[:3, :3] == pytest.approx(usbl_covariance(b, z))
    with pytest.raises(ValueError):
        start().update_usbl(z)


def test_heading_innovation_is_wrapped_through_the_residual_function() -> None:
    calls = []

    def residual(a: np.ndarray, b: np.ndarray) -> np.ndarray:
        calls.append((float(a[0]), float(b[0])))
        d = a - b
        return np.asarray((d + np.pi) % (2.0 * np.pi) - np.pi, dtype=np.float64)

    x0 = np.zeros(8)
    x0[3] = math.radians(179.0)
    nav = Navigator(x0, np.eye(8) * 1e-2, residual_heading=residual)
    nav.update_heading(math.radians(-179.0), 1e-2)
    assert calls and nav.y == pytest.approx([math.radians(2.0)])
    # gain 1/2: the estimate moves 1 deg forward, across +-180
    assert nav.x[3] == pytest.approx(math.radians(-180.0) + 2 * math.pi, abs=1e-9)
    nav.update_heading(math.radians(-179.0), 1e-2)
    assert -math.pi < nav.x[3] <= math.pi and nav.x[3] < 0.0


def test_predict_is_equation_three() -> None:
    x0 = np.array([-2.0, 1.0, 3.0, math.radians(30.0), 0.3, 0.1, -0.05, 0.02])
    nav = Navigator(x0, np.eye(8) * 1e-3)
    t = 0.4
    nav.predict(t)
    c, s = math.cos(x0[3]), math.sin(x0[3])
    expected = x0.copy()
    expected[0] += x0[4] * t * c - x0[5] * t * s
    expected[1] += x0[4] * t * s + x0[5] * t * c
    expected[2] += x0[6] * t
    expected[3] += x0[7] * t
    assert nav.x == pytest.approx(expected)
    # F is the Jacobian of the mean prediction
    J = np.zeros((8, 8))
    for i in range(8):
        d = np.zeros(8)
        d[i] = 1e-6
        a, b = Navigator(x0 + d, np.eye(8)), Navigator(x0 - d, np.eye(8))
        a.predict(t)
        b.predict(t)
        J[:, i] = (a.x - b.x) / 2e-6
    assert nav.F == pytest.approx(J, abs=1e-6)


def test_process_noise_does_not_depend_on_how_often_predict_is_called() -> None:
    x0 = np.zeros(8)
    once, often = Navigator(x0, np.eye(8) * 1e-4), Navigator(x0, np.eye(8) * 1e-4)
    once.predict(1.0)
    for _ in range(10):
        often.predict(0.1)
    q = np.square(NavigatorNoise().accel_std)
    assert np.diag(once.P)[4:] == pytest.approx(1e-4 + q)
    assert np.diag(often.P)[4:] == pytest.approx(1e-4 + q)


def test_initialised_from_the_first_fix_and_the_compass() -> None:
    R = usbl_covariance((-8.0, 7.5, 1.0), (-1.5, 3.0, 2.0))
    nav = Navigator.from_first_fix([-1.5, 3.0, 2.0], R, math.radians(5.0))
    assert nav.x == pytest.approx([-1.5, 3.0, 2.0, math.radians(5.0), 0, 0, 0, 0])
    assert nav.P[:3, :3] == pytest.approx(R) and nav.P[3, 3] == pytest.approx(
        math.radians(0.5) ** 2)
    assert np.all(nav.P[:4, 4:] == 0.0) and np.all(np.diag(nav.P)[4:] > 0.0)


def test_a_one_row_update_has_the_gain_of_the_general_solve() -> None:
    """A heading or depth update (S of one row) takes S^-1 as 1/S: the gain, state and
    covariance are those of K = solve(S, H P)^T, the route of the DVL's and the USBL's."""
    R = usbl_covariance((-8.0, 7.5, 1.0), (-1.5, 3.0, 2.0))
    nav = Navigator.from_first_fix([-1.5, 3.0, 2.0], R, math.radians(5.0))
    nav.update_dvl([0.3, -0.1, 0.05])
    nav.predict(0.4)
    for update, z, row in ((nav.update_heading, 0.2, 3), (nav.update_depth, 2.1, 2)):
        P, x = nav.P.copy(), nav.x.copy()
        update(z)
        H = np.zeros((1, 8))
        H[0, row] = 1.0
        K = np.linalg.solve(nav.S, H @ P).T  # S = H P H^T + R
        assert nav.S.shape == (1, 1) and nav.S[0, 0] > P[row, row]
        assert nav.K == pytest.approx(K, rel=1e-12, abs=1e-15)
        assert nav.K[:, 0] == pytest.approx(P[:, row] / nav.S[0, 0], rel=1e-12, abs=1e-15)
        I_KH = np.eye(8) - K @ H
        assert nav.P == pytest.approx(I_KH @ P @ I_KH.T + K @ (nav.S - H @ P @ H.T) @ K.T,
                                      rel=1e-9, abs=1e-15)
        assert nav.x[row] != x[row]


# --- staying bounded without the DVL ----------------------------------------------------------
def blind_run(seconds: float = 120.0, seed: int = 4) -> tuple[Navigator, list[float]]:
    """The vehicle sways off at full thrust from rest while the DVL has no lock (as on the
    floor, where issue 12's estimate ran away); the navigator has heading, depth and USBL only.
    The horizontal error at every USBL fix."""
    env = Environment(floor_depth=12.0)
    robot_rng, sensor_rng = np.random.default_rng(seed).spawn(2)
    robot = Ictineu(VehicleState(-6.0, -2.0, 8.0, 0.0), rng=robot_rng, env=env)
    sensors = Sensors(env, sensor_rng, usbl=Usbl(outlier_probability=0.0))
    nav = Navigator.from_first_fix([-6.0, -2.0, 8.0], np.eye(3) * 0.05**2, 0.0)
    errors, t_nav = [], 0.0
    while robot.t < seconds:
        truth = robot.step(0.05, (0.0, 22.0 if robot.t < 40.0 else -22.0, 5.9, 0.0))
        for reading in sensors.sample(robot.t, truth):
            nav.predict(robot.t - t_nav)
            t_nav = robot.t
            if isinstance(reading, DvlReading):
                nav.dvl_lost()  # no bottom lock: its velocity is not used
            elif isinstance(reading, DepthReading):
                nav.update_depth(reading.depth)
            elif isinstance(reading, HeadingReading):
                nav.update_heading(reading.heading)
            elif isinstance(reading, UsblFix):
                nav.update_usbl(reading.position, reading.covariance)
                errors.append(math.hypot(nav.x[0] - truth.x, nav.x[1] - truth.y))
    return nav, errors


def test_without_the_dvl_the_estimate_stays_with_the_usbl_fixes() -> None:
    nav, errors = blind_run()
    assert not nav.velocity_aided and len(errors) > 100
    assert max(errors) < 1.0 and float(np.sqrt(np.mean(np.square(errors)))) < 0.3
    assert nav.usbl_accepted > 0.9 * len(errors)


def test_a_run_of_agreeing_rejected_fixes_resets_the_estimate_to_them() -> None:
    x0 = np.array([-6.0, -2.0, 8.0, 0.0, 0.0, 0.0, 0.0, 0.0])
    nav = Navigator(x0, np.diag([1e-4] * 3 + [1e-4] * 5), reacquire_after=3)
    R = np.eye(3) * 0.01
    far = np.array([-1.0, 3.0, 8.0])  # 7 m away: every fix fails the gate
    assert not nav.update_usbl(far, R) and not nav.update_usbl(far + 0.1, R)
    assert nav.x[:3] == pytest.approx(x0[:3]) and nav.usbl_reacquired == 0
    assert not nav.update_usbl(far + 0.2, R)  # the third in a row: taken as a new first fix
    assert nav.usbl_reacquired == 1 and nav.usbl_rejected == 3
    assert nav.x[:3] == pytest.approx(far + 0.2)
    assert nav.P[:3, :3] == pytest.approx(R) and np.all(nav.P[:3, 3:] == 0.0)
    assert np.all(np.diag(nav.P)[4:7] >= 0.3**2 - 1e-12)
    assert nav.update_usbl(far + 0.25, R)  # and the next one agrees


def test_outliers_that_disagree_do_not_reset_the_estimate() -> None:
    x0 = np.array([-6.0, -2.0, 8.0, 0.0, 0.0, 0.0, 0.0, 0.0])
    nav = Navigator(x0, np.diag([1e-4] * 8), reacquire_after=3)
    R = np.eye(3) * 0.01
    for kick in ([4.0, 0, 0], [-4.0, 0, 0], [0, 4.0, 0], [0, -4.0, 0], [0, 0, 4.0]):
        assert not nav.update_usbl(x0[:3] + np.array(kick), R)
    assert nav.usbl_reacquired == 0 and nav.x[:3] == pytest.approx(x0[:3])
