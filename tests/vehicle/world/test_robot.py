"""The simulated Ictineu (vehicle/world/robot.py) and its sensors (vehicle/sensors/instruments.py), paper 002 §2.

Dynamics against closed forms (saturation, terminal speeds, drift in a current), determinism,
contact with the wall and the floor; sensors against their specification (rates, noise, USBL
outliers, the sonar's echo from the wall, camera footprints, housing faults).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from vehicle.world.robot import Environment, Ictineu, IctineuParams, VehicleState, allocate, wrap_angle
from vehicle.sensors.instruments import (
    DVL_ACCURACY,
    Camera,
    Dvl,
    HeadingSensor,
    HousingMonitor,
    Msis,
    PressureSensor,
    Sensors,
    Usbl,
    dvl_std,
    usbl_covariance,
)
from vehicle.sensors.readings import SonarBeam

QUIET = IctineuParams(disturbance_std=(0.0, 0.0, 0.0, 0.0))
FAR = Environment(floor_depth=200.0)


def run(robot: Ictineu, tau: tuple[float, float, float, float], seconds: float,
        dt: float = 0.05) -> list[VehicleState]:
    return [robot.step(dt, tau) for _ in range(round(seconds / dt))]


def terminal(lin: float, quad: float, force: float) -> float:
    """The speed at which lin v + quad v^2 = force."""
    return (-lin + math.sqrt(lin * lin + 4.0 * quad * force)) / (2.0 * quad)


# --- thrusters --------------------------------------------------------------------------------
def test_every_thruster_saturates_at_22_newtons() -> None:
    rng = np.random.default_rng(1)
    for tau in rng.normal(0.0, 200.0, (500, 4)):
        f, _ = allocate(tau, QUIET)
        assert np.all(np.abs(f) <= 22.0 + 1e-12)
    f, applied = allocate((1000.0, 0.0, 0.0, 0.0), QUIET)
    assert f[:2] == pytest.approx([22.0, 22.0]) and applied[0] == pytest.approx(44.0)
    f, applied = allocate((0.0, 0.0, -1000.0, 0.0), QUIET)
    assert applied[2] == pytest.approx(-44.0)


def test_feasible_demands_are_produced_exactly() -> None:
    for tau in [(10.0, -5.0, 8.0, 1.0), (0.0, 0.0, 0.0, 3.0), (-30.0, 20.0, 0.0, -2.0)]:
        _, applied = allocate(tau, QUIET)
        assert applied == pytest.approx(tau, abs=1e-9)


# --- dynamics ---------------------------------------------------------------------------------
@pytest.mark.parametrize("dof", [0, 1, 2, 3])
def test_terminal_velocity_is_where_thrust_meets_damping(dof: int) -> None:
    # heading along the wall (psi = 90 deg) so that surge and sway never reach it
    robot = Ictineu(VehicleState(-10.0, 0.0, 50.0, math.pi / 2), QUIET, env=FAR)
    tau = [0.0, 0.0, 0.0, 0.0]
    tau[dof] = 1000.0
    states = run(robot, (tau[0], tau[1], tau[2], tau[3]), 60.0)
    force = float(robot.tau_applied[dof]) - (QUIET.net_buoyancy if dof == 2 else 0.0)
    expected = terminal(QUIET.linear_damping[dof], QUIET.quadratic_damping[dof], force)
    final = states[-1].as_array()[4 + dof]
    assert final == pytest.approx(expected, rel=1e-3)
    assert robot.tau_applied[dof] == pytest.approx([44.0, 44.0, 44.0, 22.0][dof])


def test_surge_speed_at_full_thrust_is_about_two_thirds_of_a_metre_per_second() -> None:
    assert terminal(10.0, 90.0, 44.0) == pytest.approx(0.646, abs=1e-3)


def test_a_current_carries_the_vehicle_over_ground() -> None:
    env = Environment(floor_depth=200.0, current=(0.10, -0.05, 0.0))
    robot = Ictineu(VehicleState(-30.0, 0.0, 20.0, 0.3), QUIET, env=env)
    start = robot.state
    end = run(robot, (0.0, 0.0, 0.0, 0.0), 180.0)[-1]
    c, s = math.cos(end.psi), math.sin(end.psi)
    vx, vy = c * end.u - s * end.v, s * end.u + c * end.v  # over ground, world frame
    assert (vx, vy) == pytest.approx((0.10, -0.05), abs=1e-3)
    assert robot.relative_velocity[:2] == pytest.approx((0.0, 0.0), abs=1e-3)
    drift = np.array([end.x - start.x, end.y - start.y])
    assert np.linalg.norm(drift) / (math.hypot(0.10, 0.05) * 180.0) == pytest.approx(1.0, abs=0.1)
    assert math.atan2(drift[1], drift[0]) == pytest.approx(math.atan2(-0.05, 0.10), abs=0.01)


def test_a_slowly_varying_current_is_followed() -> None:
    env = Environment(floor_depth=200.0, current_fn=lambda t: (0.0, 0.1 if t > 60.0 else 0.0, 0.0))
    robot = Ictineu(VehicleState(-30.0, 0.0, 20.0, 0.0), QUIET, env=env)
    assert run(robot, (0.0, 0.0, 0.0, 0.0), 60.0)[-1].v == pytest.approx(0.0, abs=1e-6)
    assert run(robot, (0.0, 0.0, 0.0, 0.0), 120.0)[-1].v == pytest.approx(0.1, abs=1e-3)


def test_positive_buoyancy_brings_an_idle_vehicle_to_the_surface() -> None:
    robot = Ictineu(VehicleState(-10.0, 0.0, 3.0, 0.0), QUIET)
    states = run(robot, (0.0, 0.0, 0.0, 0.0), 60.0)
    assert states[-1].z == 0.0 and all(s.z >= 0.0 for s in states)


def test_same_seed_same_run_and_another_seed_another() -> None:
    def trajectory(seed: int) -> np.ndarray:
        env = Environment(current=(0.02, 0.03, 0.0))
        robot = Ictineu(VehicleState(-3.0, 1.0, 4.0, 0.2), rng=np.random.default_rng(seed), env=env)
        sensors = Sensors(env, np.random.default_rng(seed + 100))
        rows = []
        for _ in range(400):
            s = robot.step(0.05, (5.0, -3.0, 2.0, 0.5))
            readings = sensors.sample(robot.t, s)
            rows.append([*s.as_array(), len(readings)])
        return np.array(rows)

    assert np.array_equal(trajectory(7), trajectory(7))
    assert not np.allclose(trajectory(7), trajectory(8))


@pytest.mark.parametrize("curvature, y, psi, tau", [
    (0.0, 0.0, 0.0, (1000.0, 0.0, 0.0, 0.0)),
    (0.0, 2.0, math.radians(30.0), (1000.0, 0.0, 0.0, 0.0)),
    (0.0, 0.0, math.pi / 2, (0.0, -1000.0, 0.0, 0.0)),  # sideways: starboard is -x
    (0.03, 5.0, 0.0, (1000.0, 0.0, 0.0, 0.3)),  # curved wall, turning while pushing
])
def test_the_hull_never_passes_through_the_wall(curvature: float, y: float, psi: float,
                                                tau: tuple[float, float, float, float]) -> None:
    env = Environment(wall_curvature=curvature)
    robot = Ictineu(VehicleState(env.wall_x(y) - 3.0, y, 4.0, psi),
                    rng=np.random.default_rng(3), env=env)
    touched = False
    for s in run(robot, tau, 30.0):
        foot = env.wall_foot(s.x, s.y)
        nx, ny = 1.0, -2.0 * curvature * foot  # wall normal, independently of the module
        a = s.psi - math.atan2(ny, nx)
        extent = 0.4 * abs(math.cos(a)) + 0.25 * abs(math.sin(a))
        assert env.distance_to_wall(s.x, s.y) >= extent - 1e-3
        assert s.x < env.wall_x(s.y)
        touched = touched or robot.wall_contact
    assert touched and robot.collisions >= 1 and robot.collided


def test_floor_and_surface_stop_the_vehicle() -> None:
    env = Environment(floor_depth=6.0)
    robot = Ictineu(VehicleState(-5.0, 0.0, 3.0, 0.0), QUIET, env=env)
    down = run(robot, (0.0, 0.0, 1000.0, 0.0), 30.0)
    assert max(s.z for s in down) <= 6.0 - 0.25 + 1e-12 and robot.floor_contact
    assert not robot.wall_contact
    up = run(robot, (0.0, 0.0, -1000.0, 0.0), 30.0)
    assert min(s.z for s in up) >= 0.0 and up[-1].z == 0.0 and not robot.floor_contact


@pytest.mark.parametrize("psi, tau", [(math.pi, (1000.0, 0.0, 0.0, 0.0)),  # astern: -x
                                      (0.0, (0.0, -1000.0, 0.0, 0.0)),  # to port: -y
                                      (0.0, (0.0, 1000.0, 0.0, 0.0))])  # to starboard: +y
def test_the_banks_of_the_working_area_stop_the_vehicle(
        psi: float, tau: tuple[float, float, float, float]) -> None:
    env = Environment(area=(-10.0, 10.0, -5.0, 5.0))
    robot = Ictineu(VehicleState(-6.0, 0.0, 3.0, psi), rng=np.random.default_rng(2), env=env)
    touched = False
    for s in run(robot, tau, 60.0):  # 0.5-0.65 m/s for a minute: far beyond the banks
        ex = 0.4 * abs(math.cos(s.psi)) + 0.25 * abs(math.sin(s.psi))
        ey = 0.4 * abs(math.sin(s.psi)) + 0.25 * abs(math.cos(s.psi))
        assert -10.0 + ex - 1e-9 <= s.x and -5.0 + ey - 1e-9 <= s.y <= 5.0 - ey + 1e-9
        assert env.where(s.x, s.y, s.z) is None
        touched = touched or robot.edge_contact
    assert touched and robot.collided and not robot.wall_contact
    e = robot.state  # nothing left of the velocity into the bank it is pressed against
    vx, vy = e.u * math.cos(e.psi) - e.v * math.sin(e.psi), e.u * math.sin(e.psi) + e.v * math.cos(e.psi)
    into = {(-1.0, 0.0): -vx, (0.0, -1.0): -vy, (0.0, 1.0): vy}
    side = (-1.0, 0.0) if tau[0] else (0.0, math.copysign(1.0, tau[1]))
    assert into[side] <= 1e-9


def test_where_says_why_a_point_is_not_in_the_water() -> None:
    env = Environment(floor_depth=12.0, area=(-60.0, 60.0, -60.0, 60.0))
    assert env.where(-3.0, 0.0, 5.0) is None
    assert env.where(-3.0, 0.0, 18.0) == "beyond the floor (12 m)"
    assert env.where(2.0, 0.0, 5.0) == "inside the wall"
    assert env.where(-200.0, 0.0, 5.0) == "outside the working area (x -60..60 m, y -60..60 m)"
    assert env.where(-3.0, 0.0, -1.0) == "above the surface"
    assert env.where(-0.3, 0.0, 5.0, margin=0.4) == "inside the wall"  # the hull's half-length
    assert env.where(-3.0, 0.0, 11.7, margin=0.4) == "beyond the floor (12 m)"


def test_wall_geometry_against_brute_force() -> None:
    env = Environment(wall_curvature=0.04)
    ts = np.linspace(-30.0, 30.0, 600001)
    for x, y in [(-2.0, 0.0), (-1.5, 4.0), (-3.0, -6.0), (0.5, 7.0)]:
        brute = float(np.min(np.hypot(x - 0.04 * ts**2, y - ts)))
        assert abs(env.distance_to_wall(x, y)) == pytest.approx(brute, abs=1e-4)
    assert env.distance_to_wall(2.5, 7.0) < 0.0 < env.distance_to_wall(1.5, 7.0)  # x_wall 1.96
    # a ray marched in small steps meets the wall where the closed form says
    origin, d = (-2.0, 3.0, 4.0), (math.cos(0.4), math.sin(0.4), 0.0)
    s = np.arange(0.0, 20.0, 1e-4)
    inside = origin[0] + s * d[0] >= 0.04 * (origin[1] + s * d[1]) ** 2
    assert env.ray_to_wall(origin, d) == pytest.approx(s[np.argmax(inside)], abs=2e-4)
    assert env.ray_to_wall(origin, (-1.0, 0.0, 0.0)) is None
    assert Environment().ray_to_wall((-2.0, 0.0, 1.0), (math.sqrt(0.5), 0.0, -math.sqrt(0.5))) \
        is None  # would meet the wall above the surface


# --- sensors: rates ---------------------------------------------------------------------------
@pytest.mark.parametrize("dt", [0.05, 0.3])
def test_every_sensor_reports_at_its_rate(dt: float) -> None:
    env = Environment()
    sensors = Sensors(env, np.random.default_rng(0))
    sensors.camera.start(0.0)
    truth = VehicleState(-1.5, 7.5, 4.0, 0.0, 0.2)
    counts: dict[str, int] = {}
    duration = 120.0
    for k in range(round(duration / dt)):  # t in [0, duration): due times likewise
        for reading in sensors.sample(k * dt, truth):
            counts[type(reading).__name__] = counts.get(type(reading).__name__, 0) + 1
    expected = {"DvlReading": (2.0, 1), "HeadingReading": (10.0, 1), "DepthReading": (5.0, 1),
                "UsblFix": (1.0, 1), "SonarBeam": (20.0, 1), "HousingReading": (1.0, 2)}
    last = (round(duration / dt) - 1) * dt
    for name, (rate, sensors_of_kind) in expected.items():
        assert counts[name] == sensors_of_kind * (math.floor(last * rate + 1e-9) + 1), name
    assert counts["CameraImage"] == math.floor(last / sensors.camera.interval + 1e-9) + 1


# --- sensors: noise ---------------------------------------------------------------------------
def test_dvl_noise_is_two_per_mille_of_velocity_over_a_floor() -> None:
    assert DVL_ACCURACY == 0.002  # Table I
    dvl, rng = Dvl(Environment()), np.random.default_rng(2)
    truth = VehicleState(-2.0, 0.0, 4.0, 0.0, 0.5, -0.3, 0.1)
    readings = [dvl.sample(k * 0.5, truth, rng) for k in range(6000)]
    m = np.array([r.velocity for r in readings if r is not None and r.velocity is not None])
    spec = dvl_std([0.5, -0.3, 0.1])
    assert m.std(axis=0) == pytest.approx(spec, rel=0.05)
    assert np.abs(m.mean(axis=0) - [0.5, -0.3, 0.1]) == pytest.approx(0.0, abs=4 * spec.max()
                                                                        / math.sqrt(6000))
    fast = dvl_std([10.0, 0.0, 0.0])
    assert fast[0] == pytest.approx(0.02, rel=0.01)  # 0.2 % dominates at speed


def test_dvl_loses_bottom_lock_out_of_range() -> None:
    dvl, rng = Dvl(Environment(floor_depth=40.0)), np.random.default_rng(0)
    far = dvl.sample(0.0, VehicleState(z=2.0), rng)
    near = dvl.sample(1.0, VehicleState(z=30.0), rng)
    assert far is not None and not far.bottom_lock and far.velocity is None
    assert far.altitude == pytest.approx(38.0)
    assert near is not None and near.bottom_lock and near.velocity is not None


def test_heading_noise_is_under_one_degree_and_wrapped() -> None:
    sensor, rng = HeadingSensor(), np.random.default_rng(3)
    psi = math.pi - 0.001  # readings straddle +-pi
    readings = [sensor.sample(k * 0.1, VehicleState(psi=psi), rng) for k in range(5000)]
    h = np.array([r.heading for r in readings if r is not None])
    assert np.all((h > -math.pi) & (h <= math.pi)) and np.any(h < 0.0)
    err = np.array([wrap_angle(a - psi) for a in h])
    assert err.std() == pytest.approx(math.radians(0.5), rel=0.05)
    assert np.mean(np.abs(err) < math.radians(1.0)) > 0.95


def test_depth_noise() -> None:
    sensor, rng = PressureSensor(), np.random.default_rng(4)
    d = np.array([r.depth for k in range(5000)
                  if (r := sensor.sample(k * 0.2, VehicleState(z=6.0), rng)) is not None])
    assert d.std() == pytest.approx(0.03, rel=0.05) and d.mean() == pytest.approx(6.0, abs=0.002)


def test_usbl_accuracy_is_a_quarter_degree_and_half_a_percent_of_range() -> None:
    usbl, rng = Usbl(outlier_probability=0.0), np.random.default_rng(5)
    p = np.array([-1.5, 3.0, 6.0])
    b = usbl.transceiver
    rho = float(np.linalg.norm(p - b))
    fixes = [f for k in range(4000) if (f := usbl.sample(float(k), VehicleState(*p), rng))]
    assert len(fixes) == 4000
    d = np.array([f.position for f in fixes]) - b
    ranges = np.linalg.norm(d, axis=1)
    angles = np.arccos(np.clip(d @ (p - b) / (ranges * rho), -1.0, 1.0))
    assert ranges.std() == pytest.approx(0.005 * rho, rel=0.05)
    # the angle off the true line of sight is Rayleigh: E[a^2] = 2 sigma^2
    assert math.sqrt(np.mean(angles**2) / 2.0) == pytest.approx(math.radians(0.25), rel=0.05)
    # the reported covariance explains the errors: mean e^T R^-1 e is 3
    nees = [float((f.position - p) @ np.linalg.solve(f.covariance, f.position - p))
            for f in fixes]
    assert np.mean(nees) == pytest.approx(3.0, rel=0.06)
    R = usbl_covariance(b, p)
    assert abs(R[0, 2]) > 1e-6  # full, not diagonal (§4.4)


def test_usbl_outliers_come_at_the_configured_rate() -> None:
    usbl, rng = Usbl(outlier_probability=0.03), np.random.default_rng(6)
    p = np.array([-1.5, 10.0, 3.0])
    fixes = [f for k in range(6000) if (f := usbl.sample(float(k), VehicleState(*p), rng))]
    flagged = [f for f in fixes if f.injected_outlier]
    n, prob = len(fixes), 0.03
    assert abs(len(flagged) - n * prob) < 4.0 * math.sqrt(n * prob * (1.0 - prob))
    sizes = [float(np.linalg.norm(f.position - p)) for f in flagged]
    assert min(sizes) > 1.8 and max(sizes) < 6.2
    clean = [float(np.linalg.norm(f.position - p)) for f in fixes if not f.injected_outlier]
    assert max(clean) < 0.5


def test_usbl_hears_only_in_front_of_its_tilted_transceiver() -> None:
    usbl, rng = Usbl(), np.random.default_rng(0)
    # transceiver at (-8, 7.5, 1) looking down and 45 deg towards the wall: a vehicle near the
    # surface behind the buoy is outside its hemisphere
    assert usbl.sample(0.0, VehicleState(-20.0, 7.5, 0.5), rng) is None
    assert usbl.sample(1.0, VehicleState(-1.5, 7.5, 0.5), rng) is not None


# --- sonar ------------------------------------------------------------------------------------
def echo_range(beam_bins: np.ndarray, bin_size: float, near_field: float = 1.0) -> float:
    """Range of the strongest bin beyond the near field."""
    first = int(near_field / bin_size)
    return (first + int(np.argmax(beam_bins[first:])) + 0.5) * bin_size


def scan(sonar: Msis, truth: VehicleState, rng: np.random.Generator, t0: float = 0.0) -> list[SonarBeam]:
    n = round(sonar.scan_period * sonar.rate)
    return [b for k in range(n) if (b := sonar.sample(t0 + k / sonar.rate, truth, rng))]


def test_sonar_sees_the_wall_at_its_range() -> None:
    sonar, rng = Msis(Environment()), np.random.default_rng(7)
    beams = scan(sonar, VehicleState(-5.0, 0.0, 3.0, 0.0), rng)
    assert len(beams) == 200
    toward = [b for b in beams if abs(b.bearing) <= math.radians(40.0)]
    errors = [echo_range(b.bins, b.bin_size) - 5.0 / math.cos(b.bearing) for b in toward]
    assert np.mean(np.abs(errors) <= 0.25) >= 0.95 and abs(np.mean(errors)) < 0.05
    away = [b for b in beams if abs(b.bearing) > math.radians(90.0)]
    assert max(float(b.bins[10:].max()) for b in away) < 0.4


def test_sonar_bearing_is_relative_to_the_heading() -> None:
    sonar, rng = Msis(Environment()), np.random.default_rng(8)
    beams = scan(sonar, VehicleState(-4.0, 0.0, 3.0, math.radians(27.0)), rng)
    normal = min(beams, key=lambda b: abs(b.bearing + math.radians(27.0)))
    assert echo_range(normal.bins, normal.bin_size) == pytest.approx(4.0, abs=0.15)


def test_sonar_on_a_curved_wall_matches_an_independent_intersection() -> None:
    c, truth = 0.05, VehicleState(-3.0, 4.0, 3.0, 0.0)
    sonar, rng = Msis(Environment(wall_curvature=c)), np.random.default_rng(9)
    for b in scan(sonar, truth, rng)[::5]:
        phi = truth.psi + b.bearing
        s = np.arange(0.0, 20.0, 1e-3)
        inside = truth.x + s * math.cos(phi) >= c * (truth.y + s * math.sin(phi)) ** 2
        if not inside.any():
            continue
        hit = float(s[np.argmax(inside)])
        nx, ny = 1.0, -2.0 * c * (truth.y + hit * math.sin(phi))
        incidence = math.acos((math.cos(phi) * nx + math.sin(phi) * ny) / math.hypot(nx, ny))
        if incidence < math.radians(45.0) and hit < 19.0:
            assert echo_range(b.bins, b.bin_size) == pytest.approx(hit, abs=0.3)


def test_wall_echoes_only_within_sixty_degrees_of_incidence() -> None:
    rng = np.random.default_rng(10)
    truth = VehicleState(-4.0, 0.0, 3.0, 0.0)
    strongest: dict[float, list[float]] = {50.0: [], 65.0: []}
    for deg, found in strongest.items():  # the 3 deg beam stays on one side of beta = 60 deg
        for _ in range(10):
            sonar = Msis(Environment())
            sonar.beam_count = round(deg / 1.8)
            beam = sonar.sample(0.0, truth, rng)
            assert beam is not None
            found.append(float(beam.bins[10:].max()))
    assert min(strongest[50.0]) > 0.18 > max(strongest[65.0])


def test_sonar_scan_period_is_configurable_within_table_one() -> None:
    fast = Msis(Environment(), scan_period=5.0)
    assert fast.rate == pytest.approx(40.0)
    bearings = [b.bearing for b in scan(fast, VehicleState(-5.0), np.random.default_rng(0))]
    assert len(bearings) == 200
    assert np.degrees(np.diff(np.unwrap(bearings))) == pytest.approx(np.full(199, 1.8))
    for bad in (4.0, 25.0):
        with pytest.raises(ValueError):
            Msis(Environment(), scan_period=bad)


# --- camera and housings ----------------------------------------------------------------------
def test_camera_takes_images_only_while_on_and_records_the_footprint() -> None:
    cam, rng = Camera(Environment(), interval=1.0), np.random.default_rng(0)
    truth = VehicleState(-1.5, 5.0, 3.0, 0.0)
    assert cam.sample(0.0, truth, rng) is None
    cam.start(2.0)
    images = [im for k in range(40, 140) if (im := cam.sample(k * 0.05, truth, rng))]
    assert [im.t for im in images] == pytest.approx([2.0, 3.0, 4.0, 5.0, 6.0])
    assert [im.index for im in images] == [0, 1, 2, 3, 4]
    cam.stop()
    assert cam.sample(10.0, truth, rng) is None
    fp = images[0].footprint
    assert fp is not None and fp.distance == pytest.approx(1.5)
    half_w, half_h = 1.5 * math.tan(math.radians(25.0)), 1.5 * math.tan(math.radians(19.0))
    assert (fp.y_min, fp.y_max) == pytest.approx((5.0 - half_w, 5.0 + half_w))
    assert (fp.z_min, fp.z_max) == pytest.approx((3.0 - half_h, 3.0 + half_h))
    assert cam.footprint(VehicleState(-10.0, 5.0, 3.0, 0.0)) is None  # beyond visibility


def test_housing_faults_appear_at_their_time() -> None:
    mon, rng = HousingMonitor("computer"), np.random.default_rng(0)
    mon.inject("leak", at=30.0)
    mon.inject("overtemperature", at=10.0, rate=0.5)
    readings = [r for k in range(80) if (r := mon.sample(float(k), VehicleState(), rng))]
    assert [r.leak for r in readings] == [False] * 30 + [True] * 50
    assert readings[5].temperature == pytest.approx(20.0, abs=0.5)
    assert readings[70].temperature == pytest.approx(50.0, abs=0.5)
    assert readings[79].pressure > readings[29].pressure + 0.03  # water coming in
    hot = HousingMonitor("power")
    hot.inject("overpressure", at=0.0)
    late = [r for k in range(61) if (r := hot.sample(float(k), VehicleState(), rng))][-1]
    assert late.pressure == pytest.approx(1.6, abs=0.01) and not late.leak
