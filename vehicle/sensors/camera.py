"""The camera that sees the wall (paper 002 §6.1): a pinhole camera rendering the dam wall.

The wall is a texture generated from a seed (vehicle/sensors/wall_texture.py). Each image is
rendered from the vehicle's true pose: rays through every pixel of a pinhole camera (no roll or
pitch: the Ictineu is passively stable), cut with the wall surface x = wall_curvature * y**2,
sampled from the texture; then the conditions of §6.7 as far as they matter for registration: the
vehicle's lamp (a spot off the optical axis with cos^4 fall-off), light lost over the range
(lamp to wall and back), backscatter and the water's colour, a mild blur, and sensor noise.

Chosen here (the paper gives no camera figures): 320 x 240 pixels (small, to be fast), square
pixels, focal length 343.1 px (50 deg horizontal, 38.6 deg vertical field of view: the 50 x 38
deg of vehicle.sensors.instruments.Camera), principal point at the centre, no lens distortion (§6.1
removes it before anything else); attenuation 0.25 /m (green water of a reservoir; red
0.45 /m, blue 0.3 /m). The images of a run are written by vehicle/sensors/image_recorder.py.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
import numpy.typing as npt

from vehicle.sensors.wall_texture import FloatArray, Image, WallTexture

FloatImage = npt.NDArray[np.float32]

WIDTH, HEIGHT = 320, 240  # pixels
HFOV = math.radians(50.0)
FOCAL = 0.5 * WIDTH / math.tan(0.5 * HFOV)  # px, square pixels
VISIBILITY = 4.0  # m, as vehicle.sensors.instruments.Camera
ATTENUATION = (0.30, 0.25, 0.45)  # 1/m, B G R
WATER = (95.0, 110.0, 60.0)  # B G R of the backscatter seen at long range


@dataclass(frozen=True)
class Intrinsics:
    """Pinhole camera K (§6.1, Eq. 33): focal lengths and principal point in pixels."""

    width: int = WIDTH
    height: int = HEIGHT
    fx: float = FOCAL
    fy: float = FOCAL
    cx: float = 0.5 * (WIDTH - 1)
    cy: float = 0.5 * (HEIGHT - 1)

    def rays(self) -> tuple[FloatArray, FloatArray]:
        """Per pixel, the ray's body-frame slopes a = (u - cx)/fx (starboard), b = (v - cy)/fy
        (down), for a ray (1, a, b) along the optical axis (forward)."""
        u, v = np.meshgrid(np.arange(self.width, dtype=np.float64),
                           np.arange(self.height, dtype=np.float64))
        return (u - self.cx) / self.fx, (v - self.cy) / self.fy


# --- the camera -------------------------------------------------------------------------------
def wall_hits(pose: tuple[float, float, float, float], a: FloatArray, b: FloatArray,
              wall_curvature: float = 0.0) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Where the rays of slopes (a, b) from a camera at pose (x, y, z, yaw) meet the wall
    x = c y**2: wall y, wall z and the range (m); NaN where a ray misses it."""
    x0, y0, z0, psi = pose
    c, s = math.cos(psi), math.sin(psi)
    dx, dy, dz = c - s * a, s + c * a, b
    if wall_curvature == 0.0:
        with np.errstate(divide="ignore", invalid="ignore"):
            t = np.where(dx > 1e-9, -x0 / dx, np.nan)
    else:  # c (y0 + t dy)^2 = x0 + t dx: the smallest positive root
        qa = wall_curvature * dy * dy
        qb = 2.0 * wall_curvature * y0 * dy - dx
        qc = wall_curvature * y0 * y0 - x0
        disc = qb * qb - 4.0 * qa * qc
        with np.errstate(divide="ignore", invalid="ignore"):
            root = np.sqrt(np.where(disc >= 0, disc, np.nan))
            t1 = np.where(np.abs(qa) > 1e-12, (-qb - root) / (2 * qa), -qc / qb)
            t2 = np.where(np.abs(qa) > 1e-12, (-qb + root) / (2 * qa), np.nan)
            t = np.where(t1 > 0, t1, np.where(t2 > 0, t2, np.nan))
    t = np.where(t > 0, t, np.nan)
    rng = dx * dx + dy * dy + dz * dz  # the ray's length a metre forward, then the range
    np.sqrt(rng, out=rng)
    rng *= t
    depth = t * dz
    depth += z0
    return y0 + t * dy, depth, rng


@dataclass
class Lighting:
    """The vehicle's lamp and the water: see the module's docstring."""

    spot: tuple[float, float] = (0.35, -0.25)  # lamp's aim on the image, in half-widths
    spot_width: float = 0.75  # Gaussian sigma of the spot, in image widths
    gain: float = 1.15  # the brightness of a wall at the reference range, spot's centre
    reference_range: float = 1.5  # m
    attenuation: tuple[float, float, float] = ATTENUATION
    water: tuple[float, float, float] = WATER
    blur: float = 0.7  # px, Gaussian sigma (optics and motion)
    noise: float = 2.5  # DN, sensor noise sigma


