"""Foresti's pipeline tracker (paper 000): the pipe's edges as two lines, and an EKF on the pose.

*Scene model* (§II): the pipe is a cylinder of diameter d whose axis is the Z axis of the
world frame (X across it, to starboard of its direction; Y up). The camera at (Cx, Cy, Cz)
with pan θ, tilt φ and roll ξ has the versors h, v, a of §II, and the perspective
transformation [T] of eq. (1)-(3) maps a scene point to the image (i column, j row).

*Measurement* (§IV, §V-B): Canny edges, straight lines by a Hough transform, each line's
*domain* (the rows where edges support it, small holes filled), its reliabilities PL, PR, PF and
Λ = γPL·PL + γPR·PR + γPF·PF (eq. 6, γ = 0.5, 0.35, 0.15 as Tables I-II); grouping keeps the
pairs compatible with the scene (they neither cross nor diverge, their width fits the pipe)
and picks, when the EKF predicts where the edges are, the pair closest to the prediction (in
the innovation's Mahalanobis distance, whose gate widens as the prediction grows uncertain:
the search when the pipe is lost), else the pair of highest grouping reliability. The
measure z = (i1, i2, i3, i4): the columns where the two edges cross the first and the last
row (Fig. 4); g(x) solves (2b) for Pz on the edges (±d/2, 0, Pz) and substitutes in (2a)
(Appendix, eqs. 18-22).

*EKF* (§V): state x = (Cx, Cy, θ, φ) — Cz drops out (the pipe looks the same all along), the
roll ξ is 0 (no current across, §VI-A); the motion between frames is uniform (eq. 8c-8d with
the vehicle's surge and sway over the interval τ), the angles constant (eq. 9) but for the
vehicle's own yaw rate and heave (inputs here, 0 in the paper); Q, R, x0, P0 of §VI-A.
A frame without a measurement keeps the prediction (eq. 17a-b, Chen's method): the
covariance grows until the pipe is seen again.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import cv2
import numpy as np
import numpy.typing as npt

FloatArray = npt.NDArray[np.float64]

# §VI-A: R for 4 px on each abscissa; Q for 0.1 m on Cx and Cy, 2 deg on θ, 5 deg on φ (the
# paper's diagonal as printed); P0 as printed.
R_PAPER = np.diag([16.0, 16.0, 16.0, 16.0])
Q_PAPER = np.diag([0.01, 0.01, 0.0012, 0.087])
P0_PAPER = np.diag([1.0, 1.0, 0.3, 0.3])
GAMMA = (0.5, 0.35, 0.15)  # γPL, γPR, γPF (Tables I and II)
GATE = 18.47  # chi-square, 4 degrees of freedom, 0.999


def versors(theta: float, phi: float, xi: float = 0.0
            ) -> tuple[FloatArray, FloatArray, FloatArray]:
    """h (image columns), v (image rows) and a (optical axis) of §II, from pan θ, tilt φ and
    roll ξ."""
    st, ct, sp, cp, sx, cx = (math.sin(theta), math.cos(theta), math.sin(phi), math.cos(phi),
                              math.sin(xi), math.cos(xi))
    h = np.array([ct * cx, -sx * ct, -st])
    v = np.array([-sp * st * cx - cp * sx, -cp * cx + sp * st * sx, -sp * ct])
    a = np.array([cp * st * cx - sp * sx, -sp * cx + st * sx * cp, cp * ct])
    return h, v, a


@dataclass(frozen=True)
class PipeModel:
    """The pipe's diameter and the camera's intrinsics (focal length in pixels, f/δx = f/δy,
    image size, centre (i0, j0))."""

    diameter: float
    focal: float
    width: int
    height: int

    @property
    def centre(self) -> tuple[float, float]:
        return ((self.width - 1) / 2, (self.height - 1) / 2)

    def calibration(self, x: FloatArray) -> FloatArray:
        """[T] (3 x 4) of eq. (1) for state (Cx, Cy, θ, φ), Cz = 0, ξ = 0 (eq. 3)."""
        cx, cy, theta, phi = (float(e) for e in x[:4])
        h, v, a = versors(theta, phi)
        c = np.array([cx, cy, 0.0])
        i0, j0 = self.centre
        f = self.focal
        return np.array([
            [*(f * h + i0 * a), -f * (c @ h) - i0 * (c @ a)],
            [*(f * v + j0 * a), -f * (c @ v) - j0 * (c @ a)],
            [*a, -(c @ a)]])

    def g(self, x: FloatArray) -> FloatArray:
        """The measure model z = g(x) = (i1, i2, i3, i4): columns of the edges X = -d/2 and
        X = +d/2 (in the plane Y = 0 of the axis) at the first row and at the last."""
        t = self.calibration(x)
        out = []
        for j in (0.0, float(self.height - 1)):
            for px in (-self.diameter / 2, self.diameter / 2):
                # (2b) solved for Pz, then (2a)
                den = j * t[2, 2] - t[1, 2]
                if abs(den) < 1e-12:
                    den = 1e-12
                pz = (t[1, 0] * px + t[1, 3] - j * (t[2, 0] * px + t[2, 3])) / den
                w = t[2, 0] * px + t[2, 2] * pz + t[2, 3]
                out.append((t[0, 0] * px + t[0, 2] * pz + t[0, 3]) / (w if abs(w) > 1e-12
                                                                       else 1e-12))
        return np.array(out)

    def jacobian(self, x: FloatArray) -> FloatArray:
        """G = dg/dx (central differences)."""
        steps = (1e-4, 1e-4, 1e-5, 1e-5)
        cols = []
        for k, hstep in enumerate(steps):
            e = np.zeros(4)
            e[k] = hstep
            cols.append((self.g(x + e) - self.g(x - e)) / (2 * hstep))
        return np.stack(cols, axis=1)


# --- feature extraction (§IV) -----------------------------------------------------------------
@dataclass(frozen=True)
class Line:
    """A straight line in normal form x cos α + y sin α = ρ (pixels), with its domain and
    reliabilities (eq. 5-6)."""

    rho: float
    alpha: float
    pl: float
    pr: float
    pf: float
    reliability: float  # Λ

    def column(self, row: float) -> float:
        return (self.rho - row * math.sin(self.alpha)) / math.cos(self.alpha)


@dataclass
class FeatureExtraction:
    """Edges (Canny), lines (Hough) with domains and reliability Λ, and grouping into pairs."""

    width: int
    height: int
    canny: tuple[int, int] = (25, 60)
    min_pl: float = 0.4  # the paper shows PL > 0.5 and PR > 0.65 (Fig. 8): a little looser
    min_pr: float = 0.5  # for the part-buried, overgrown stretches of the scene here
    max_lines: int = 24

    def lines(self, image: npt.NDArray[np.uint8]) -> list[Line]:
        blur = cv2.GaussianBlur(image, (5, 5), 1.2)
        edges = cv2.Canny(blur, self.canny[0], self.canny[1], L2gradient=True)
        gx = cv2.Sobel(blur, cv2.CV_32F, 1, 0, ksize=3)
        gy = cv2.Sobel(blur, cv2.CV_32F, 0, 1, ksize=3)
        modulus = cv2.magnitude(gx, gy)
        found = cv2.HoughLines(edges, 1, math.pi / 180, max(20, self.height // 4))
        if found is None:
            return []
        h = self.height
        rows = np.arange(h)
        kernel = np.ones(5, np.uint8)
        candidates: list[tuple[float, float, float, float, float, float]] = []
        for rho, alpha in found[: self.max_lines * 3, 0]:
            if abs(math.cos(alpha)) < math.cos(math.radians(50)):
                continue  # along the image's rows: not a pipe running under the vehicle
            cols = np.rint((rho - rows * math.sin(alpha)) / math.cos(alpha)).astype(int)
            inside = (cols >= 1) & (cols < self.width - 1)
            dom = np.zeros(h, np.uint8)
            r_in, c_in = rows[inside], cols[inside]
            hit = (edges[r_in, c_in] | edges[r_in, c_in - 1] | edges[r_in, c_in + 1]) > 0
            dom[r_in[hit]] = 1
            # restoration of the domain: fill small holes (a closing), drop isolated points
            closed = cv2.morphologyEx(dom.reshape(-1, 1), cv2.MORPH_CLOSE,
                                      kernel.reshape(-1, 1))
            dom = np.asarray(cv2.morphologyEx(closed, cv2.MORPH_OPEN,
                                              np.ones((3, 1), np.uint8)), np.uint8).ravel()
            ones = np.flatnonzero(dom)
            if len(ones) < 2:
                continue
            d1, d2 = int(ones[0]), int(ones[-1])
            pl = (d2 - d1) / h  # (6a)
            pr = len(ones) / max(1, d2 - d1)  # (6b)
            m = float(modulus[r_in[hit], c_in[hit]].mean()) if hit.any() else 0.0
            candidates.append((float(rho), float(alpha), pl, min(pr, 1.0), m, 0.0))
        if not candidates:
            return []
        m_max = max(c[4] for c in candidates) or 1.0
        out: list[Line] = []
        for rho, alpha, pl, pr, m, _ in candidates:
            if pl < self.min_pl or pr < self.min_pr:
                continue
            pf = m / m_max  # (6c)
            lam = GAMMA[0] * pl + GAMMA[1] * pr + GAMMA[2] * pf  # (6d)
            line = Line(rho, alpha, pl, pr, pf, lam)
            mid = line.column(h / 2)
            dup = [k for k, o in enumerate(out) if abs(o.column(h / 2) - mid) < 3
                   and abs(math.sin(o.alpha - alpha)) < math.sin(math.radians(4))]
            if dup:
                if out[dup[0]].reliability < lam:
                    out[dup[0]] = line
                continue
            out.append(line)
        out.sort(key=lambda ln: -ln.reliability)
        return out[: self.max_lines]

    def pairs(self, lines: list[Line], image: npt.NDArray[np.uint8],
              expected: tuple[float, float] | None
              ) -> list[tuple[FloatArray, float]]:
        """Compatible pairs as (z = (i1, i2, i3, i4), grouping reliability ΔR), best first.
        ``expected``: the pipe's width in pixels at the first and the last row, if known."""
        h = self.height - 1
        out = []
        for a in range(len(lines)):
            for b in range(a + 1, len(lines)):
                la, lb = lines[a], lines[b]
                if la.column(h / 2) > lb.column(h / 2):
                    la, lb = lb, la
                z = np.array([la.column(0), lb.column(0), la.column(h), lb.column(h)])
                top, bottom = z[1] - z[0], z[3] - z[2]
                if top < 2 or bottom < 2:
                    continue  # they cross in the image
                ratio = top / bottom
                if not 0.4 <= ratio <= 1.25:
                    continue  # they diverge away from the camera, or converge too fast
                fit = 1.0
                if expected is not None:
                    err = abs(math.log((top + bottom) / max(1.0, expected[0] + expected[1])))
                    if err > math.log(1.8):
                        continue  # not the pipe's width
                    fit = 1.0 - err / math.log(1.8)
                contrast = self._contrast(image, z)
                if contrast < 8.0:
                    continue  # no surface between them that differs from the sand beside
                symmetry = 1.0 - min(1.0, abs(la.pl - lb.pl))
                delta_r = (0.5 * (la.reliability + lb.reliability)
                           * (0.5 + 0.25 * fit + 0.25 * symmetry) * min(1.0, contrast / 30.0))
                out.append((z, delta_r))
        out.sort(key=lambda p: -p[1])
        return out

    def _contrast(self, image: npt.NDArray[np.uint8], z: FloatArray) -> float:
        """|mean inside - mean beside| along a few rows (grey levels)."""
        h = self.height - 1
        diffs = []
        for frac in (0.2, 0.5, 0.8):
            row = int(frac * h)
            left = z[0] + (z[2] - z[0]) * frac
            right = z[1] + (z[3] - z[1]) * frac
            w = right - left
            lo, hi = int(left + 0.25 * w), int(right - 0.25 * w) + 1
            band = max(2, int(0.4 * w))
            beside = np.concatenate([
                image[row, max(0, int(left) - 2 - band):max(0, int(left) - 2)],
                image[row, min(self.width, int(right) + 3):min(self.width,
                                                               int(right) + 3 + band)]])
            if hi <= lo or lo < 0 or hi > self.width or beside.size < 2:
                continue
            diffs.append(abs(float(image[row, lo:hi].mean()) - float(beside.mean())))
        return float(np.median(diffs)) if diffs else 0.0


