"""The downward camera over the seabed: a pinhole camera rendering grey images from the true pose.

Mounted at the vehicle's centre, looking down and ``tilt`` forward of the vertical (paper 004's
camera "points slightly forward"; paper 000's tilt angle is 90 deg minus this), image rows
upwards = forward, columns rightwards = starboard. Each pixel's ray is cut with the plane of
the line's axis (a pipe is a cylinder lying on the floor; its edges are taken in that plane,
the approximation of paper 000 §V-B) and with the floor; the pixel's grey level is the albedo
there (sand texture, the pipe shaded as a cylinder, marine growth), lit by the vehicle's lamp
(inverse-square falloff and absorption along the ray, normalised to the centre pixel as an
auto-exposure would), plus backscatter from suspended particles (bright specks) and sensor
noise. Images are ``width`` x ``height`` grey levels (uint8), 160 x 120 by default.

Chosen here: 60 deg horizontal field of view, 15 deg forward tilt, 4 frames a second (paper 000's rate), noise
of 3 grey levels, absorption 0.15 /m, 12 particles per frame.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from vehicle.world.seabed import LaidLine, Seabed

FloatArray = npt.NDArray[np.float64]
Image = npt.NDArray[np.uint8]
_LIGHT: dict[DownwardCamera, dict[float, FloatArray]] = {}
_yy, _xx = np.mgrid[-4:5, -4:5]
_PARTICLE = np.exp(-(_xx * _xx + _yy * _yy) / (2 * 1.4 ** 2))  # one particle's blur


@dataclass(frozen=True)
class DownwardCamera:
    width: int = 160
    height: int = 120
    hfov: float = math.radians(60.0)
    tilt: float = math.radians(15.0)  # forward of the vertical
    rate: float = 4.0  # frames a second
    noise: float = 3.0  # grey levels, 1 sigma
    absorption: float = 0.15  # 1/m
    particles: int = 12  # suspended particles in view per frame

    @property
    def focal(self) -> float:
        """Focal length in pixels (f / delta x of paper 000)."""
        return (self.width / 2) / math.tan(self.hfov / 2)

    @property
    def centre(self) -> tuple[float, float]:
        return ((self.width - 1) / 2, (self.height - 1) / 2)

    def axes(self, psi: float) -> tuple[FloatArray, FloatArray, FloatArray]:
        """The camera's right (image x), down (image y) and optical axes in the world frame."""
        c, s = math.cos(psi), math.sin(psi)
        fwd = np.array([c, s, 0.0])
        stbd = np.array([-s, c, 0.0])
        down = np.array([0.0, 0.0, 1.0])
        t = self.tilt
        optical = math.sin(t) * fwd + math.cos(t) * down
        image_down = -math.cos(t) * fwd + math.sin(t) * down
        return stbd, image_down, optical

    def rays(self, psi: float) -> tuple[FloatArray, FloatArray, FloatArray]:
        """The x, y, z world components (each (H, W)) of every pixel's ray (not normalised)."""
        right, down, optical = self.axes(psi)
        cx, cy = self.centre
        u = ((np.arange(self.width) - cx) / self.focal)[None, :]
        v = ((np.arange(self.height) - cy) / self.focal)[:, None]
        rx = optical[0] + u * right[0] + v * down[0]
        ry = optical[1] + u * right[1] + v * down[1]
        rz = optical[2] + u * right[2] + v * down[2] + 0.0 * u
        return rx, ry, rz

    def project(self, pose: tuple[float, float, float, float],
                points: FloatArray) -> FloatArray:
        """World points (N, 3) to pixels (N, 2: column, row); NaN behind the camera."""
        x, y, z, psi = pose
        right, down, optical = self.axes(psi)
        q = np.asarray(points, float) - np.array([x, y, z])
        depth = q @ optical
        cx, cy = self.centre
        with np.errstate(divide="ignore", invalid="ignore"):
            col = cx + self.focal * (q @ right) / depth
            row = cy + self.focal * (q @ down) / depth
        out = np.stack([col, row], axis=1)
        out[depth <= 1e-6] = np.nan
        return out

    def line_in_image(self, pose: tuple[float, float, float, float], line: LaidLine,
                      floor_depth: float) -> tuple[FloatArray, FloatArray]:
        """The line's two edges (port, starboard) as pixel columns at every image row, from
        the true pose: the ground truth a tracker is measured against. (H,) arrays each."""
        x, y, z, psi = pose
        rx, ry, rz = self.rays(psi)
        zp = floor_depth - line.diameter / 2
        t = (zp - z) / rz
        s_seen = line.frame(x + t * rx, y + t * ry)[0]
        ss = np.linspace(float(s_seen.min()) - 1.0, float(s_seen.max()) + 1.0, 400)
        rows = np.arange(self.height, dtype=float)
        edges = []
        for side in (-1.0, 1.0):
            pts = []
            for sk in ss:
                px, py = line.point(float(sk))
                h = line.direction(float(sk))
                pts.append((px - side * line.diameter / 2 * math.sin(h),
                            py + side * line.diameter / 2 * math.cos(h), zp))
            pix = self.project(pose, np.array(pts))
            order = np.argsort(pix[:, 1])
            edges.append(np.interp(rows, pix[order, 1], pix[order, 0]))
        return edges[0], edges[1]

    def lighting(self, altitude: float) -> FloatArray:
        """The lamp at the camera: inverse square and absorption along each pixel's ray,
        normalised at the centre pixel (auto exposure) — a function of the altitude alone over
        a flat floor (cached by the centimetre)."""
        key = round(max(altitude, 0.05), 2)
        cache = _LIGHT.setdefault(self, {})
        if key not in cache:
            if len(cache) > 512:
                cache.clear()
            rx, ry, rz = self.rays(0.0)
            norm = np.sqrt(rx * rx + ry * ry + rz * rz)
            k = norm / rz  # range per metre of altitude
            kc = k[self.height // 2, self.width // 2]
            cache[key] = (rz / norm) * (kc / k) ** 2 * np.exp(-self.absorption * key * (k - kc))
        return cache[key]

    def render(self, seabed: Seabed, pose: tuple[float, float, float, float], t: float,
               rng: np.random.Generator) -> Image:
        """One grey image of the seabed from the true pose (x, y, z, psi) at time t."""
        x, y, z, psi = pose
        rx, ry, rz = self.rays(psi)
        rz = np.maximum(rz, 1e-6)
        floor_t = (seabed.floor_depth - z) / rz
        fx, fy = x + floor_t * rx, y + floor_t * ry
        albedo = seabed.sand(fx, fy)
        buried = seabed.buried_from is not None and t >= seabed.buried_from
        corners = (slice(None, None, self.height - 1), slice(None, None, self.width - 1))
        for line in seabed.lines:
            if buried:
                break
            r = line.diameter / 2
            zp = seabed.floor_depth - r
            lt = (zp - z) / rz
            lx, ly = x + lt * rx, y + lt * ry
            cs, ce, _ = line.frame(lx[corners], ly[corners])
            if (ce.min() > 2 * r or ce.max() < -2 * r or cs.max() < 0
                    or cs.min() > line.length):
                continue  # the footprint (convex) lies on one side of the line
            s0 = float(line.frame(lx[self.height // 2, self.width // 2],
                                  ly[self.height // 2, self.width // 2])[0])
            s, e = line.frame_near(lx, ly, s0)
            near = np.abs(e) < r * 1.6
            if not near.any():
                continue
            s, e = s[near], e[near]  # the pixels near the line only
            share = line.visible_share(s)
            # the width seen from above: whole while the sand stays below the axis, then the
            # chord at the sand's level
            half = np.where(share >= 0.5, r, 2 * r * np.sqrt(np.clip(share * (1 - share), 0, 1)))
            on = (np.abs(e) < half) & (share > 0)
            shade = np.sqrt(np.clip(1 - (e / r) ** 2, 0.0, 1.0))  # the cylinder's normal
            value = line.albedo * (0.7 + 0.3 * shade)
            sand = albedo[near]
            grown = line.overgrown(s)
            if grown.any():
                g = np.clip(seabed.growth(lx[near], ly[near]), 0, 1)
                value = np.where(grown, value * (1 - 0.45 * g) + 0.1 * g, value)
                # growth and its shadow spill onto the sand beside the pipe
                sand = np.where(grown & ~on, sand * (1 - 0.3 * g), sand)
            # sand over a part-buried stretch lies in a faint mound along the line
            sand = np.where(~on & (share < 1) & (share > 0), sand * 1.04, sand)
            albedo[near] = np.where(on, value, sand)
        img = 200.0 * albedo * self.lighting(seabed.floor_depth - z) + 12.0  # + backscatter
        # suspended particles: small bright blurs (a stamp per particle)
        cols = rng.integers(0, self.width, self.particles)
        rows = rng.integers(0, self.height, self.particles)
        gains = rng.uniform(20, 60, self.particles)
        k = _PARTICLE.shape[0] // 2
        for c, r, g in zip(cols, rows, gains):
            y0, y1, x0, x1 = max(0, r - k), min(self.height, r + k + 1), max(0, c - k), \
                min(self.width, c + k + 1)
            img[y0:y1, x0:x1] += g * _PARTICLE[y0 - r + k:y1 - r + k, x0 - c + k:x1 - c + k]
        img += self.noise * rng.standard_normal(img.shape, dtype=np.float32)
        return np.clip(img, 0, 255).astype(np.uint8)
