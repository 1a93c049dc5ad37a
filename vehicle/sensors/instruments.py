"""The Ictineu's sensors, simulated with the accuracies of Table I (paper 002 §2, §2.2, §5, §7).

Every sensor has a ``rate`` (Hz) and ``sample(t, truth, rng)`` that returns a typed reading
(vehicle/sensors/readings.py) when one is due at time t (s) and None otherwise; ``truth`` is
the vehicle's true :class:`~vehicle.world.robot.VehicleState`. Due times are t0 + k/rate; a caller that steps more
coarsely than a sensor's period gets the missed readings on the next calls at the same t
(:meth:`Sensors.sample` collects them all).

From Table I: MSIS (Tritech Miniking) 3 deg horizontal beam, 5-20 s per 360 deg, 100 m maximum
range; DVL (Sontek Argonaut) 0.2 % of the measured velocity; MRU + FOG heading better than
1 deg; USBL (Linkquest Tracklink 1500 HA) 0.25 deg angular and 0.5 % of the slant range.
§2.1: 30 m depth rating, two pressure vessels (power, computer) with leak, temperature and
pressure sensors (§3.1). §5.1: the wall echoes at incidences up to beta = 60 deg. §7: the buoy
moored about 8 m from the wall, its transceiver tilted 45 deg; 1,998 images in 29 min.

Chosen here (the paper gives no rates or noise floors): DVL 2 Hz with a 1 mm/s noise floor and
bottom lock from 0.3 m to 15 m altitude; heading 10 Hz, 1 sigma = 0.5 deg (so that errors stay
under 1 deg at 2 sigma); depth 5 Hz, 1 sigma = 0.03 m (0.1 % of the 30 m rating); USBL 1 Hz,
the stated accuracies taken as 1 sigma, 3 % outliers of 2-6 m in a random direction, fixes
only inside the transceiver's hemisphere (90 deg about its tilted axis); sonar 1.8 deg steps,
20 m range in 0.1 m bins; camera every 0.87 s (29 min / 1,998 images), 50 x 38 deg field of
view, 4 m visibility; vessels 20 deg C and 1.0 bar when healthy.
"""

from __future__ import annotations

import bisect
import math
from dataclasses import dataclass, field
from typing import Literal

import numpy as np
import numpy.typing as npt

from vehicle.sensors.readings import (
    CameraImage,
    DepthReading,
    DvlReading,
    HeadingReading,
    HousingReading,
    Reading,
    Schedule,
    Sensor,
    SonarBeam,
    UsblFix,
    WallFootprint,
)
from vehicle.world.robot import Environment, FloatArray, VehicleState, wrap_angle

# --- Table I figures and the choices made around them ----------------------------------------
DVL_RATE_HZ = 2.0
DVL_ACCURACY = 0.002  # fraction of the measured velocity, Table I
DVL_NOISE_FLOOR = 0.001  # m/s
DVL_ALTITUDE_RANGE = (0.3, 15.0)  # m, bottom lock
HEADING_RATE_HZ = 10.0
HEADING_STD = math.radians(0.5)  # rad; Table I: "better than 1 deg"
DEPTH_RATE_HZ = 5.0
DEPTH_STD = 0.03  # m
USBL_RATE_HZ = 1.0
USBL_ANGLE_STD = math.radians(0.25)  # rad, Table I
USBL_RANGE_FRACTION = 0.005  # of the slant range, Table I
USBL_TRANSCEIVER = (-8.0, 7.5, 1.0)  # m: moored ~8 m from the wall (§7), 1 m down
USBL_TILT = math.radians(45.0)  # §7: transceiver tilted 45 deg (towards the wall)
SONAR_BEAM_WIDTH = math.radians(3.0)  # Table I
SONAR_INCIDENCE_LIMIT = math.radians(60.0)  # §5.1, beta
CAMERA_INTERVAL = 29.0 * 60.0 / 1998.0  # s, §7


def dvl_std(velocity: npt.ArrayLike, accuracy: float = DVL_ACCURACY,
            floor: float = DVL_NOISE_FLOOR) -> FloatArray:
    """Per-axis DVL noise (m/s): accuracy * |v_i| combined with the floor."""
    v = np.asarray(velocity, dtype=float)
    return np.sqrt(floor * floor + (accuracy * v) ** 2)