# --- the EKF (§V) ------------------------------------------------------------------------------
@dataclass
class PipelineTracker:
    """Foresti's EKF on (Cx, Cy, θ, φ), fed by the feature extraction, one frame at a time."""

    model: PipeModel
    x: FloatArray = field(default_factory=lambda: np.zeros(4))
    P: FloatArray = field(default_factory=lambda: P0_PAPER.copy())
    Q: FloatArray = field(default_factory=lambda: Q_PAPER.copy())
    R: FloatArray = field(default_factory=lambda: R_PAPER.copy())
    nominal_tilt: float = math.radians(75.0)  # φ of the mount (σ = φ - this)
    acquired: bool = False
    missing: int = 0  # frames in a row without a measurement
    reacquire_after: int = 12  # frames: then the gate is dropped (the pipe is searched anew)
    last_z: FloatArray | None = None

    def __post_init__(self) -> None:
        self.features = FeatureExtraction(self.model.width, self.model.height)

    @classmethod
    def start(cls, model: PipeModel, height: float, tilt: float) -> PipelineTracker:
        """x0 = (0, height above the axis, 0, tilt), P0 of §VI-A."""
        return cls(model, x=np.array([0.0, height, 0.0, tilt]), nominal_tilt=tilt)

    # (15a-b) with eq. 8c-8d and 9
    def predict(self, tau: float, surge: float, sway: float, yaw_rate: float = 0.0,
                heave: float = 0.0) -> None:
        cx, cy, theta, phi = self.x
        sigma = phi - self.nominal_tilt
        ct, st = math.cos(theta), math.sin(theta)
        self.x = np.array([cx + (sway * ct + surge * math.cos(sigma) * st) * tau,
                           cy - (surge * math.sin(sigma) + heave) * tau,
                           theta + yaw_rate * tau, phi])
        F = np.eye(4)
        F[0, 2] = (-sway * st + surge * math.cos(sigma) * ct) * tau
        F[0, 3] = -surge * math.sin(sigma) * st * tau
        F[1, 3] = -surge * math.cos(sigma) * tau
        self.P = F @ self.P @ F.T + self.Q

    def expected_widths(self) -> tuple[float, float]:
        z = self.model.g(self.x)
        return float(z[1] - z[0]), float(z[3] - z[2])

    def measure(self, image: npt.NDArray[np.uint8]) -> FloatArray | None:
        """The frame's measure z, or None (no compatible pair; outside the gate)."""
        lines = self.features.lines(image)
        pairs = self.features.pairs(lines, image, self.expected_widths())
        if not pairs:
            return None
        if not self.acquired or self.missing >= self.reacquire_after:
            return pairs[0][0] if pairs[0][1] > 0.35 else None
        zhat = self.model.g(self.x)
        G = self.model.jacobian(self.x)
        S = G @ self.P @ G.T + self.R
        Sinv = np.linalg.inv(S)
        best, best_d = None, GATE
        for z, _ in pairs:
            nu = z - zhat
            d = float(nu @ Sinv @ nu)
            if d < best_d:
                best, best_d = z, d
        return best

    def update(self, z: FloatArray | None) -> bool:
        """(16a-c) with z; without one (17a-b): the prediction stands. True if updated."""
        self.last_z = z
        if z is None:
            self.missing += 1
            return False
        if not self.acquired or self.missing >= self.reacquire_after:
            self.P = np.maximum(self.P, P0_PAPER)  # start over from the search
        prior = self.x.copy()
        x = prior
        for _ in range(1 if self.acquired else 4):  # iterated on acquisition (far from x0)
            G = self.model.jacobian(x)
            S = G @ self.P @ G.T + self.R
            K = self.P @ G.T @ np.linalg.inv(S)
            x = prior + K @ (z - self.model.g(x) - G @ (prior - x))
        self.x = x
        self.P = (np.eye(4) - K @ G) @ self.P
        self.P = 0.5 * (self.P + self.P.T)
        self.x[2] = math.remainder(float(self.x[2]), 2 * math.pi)
        self.acquired = True
        self.missing = 0
        return True

    def step(self, image: npt.NDArray[np.uint8]) -> bool:
        """Measure and update (after :meth:`predict`): True if the pipe was measured."""
        return self.update(self.measure(image))

    # -- in the vehicle's terms ---------------------------------------------------------------
    @property
    def offset(self) -> float:
        """Where the pipe's axis is beside the vehicle (m, + starboard): -Cx."""
        return -float(self.x[0])

    @property
    def angle(self) -> float:
        """The pipe's direction relative to the vehicle's heading (rad, + starboard): -θ."""
        return -float(self.x[2])
