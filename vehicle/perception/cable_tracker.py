"""Wirth's Condensation cable tracker (paper 004, chapters 3-5): a particle filter on the cable's
borders in the image.

*State* (§4.2, §4.4): x = (d, α, w, β, v_d, v_α) — the distance (px) from the image centre to
the cable's centreline, the centreline's angle (rad, 0 along the image's columns, + leaning to
the right at the top), the cable's width (px), its skew β (each border leans towards the
centreline by β: the perspective of a camera looking slightly forward), and the velocities of d
and α (per frame). Image coordinates as in the thesis: origin at the image centre, x to the
right, y up.

*Movement model* (eq. 4.9): drift d += v_d, α += v_α; diffuse every component with Gaussian
noise of the variances of Table 5.1 (σ_d² 0.5 px², σ_α² 0.01 deg², σ_w² 4 px², σ_β² 0.1 deg²,
σ_vd² 8 px², σ_vα² 0.005 deg²).

*Observation model* (§4.5): along each hypothetical border, every ``sample distance`` px (20,
Table 5.1), a derivative-of-Gaussian filter (eq. 4.10) of ``filter size`` px (11, σ ≈ 1.6)
across the border; the responses summed are the border's score c; the particle's weight is
c_l - c_r when c_l > 0 > c_r (a dark cable), c_r - c_l when c_r > 0 > c_l (a bright one), ε
otherwise (eq. 4.11), normalised (eq. 4.12).

*Algorithm* (Fig. 4.10, §3.4): resample (cumulative weights, binary search) when the estimated
number of effective particles (eq. 3.10) falls below N/2, drift and diffuse, measure, and take
the minimum-mean-square estimate. 500 particles (§5.2.1). Initialisation: around a known state
(the thesis uses ground truth; here the detection of the pipeline tracker's feature extraction,
as its §6.1 proposes) or uniform within Table 5.2's limits.

*Confidence and recovery* (not in the thesis, whose cable never left the image): the
estimate's own score per sample point; below ``min_score`` grey levels the cable counts as not
in view this frame, and after two such frames a fifth of the particles is drawn again around
the last estimate that looked like a cable, velocities damped (:meth:`CableTracker.reseed`).
The stack also seeds the particles from a detection (the thesis's §6.1 proposal) when a
follower starts, and turns them by the vehicle's own yaw between frames (its odometry).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
import numpy.typing as npt

FloatArray = npt.NDArray[np.float64]

DEG2 = (math.pi / 180) ** 2
# Table 5.1: movement model variances (per frame), in the state's units (px, rad)
TABLE_5_1 = {"d": 0.5, "alpha": 0.01 * DEG2, "w": 4.0, "beta": 0.1 * DEG2, "v_d": 8.0,
             "v_alpha": 0.005 * DEG2, "filter_size": 11, "sample_distance": 20}
# Table 5.2: limits for a random initialisation
TABLE_5_2 = ((-150.0, 150.0), (math.radians(-45), math.radians(45)), (5.0, 100.0),
             (0.0, math.radians(10)), (-1.0, 1.0), (math.radians(-0.1), math.radians(0.1)))
EPSILON = 1e-3


def dog_filter(size: int) -> FloatArray:
    """The derivative-of-Gaussian filter of eq. 4.10, ``size`` taps (σ = size / 7)."""
    sigma = size / 7.0
    x = np.arange(size) - (size - 1) / 2
    return np.asarray(-x / (sigma ** 3 * math.sqrt(2 * math.pi)) * np.exp(-x * x / (2 * sigma ** 2)))


@dataclass
class CableTracker:
    width: int
    height: int
    particles: int = 500
    variances: dict[str, float] = field(default_factory=lambda: dict(TABLE_5_1))
    min_score: float = 2.5  # grey levels per sample point (see the module's docstring)
    seed: int = 0
    states: FloatArray = field(init=False)
    weights: FloatArray = field(init=False)

    def __post_init__(self) -> None:
        self.rng = np.random.default_rng(self.seed)
        size = int(self.variances["filter_size"])
        self.taps = dog_filter(size)
        self.offsets = np.arange(size) - (size - 1) / 2
        reach = math.hypot(self.width, self.height) / 2
        step = float(self.variances["sample_distance"])
        self.along = np.arange(-math.floor(reach / step), math.floor(reach / step) + 1) * step
        self.sigma = np.sqrt(np.array([self.variances[k] for k in
                                       ("d", "alpha", "w", "beta", "v_d", "v_alpha")]))
        self.estimate = np.zeros(6)
        self.score = 0.0
        self.unseen = 0  # frames in a row below min_score
        self.last_good: FloatArray | None = None  # the last estimate that looked like a cable
        self.randomise()
        self.image: FloatArray | None = None

    # -- initialisation (§4.3) -------------------------------------------------------------------
    def randomise(self) -> None:
        """Uniform within Table 5.2's limits (eq. 4.1), equal weights."""
        lo = np.array([a for a, _ in TABLE_5_2])
        hi = np.array([b for _, b in TABLE_5_2])
        self.states = lo + self.rng.random((self.particles, 6)) * (hi - lo)
        self.weights = np.full(self.particles, 1.0 / self.particles)

    def start_at(self, d: float, alpha: float, w: float, beta: float,
                 spread: tuple[float, float, float, float] = (4.0, 0.03, 3.0, 0.01)) -> None:
        """Around a known state (ground truth, or a detection), equal weights."""
        centre = np.array([d, alpha, w, beta, 0.0, 0.0])
        scale = np.array([*spread, 0.5, 0.002])
        self.states = centre + self.rng.normal(0.0, 1.0, (self.particles, 6)) * scale
        self.states[:, 2] = np.maximum(self.states[:, 2], 2.0)
        self.weights = np.full(self.particles, 1.0 / self.particles)
        self.last_good = centre
        self.unseen = 0

    # -- one iteration (Fig. 4.10) ---------------------------------------------------------------
    def effective_particles(self) -> float:
        return float(1.0 / np.sum(self.weights ** 2))  # eq. 3.10

    def resample(self) -> None:
        """Cumulative weights (eq. 3.8-3.9), a binary search per new particle (Fig. 3.6)."""
        c = np.cumsum(self.weights)
        c /= c[-1]
        idx = np.searchsorted(c, self.rng.random(self.particles), side="right")
        self.states = self.states[np.minimum(idx, self.particles - 1)]
        self.weights = np.full(self.particles, 1.0 / self.particles)

    def drift_and_diffuse(self, turn: float = 0.0, shift: float = 0.0) -> None:
        """Eq. 4.9; ``turn`` (rad) and ``shift`` (px) are the vehicle's own yaw since the last
        frame as seen in the image (0 in the thesis, whose model has no odometry)."""
        s = self.states
        s[:, 0] += s[:, 4] + shift
        s[:, 1] += s[:, 5] + turn
        s += self.rng.normal(0.0, 1.0, s.shape) * self.sigma
        s[:, 2] = np.clip(s[:, 2], 2.0, 0.8 * self.width)
        s[:, 3] = np.clip(s[:, 3], -math.radians(20), math.radians(20))
        s[:, 1] = np.clip(s[:, 1], -math.radians(80), math.radians(80))

    def border_scores(self, states: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray]:
        """(c_l, c_r, the number of sample points inside the image) for every state."""
        assert self.image is not None
        d, alpha, w, beta = states[:, 0], states[:, 1], states[:, 2], states[:, 3]
        nx, ny = np.cos(alpha), -np.sin(alpha)  # the centreline's normal (to the right)
        cx, cy = d * nx, d * ny  # its point nearest the image centre
        out = []
        counts = np.zeros(len(states))
        for side in (-1.0, 1.0):
            a = alpha - side * beta  # the left border leans right at the top (+β), the right left
            tx, ty = np.sin(a), np.cos(a)  # along the border, upwards
            bx, by = cx + side * w / 2 * nx, cy + side * w / 2 * ny
            # sample points along the border, the filter across it (along the normal)
            px = bx[:, None] + self.along[None, :] * tx[:, None]
            py = by[:, None] + self.along[None, :] * ty[:, None]
            qx = px[:, :, None] + self.offsets[None, None, :] * np.cos(a)[:, None, None]
            qy = py[:, :, None] - self.offsets[None, None, :] * np.sin(a)[:, None, None]
            col = np.rint(qx + (self.width - 1) / 2).astype(np.int64)
            row = np.rint((self.height - 1) / 2 - qy).astype(np.int64)
            ok = ((col >= 0) & (col < self.width) & (row >= 0) & (row < self.height)).all(axis=2)
            col = np.clip(col, 0, self.width - 1)
            row = np.clip(row, 0, self.height - 1)
            resp = (self.image[row, col] * self.taps[None, None, :]).sum(axis=2)
            out.append(np.where(ok, resp, 0.0).sum(axis=1))
            counts += ok.sum(axis=1)
        return out[0], out[1], counts

    def measure(self) -> None:
        """Eq. 4.11-4.12."""
        cl, cr, _ = self.border_scores(self.states)
        raw = np.where((cl > 0) & (cr < 0), cl - cr,
                       np.where((cr > 0) & (cl < 0), cr - cl, EPSILON))
        self.weights = raw / raw.sum()

    def step(self, image: npt.NDArray[np.uint8], yaw: float = 0.0, tilt: float = 0.0,
             focal: float = 1.0) -> bool:
        """One iteration on a new image; True if the estimate looks like a cable. ``yaw``: the
        vehicle's turn since the last frame (rad, + starboard; 0: the thesis's model), which
        turns the cable the other way in the image and, for a camera ``tilt`` forward, shifts
        the point under the image centre by about focal·tan(yaw)·sin(tilt) pixels."""
        self.image = image.astype(np.float64)
        if self.effective_particles() < self.particles / 2:
            self.resample()
        self.drift_and_diffuse(-yaw / max(math.cos(tilt), 0.2),
                               -focal * math.tan(yaw) * math.sin(tilt))
        if self.unseen >= 2 and self.last_good is not None:
            self.reseed()
        self.measure()
        self.estimate = self.weights @ self.states  # the MMSE estimate
        cl, cr, n = self.border_scores(self.estimate[None, :])
        c_l, c_r, count = float(cl[0]), float(cr[0]), max(1.0, float(n[0]))
        self.score = abs(c_l - c_r) / count if c_l * c_r < 0 else 0.0
        seen = self.score >= self.min_score
        self.unseen = 0 if seen else self.unseen + 1
        if seen:
            self.last_good = self.estimate.copy()
        return seen

    def reseed(self, share: float = 0.2) -> None:
        """Recovery (not in the thesis, whose cable never left the image): while the cable is
        out of sight, a share of the particles is drawn again around the last estimate that
        looked like a cable (20 px, 8 deg, 3 px), and the velocities are damped, so that the
        particles stay where it will most likely show again instead of diffusing away."""
        assert self.last_good is not None
        k = int(share * self.particles)
        idx = self.rng.choice(self.particles, k, replace=False)
        spread = np.array([20.0, math.radians(8), 3.0, 0.01, 0.5, 0.002])
        centre = self.last_good.copy()
        centre[4:] = 0.0
        self.states[idx] = centre + self.rng.normal(0.0, 1.0, (k, 6)) * spread
        self.states[:, 2] = np.maximum(self.states[:, 2], 2.0)
        self.states[:, 4:] *= 0.5

    # -- in the vehicle's terms (the camera's geometry) -----------------------------------------
    def in_vehicle_terms(self, focal: float, tilt: float, height: float) -> tuple[float, float]:
        """(offset m, + starboard; angle rad, + starboard) of the cable relative to the vehicle,
        from the estimate, for a camera ``tilt`` forward of the vertical at ``height`` m above
        the cable: the image centre looks at a point height·tan(tilt) ahead, range
        height/cos(tilt); a ground direction γ shows at tan α = tan γ / cos(tilt)."""
        d, alpha = float(self.estimate[0]), float(self.estimate[1])
        rng = height / math.cos(tilt)
        ahead = height * math.tan(tilt)
        gamma = math.atan(math.tan(alpha) * math.cos(tilt))
        lateral_ahead = d / math.cos(alpha) * rng / focal
        return lateral_ahead - ahead * math.tan(gamma), gamma