def usbl_covariance(transceiver: npt.ArrayLike, position: npt.ArrayLike,
                    angle_std: float = USBL_ANGLE_STD,
                    range_fraction: float = USBL_RANGE_FRACTION) -> FloatArray:
    """World-frame covariance (m^2) of a USBL fix at ``position`` (§4.4: full, not diagonal).

    Range noise range_fraction * rho along the line of sight e, angular noise angle_std in
    both directions across it: (range_fraction rho)^2 e e^T + (rho angle_std)^2 (I - e e^T).
    """
    d = np.asarray(position, dtype=float) - np.asarray(transceiver, dtype=float)
    rho = float(np.linalg.norm(d))
    if rho == 0.0:
        return np.zeros((3, 3))
    e = d / rho
    ee = np.outer(e, e)
    cov: FloatArray = (range_fraction * rho) ** 2 * ee + (rho * angle_std) ** 2 * (np.eye(3) - ee)
    return cov


# --- navigation sensors -----------------------------------------------------------------------
class Dvl:
    """Doppler velocity log: body velocities over ground while in bottom lock."""

    def __init__(self, env: Environment, rate: float = DVL_RATE_HZ,
                 accuracy: float = DVL_ACCURACY, floor: float = DVL_NOISE_FLOOR,
                 altitude_range: tuple[float, float] = DVL_ALTITUDE_RANGE) -> None:
        self.env, self.rate, self.accuracy, self.floor = env, rate, accuracy, floor
        self.altitude_range = altitude_range
        self.schedule = Schedule(rate)

    def sample(self, t: float, truth: VehicleState, rng: np.random.Generator) -> DvlReading | None:
        if not self.schedule.due(t):
            return None
        altitude = self.env.floor_depth - truth.z
        lo, hi = self.altitude_range
        if not lo <= altitude <= hi:
            return DvlReading(t, None, altitude, False)
        v = np.array([truth.u, truth.v, truth.w])
        m = v + rng.normal(0.0, 1.0, 3) * dvl_std(v, self.accuracy, self.floor)
        return DvlReading(t, (float(m[0]), float(m[1]), float(m[2])), altitude, True)


class HeadingSensor:
    """MRU + FOG heading (Tritech iGC/iFG)."""

    def __init__(self, rate: float = HEADING_RATE_HZ, std: float = HEADING_STD) -> None:
        self.rate, self.std, self.schedule = rate, std, Schedule(rate)

    def sample(self, t: float, truth: VehicleState,
               rng: np.random.Generator) -> HeadingReading | None:
        if not self.schedule.due(t):
            return None
        return HeadingReading(t, wrap_angle(truth.psi + float(rng.normal(0.0, self.std))))


class PressureSensor:
    """Depth from the pressure sensor."""

    def __init__(self, rate: float = DEPTH_RATE_HZ, std: float = DEPTH_STD) -> None:
        self.rate, self.std, self.schedule = rate, std, Schedule(rate)

    def sample(self, t: float, truth: VehicleState,
               rng: np.random.Generator) -> DepthReading | None:
        if not self.schedule.due(t):
            return None
        return DepthReading(t, truth.z + float(rng.normal(0.0, self.std)))