class WallCamera:
    """Renders what the camera sees of the wall from a pose (x, y, z, yaw)."""

    def __init__(self, texture: WallTexture, wall_curvature: float = 0.0,
                 intrinsics: Intrinsics | None = None, lighting: Lighting | None = None,
                 visibility: float = VISIBILITY) -> None:
        self.texture, self.wall_curvature = texture, wall_curvature
        self.k = intrinsics or Intrinsics()
        self.light = lighting or Lighting()
        self.visibility = visibility
        self.a, self.b = self.k.rays()
        self.a_row, self.b_column = self.a[:1, :], self.b[:, :1]  # a by column, b by row
        w = self.k.width
        sx = self.k.cx + self.light.spot[0] * 0.5 * w
        sy = self.k.cy + self.light.spot[1] * 0.5 * w
        u, v = np.meshgrid(np.arange(w), np.arange(self.k.height))
        spot = np.exp(-((u - sx) ** 2 + (v - sy) ** 2) / (2 * (self.light.spot_width * w) ** 2))
        cos4 = 1.0 / (1.0 + self.a**2 + self.b**2) ** 2
        self.pattern = (spot * cos4)[:, :, None]  # the lamp's pattern on the image (0..1)
        self._k = np.asarray(self.light.attenuation, np.float32)[None, None, :]
        # -k on the whole image, so that the light lost is worked out on arrays of one
        # layout: numpy multiplies an (h, w, 1) by a (1, 1, 3) array a value at a time, one
        # of the same shape several at once (the same numbers; lit 2.8 -> 2.1 ms an image)
        self._minus_k = np.ascontiguousarray(
            np.broadcast_to(-self._k, (self.k.height, self.k.width, 3)))
        r0 = self.light.reference_range
        self._lamp_at_reference = (self.light.gain * self.pattern * r0 * r0 * np.exp(
            2.0 * self._k * r0)).astype(np.float32)
        self._back = (np.asarray(self.light.water, np.float32)[None, None, :]
                      * (0.35 + 0.65 * self.pattern)).astype(np.float32)
        self._minus_back = -self._back

    def render(self, pose: tuple[float, float, float, float],
               rng: np.random.Generator) -> Image:
        """The B, G, R image (HEIGHT x WIDTH, uint8) seen from the pose: :meth:`lit`, then
        :meth:`expose` with the :meth:`noise` drawn from ``rng``."""
        return self.expose(self.lit(pose), self.noise(rng))

    def noise(self, rng: np.random.Generator, out: FloatImage | None = None) -> FloatImage:
        """The sensor noise of one image, drawn from ``rng``: the only part of an image that
        depends on the images before it (the generator's sequence), so that images can be
        lit in any order, or at once, and come out the same. ``out``: an array of the
        image's shape (float32) to draw it into, the same numbers as a new one."""
        if out is None:
            out = np.empty((self.k.height, self.k.width, 3), dtype=np.float32)
        rng.standard_normal(dtype=np.float32, out=out)
        out *= self.light.noise
        return out

    def lit(self, pose: tuple[float, float, float, float]) -> FloatImage:
        """The light that reaches the sensor from the pose, before the sensor's noise: the
        wall's texture under the lamp, through the water, blurred (float B, G, R)."""
        import cv2

        # A ray's horizontal slope is its column's, its vertical slope its row's: where a
        # ray meets the wall along it is worked out once a column (the same numbers as pixel
        # by pixel, a fifth of the time), the depth and the range on the whole grid.
        y, z, rng_m = wall_hits(pose, self.a_row, self.b_column, self.wall_curvature)
        seen = np.isfinite(rng_m) & (rng_m <= self.visibility)
        everywhere = bool(seen.all())  # the wall fills the image: nothing to mask
        if everywhere:
            wall = self.texture.sample(y, z)
            r = rng_m.astype(np.float32)
        else:
            wall = self.texture.sample(np.where(seen, y, 0.0), np.where(seen, z, 0.0))
            r = np.where(seen, rng_m, self.visibility).astype(np.float32)
        # Each step below writes into an array it has made, not a new one: the same numbers,
        # a fraction of the memory walked through.
        r3: Any = cv2.merge((r, r, r))  # the range, for each colour (np.repeat: 7 times as
        # long)
        lost = np.multiply(self._minus_k, r3)
        np.exp(lost, out=lost)  # the share of light left after r metres of water
        transmit = lost * lost  # lamp to wall and back, relative to the reference range
        r3 *= r3
        np.divide(self._lamp_at_reference, r3, out=r3)
        transmit *= r3  # and the lamp's light spreads
        if not everywhere:
            transmit[~seen] = 0.0
        img: Any = wall.astype(np.float32)
        img *= transmit
        lost -= 1.0
        lost *= self._minus_back  # backscatter: the water's colour where the light was lost
        img += lost
        return np.asarray(cv2.GaussianBlur(img, (0, 0), self.light.blur), dtype=np.float32)

    @staticmethod
    def expose(light: FloatImage, noise: FloatImage) -> Image:
        """The sensor's 8-bit image of ``light`` with its ``noise`` (``light`` is used up)."""
        light += noise
        light += 0.5
        np.clip(light, 0, 255, out=light)
        return np.asarray(light, dtype=np.uint8)

    def centre(self, pose: tuple[float, float, float, float]) -> tuple[float, float] | None:
        """Wall (y, z) at the image's centre, None if the axis misses the wall."""
        y, z, r = wall_hits(pose, np.array([0.0]), np.array([0.0]), self.wall_curvature)
        return None if not np.isfinite(r[0]) else (float(y[0]), float(z[0]))