class Usbl:
    """Fixes of the vehicle's transponder from the transceiver on the moored buoy (§2.2, §7).

    The buoy's DGPS and MRU are taken as perfect: fixes are in world coordinates. The
    transceiver looks down, tilted ``tilt`` towards the wall (+x); it hears the transponder
    only within ``cone_half_angle`` of that axis.
    """

    def __init__(self, transceiver: tuple[float, float, float] = USBL_TRANSCEIVER,
                 tilt: float = USBL_TILT, cone_half_angle: float = math.radians(90.0),
                 rate: float = USBL_RATE_HZ, angle_std: float = USBL_ANGLE_STD,
                 range_fraction: float = USBL_RANGE_FRACTION,
                 outlier_probability: float = 0.03,
                 outlier_size: tuple[float, float] = (2.0, 6.0)) -> None:
        self.transceiver = np.asarray(transceiver, dtype=float)
        self.axis = np.array([math.sin(tilt), 0.0, math.cos(tilt)])
        self.cone_half_angle, self.rate = cone_half_angle, rate
        self.angle_std, self.range_fraction = angle_std, range_fraction
        self.outlier_probability, self.outlier_size = outlier_probability, outlier_size
        self.schedule = Schedule(rate)

    def covariance(self, position: npt.ArrayLike) -> FloatArray:
        return usbl_covariance(self.transceiver, position, self.angle_std, self.range_fraction)

    def sample(self, t: float, truth: VehicleState, rng: np.random.Generator) -> UsblFix | None:
        if not self.schedule.due(t):
            return None
        d = np.array([truth.x, truth.y, truth.z]) - self.transceiver
        rho = float(np.linalg.norm(d))
        if rho == 0.0 or float(d @ self.axis) < rho * math.cos(self.cone_half_angle):
            return None
        e = d / rho
        e1 = np.cross(e, [0.0, 0.0, 1.0] if abs(e[2]) < 0.9 else [1.0, 0.0, 0.0])
        e1 /= np.linalg.norm(e1)
        e2 = np.cross(e, e1)
        a1, a2, dr = rng.normal(0.0, 1.0, 3) * [self.angle_std, self.angle_std,
                                                 self.range_fraction * rho]
        los = e * math.cos(math.hypot(a1, a2)) + (a1 * e1 + a2 * e2) * _sinc(math.hypot(a1, a2))
        measured = self.transceiver + (rho + dr) * los
        outlier = bool(rng.random() < self.outlier_probability)
        if outlier:
            kick = rng.normal(0.0, 1.0, 3)
            measured = measured + kick / np.linalg.norm(kick) * rng.uniform(*self.outlier_size)
        slant = float(np.linalg.norm(measured - self.transceiver))
        return UsblFix(t, measured, self.covariance(measured), slant, outlier)


def _sinc(a: float) -> float:
    return math.sin(a) / a if a > 1e-12 else 1.0


# --- perception sensors -----------------------------------------------------------------------
class Msis:
    """Mechanically scanned imaging sonar (Tritech Miniking), one beam per step (§5).

    A beam's intensities: Rayleigh background speckle, near-field clutter by the head, and the
    wall's echo where rays across the 3 deg beam meet it at an incidence within beta = 60 deg
    (stronger near the normal), with multiplicative speckle; little comes back from behind it.
    Intensities are on a 0..1 scale in 8-bit steps: about 0.8 from the wall seen square on,
    0.04 background, under 0.15 beyond 0.5 m from the head.
    """

    def __init__(self, env: Environment, scan_period: float = 10.0, step: float = math.radians(1.8),
                 max_range: float = 20.0, bin_size: float = 0.1,
                 beam_width: float = SONAR_BEAM_WIDTH,
                 incidence_limit: float = SONAR_INCIDENCE_LIMIT, near_field: float = 1.0,
                 wall_level: float = 0.8, background_level: float = 0.04,
                 near_level: float = 0.6, speckle: float = 0.3) -> None:
        if not 5.0 <= scan_period <= 20.0:
            raise ValueError(f"Table I: 5-20 s per 360 deg scan, got {scan_period}")
        if not 0.0 < max_range <= 100.0:
            raise ValueError(f"Table I: maximum range 100 m, got {max_range}")
        self.env, self.scan_period, self.step = env, scan_period, step
        self.rate = 2.0 * math.pi / step / scan_period
        self.max_range, self.bin_size = max_range, bin_size
        self.incidence_limit, self.near_field = incidence_limit, near_field
        self.wall_level, self.background_level = wall_level, background_level
        self.near_level, self.speckle = near_level, speckle
        self.offsets = np.linspace(-0.5 * beam_width, 0.5 * beam_width, 7)
        weights = np.exp(-0.5 * (self.offsets / (beam_width / 2.355)) ** 2)
        self.weights = weights / weights.sum()
        n = round(max_range / bin_size)
        self.r = (np.arange(n) + 0.5) * bin_size
        self.schedule = Schedule(self.rate)
        self.beam_count = 0
        # The same numbers every beam, worked out once: the near-field clutter, the rays
        # across the beam, the background's noise beyond the first echo and before it.
        self._near = self.near_level * np.exp(-self.r / (self.near_field / 3.0))
        self._rays = [(offset, self.wall_level * weight) for offset, weight
                      in zip(self.offsets.tolist(), self.weights.tolist())]
        self._cos_limit = math.cos(self.incidence_limit)
        self._bins = self.r.tolist()  # the bins' ranges, ascending, for bisect
        # The background's noise is 0.3 of its level beyond the first echo (r > first echo +
        # 3 bins) and its level before: since r ascends, one array for each first bin beyond.
        beyond, before = (0.3 * self.background_level / math.sqrt(2.0),
                          1.0 * self.background_level / math.sqrt(2.0))
        self._sigmas = [np.where(np.arange(n) >= j, beyond, before) for j in range(n + 1)]
        self._shape = 1.0 / self.speckle**2  # the speckle's gamma shape

    def sample(self, t: float, truth: VehicleState, rng: np.random.Generator) -> SonarBeam | None:
        if not self.schedule.due(t):
            return None
        bearing = wrap_angle(self.beam_count * self.step)
        self.beam_count += 1
        first_echo = math.inf
        x, y, heading = truth.x, truth.y, truth.psi + bearing
        origin = (x, y, truth.z)
        ray_to_wall, wall_normal = self.env.ray_to_wall, self.env.wall_normal
        hits, amplitudes = [], []
        for offset, level in self._rays:  # level: the wall's, times the ray's weight
            phi = heading + offset
            c, s = math.cos(phi), math.sin(phi)
            hit = ray_to_wall(origin, (c, s, 0.0))
            if hit is None or hit > self.max_range:
                continue
            nx, ny = wall_normal(y + hit * s)
            cos_incidence = c * nx + s * ny
            if cos_incidence < self._cos_limit:
                continue
            hits.append(hit)
            amplitudes.append(level * cos_incidence)
            if hit < first_echo:
                first_echo = hit
        # The numbers and their order are those of the plain expressions (each ray's echo added
        # to the near field in turn, then the speckle, the noise, the 8-bit steps), worked out
        # in place: a beam's 200 bins cost less in numpy's calls than in its arithmetic. The
        # rows (near field, then each echo) are summed down the columns, one row after another.
        r = self.r
        if hits:
            rows = np.empty((len(hits) + 1, r.size))
            rows[0] = self._near
            echoes = rows[1:]
            np.subtract(r, np.array(hits)[:, None], out=echoes)
            echoes /= self.bin_size
            np.square(echoes, out=echoes)
            echoes *= -0.5
            np.exp(echoes, out=echoes)
            echoes *= np.array(amplitudes)[:, None]
            profile = np.add.reduce(rows, axis=0)
        else:
            profile = self._near
        k = self._shape  # gamma speckle: mean 1, std self.speckle
        speckle = rng.gamma(k, 1.0 / k, r.size)
        speckle *= profile
        noise = rng.normal(0.0, 1.0, (2, r.size))
        noise *= self._sigmas[bisect.bisect_right(self._bins, first_echo + 3.0 * self.bin_size)]
        noise[0] += speckle
        bins = np.hypot(noise[0], noise[1])
        np.minimum(bins, 1.0, out=bins)  # hypot is never below 0: the clip to 0..1
        bins *= 255.0
        np.rint(bins, out=bins)  # the head's 8-bit output
        bins /= 255.0
        return SonarBeam(t, bearing, bins, self.bin_size)


class Camera:
    """The forward-looking camera: while on, one image every ``interval`` s; records the
    bounding box of what it sees of the wall."""

    def __init__(self, env: Environment, interval: float = CAMERA_INTERVAL,
                 hfov: float = math.radians(50.0), vfov: float = math.radians(38.0),
                 visibility: float = 4.0) -> None:
        self.env, self.interval, self.rate = env, interval, 1.0 / interval
        self.hfov, self.vfov, self.visibility = hfov, vfov, visibility
        self.on = False
        self.images = 0
        self.schedule = Schedule(self.rate)

    def start(self, t: float) -> None:
        """Switch on at t: the first image is taken at t."""
        self.on, self.schedule = True, Schedule(self.rate, t)

    def stop(self) -> None:
        self.on = False

    def footprint(self, truth: VehicleState) -> WallFootprint | None:
        c, s = math.cos(truth.psi), math.sin(truth.psi)
        origin = (truth.x, truth.y, truth.z)
        hits = []
        th, tv = math.tan(0.5 * self.hfov), math.tan(0.5 * self.vfov)
        for bx, by, bz in ((1.0, 0.0, 0.0), (1.0, -th, -tv), (1.0, th, -tv), (1.0, -th, tv),
                           (1.0, th, tv)):
            n = math.sqrt(bx * bx + by * by + bz * bz)
            d = ((c * bx - s * by) / n, (s * bx + c * by) / n, bz / n)
            hit = self.env.ray_to_wall(origin, d)
            if hit is None or hit > self.visibility:
                return None
            hits.append((origin[0] + hit * d[0], origin[1] + hit * d[1], origin[2] + hit * d[2],
                         hit))
        ys, zs = [h[1] for h in hits[1:]], [h[2] for h in hits[1:]]
        return WallFootprint(min(ys), max(ys), min(zs), max(zs), hits[0][3])

    def sample(self, t: float, truth: VehicleState, rng: np.random.Generator) -> CameraImage | None:
        if not self.on or not self.schedule.due(t):
            return None
        self.images += 1
        return CameraImage(t, self.images - 1, self.footprint(truth),
                           (truth.x, truth.y, truth.z, truth.psi))


# --- the pressure vessels' internal sensors ---------------------------------------------------
FaultKind = Literal["leak", "overtemperature", "overpressure"]


@dataclass(frozen=True, slots=True)
class Fault:
    """A fault from time ``at`` (s); ``rate``: deg C/s or bar/s of the rise it causes."""

    kind: FaultKind
    at: float
    rate: float


DEFAULT_FAULT_RATE: dict[str, float] = {"leak": 0.001, "overtemperature": 0.5,
                                        "overpressure": 0.01}


@dataclass
class HousingMonitor:
    """Leak detector, temperature and pressure inside one pressure vessel (§2.1, §3.1)."""

    vessel: str = "computer"
    rate: float = 1.0
    temperature: float = 20.0  # deg C, healthy
    pressure: float = 1.0  # bar, healthy
    temperature_std: float = 0.1
    pressure_std: float = 0.002
    faults: list[Fault] = field(default_factory=list)

    def __post_init__(self) -> None:
        self.schedule = Schedule(self.rate)

    def inject(self, kind: FaultKind, at: float, rate: float | None = None) -> None:
        """From time ``at`` (s): a leak (flag set, pressure creeping up), or temperature or
        pressure rising at ``rate``."""
        self.faults.append(Fault(kind, at, DEFAULT_FAULT_RATE[kind] if rate is None else rate))

    def sample(self, t: float, truth: VehicleState,
               rng: np.random.Generator) -> HousingReading | None:
        if not self.schedule.due(t):
            return None
        active = [f for f in self.faults if t >= f.at]
        temp = self.temperature + sum(f.rate * (t - f.at) for f in active
                                      if f.kind == "overtemperature")
        pres = self.pressure + sum(f.rate * (t - f.at) for f in active if f.kind != "overtemperature")
        noise = rng.normal(0.0, 1.0, 2)
        return HousingReading(t, self.vessel, any(f.kind == "leak" for f in active),
                              temp + self.temperature_std * float(noise[0]),
                              pres + self.pressure_std * float(noise[1]))


# --- the bundle -------------------------------------------------------------------------------
class Sensors:
    """All of the Ictineu's sensors; :meth:`sample` returns the readings due at time t.

    Each sensor draws from its own stream spawned from ``rng``, so adding or removing a sensor
    leaves the others' noise unchanged.
    """

    def __init__(self, env: Environment, rng: np.random.Generator, *, dvl: Dvl | None = None,
                 heading: HeadingSensor | None = None, depth: PressureSensor | None = None,
                 usbl: Usbl | None = None, sonar: Msis | None = None, camera: Camera | None = None,
                 housings: list[HousingMonitor] | None = None) -> None:
        self.dvl = dvl or Dvl(env)
        self.heading = heading or HeadingSensor()
        self.depth = depth or PressureSensor()
        self.usbl = usbl or Usbl()
        self.sonar = sonar or Msis(env)
        self.camera = camera or Camera(env)
        self.housings = housings if housings is not None else [HousingMonitor("power"),
                                                              HousingMonitor("computer")]
        self.all: list[Sensor] = [self.dvl, self.heading, self.depth, self.usbl, self.sonar,
                                  self.camera, *self.housings]
        self._rngs = rng.spawn(len(self.all))

    def remove(self, sensor: Sensor) -> None:
        """Take a sensor out of the bundle; the others keep their own streams (and readings)."""
        i = self.all.index(sensor)
        del self.all[i]
        del self._rngs[i]

    def sample(self, t: float, truth: VehicleState) -> list[Reading]:
        """Every reading due at t (several from one sensor if the caller stepped past them)."""
        out: list[Reading] = []
        for sensor, g in zip(self.all, self._rngs):
            if sensor.schedule.waiting(t):  # not due: its sample would say None
                continue
            for _ in range(1000):
                reading = sensor.sample(t, truth, g)
                if reading is None:
                    break
                out.append(reading)
        return out
