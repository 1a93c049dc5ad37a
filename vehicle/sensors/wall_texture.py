"""The dam wall the camera sees (paper 002 §6.1): a texture generated from a seed — concrete with
formwork joints, stains, algae and cracks — kept as a ground-truth image at
:data:`TEXTURE_MM_PER_PX` mm per pixel over a wall patch in the wall frame (y along the wall,
z depth down, metres). Chosen here: 4 mm/pixel (the camera of vehicle/sensors/camera.py sees
4.4 mm per pixel at 1.5 m), over y -3..19 m and z -0.5..6.5 m (beyond it the texture is
mirrored). The mosaic measures itself against it (mosaic/accuracy.py).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
import numpy.typing as npt

FloatArray = npt.NDArray[np.float64]
Image = npt.NDArray[np.uint8]

TEXTURE_MM_PER_PX = 4.0
TEXTURE_Y = (-3.0, 19.0)  # m along the wall
TEXTURE_Z = (-0.5, 6.5)  # m depth


# --- the wall ---------------------------------------------------------------------------------
@dataclass(frozen=True)
class TextureSpec:
    seed: int = 1
    mm_per_px: float = TEXTURE_MM_PER_PX
    y_range: tuple[float, float] = TEXTURE_Y
    z_range: tuple[float, float] = TEXTURE_Z

    @property
    def shape(self) -> tuple[int, int]:
        """(rows, columns): rows along z (down), columns along y."""
        s = self.mm_per_px / 1000.0
        return (int(round((self.z_range[1] - self.z_range[0]) / s)),
                int(round((self.y_range[1] - self.y_range[0]) / s)))

    def to_pixel(self, y: npt.ArrayLike, z: npt.ArrayLike) -> tuple[FloatArray, FloatArray]:
        """Wall (y, z) in m -> texture (column, row), pixel centres at integers."""
        s = self.mm_per_px / 1000.0
        col = np.asarray(y, dtype=float) - self.y_range[0]  # a new array, then in place
        col /= s
        col -= 0.5
        row = np.asarray(z, dtype=float) - self.z_range[0]
        row /= s
        row -= 0.5
        return col, row


BAND = 32  # rows of the texture worked on at once where each pixel is on its own (in cache)


def _noise(rng: np.random.Generator, shape: tuple[int, int], cell: float) -> FloatArray:
    """Smooth value noise of about `cell` pixels' feature size, zero mean, unit-ish spread."""
    return np.asarray(_noise32(rng, shape, cell), dtype=np.float64)


def _noise32(rng: np.random.Generator, shape: tuple[int, int], cell: float) -> Any:
    """:func:`_noise` as the float32 numbers it is made of (:func:`_noise` is them as float64)."""
    import cv2

    h, w = shape
    gh, gw = max(2, int(h / cell) + 2), max(2, int(w / cell) + 2)
    grid = rng.standard_normal((gh, gw)).astype(np.float32)
    big = cv2.resize(grid, (int(gw * cell), int(gh * cell)), interpolation=cv2.INTER_CUBIC)
    return big[:h, :w]


def concrete(grey: Any, grain: Any, aggregate: Any, voids: Any) -> None:
    """The concrete's grey level, in ``grey`` (float32): its fine grain (``grey``, blurred
    noise), aggregate at two sizes (``grain``, ``aggregate``, smooth noise), air voids where
    ``voids`` exceeds 2.1. Worked out a band of rows at a time (in cache) with the numbers
    of whole-image numpy: each noise added as float64, as numpy adds a float64 array."""
    for r0 in range(0, grey.shape[0], BAND):
        band = grey[r0:r0 + BAND]
        band *= 14.0
        band += 9.0 * grain[r0:r0 + BAND].astype(np.float64)
        band += 7.0 * aggregate[r0:r0 + BAND].astype(np.float64)
        band += 140.0
        band[voids[r0:r0 + BAND].astype(np.float64) > 2.1] -= 45.0


def colour(low: Any, grey: Any) -> Image:
    """The 8-bit colour image of the slowly varying colour ``low`` (h, w, 3) over the grey
    level ``grey`` (h, w), both float32: their sum clipped to 0..255, a band at a time (the
    grey level for each colour by cv2.merge: numpy adds an (h, w, 1) array to an (h, w, 3)
    one a value at a time)."""
    import cv2

    out = np.empty(low.shape, np.uint8)
    for r0 in range(0, low.shape[0], BAND):
        band, level = low[r0:r0 + BAND], grey[r0:r0 + BAND]
        band += cv2.merge((level, level, level))
        np.clip(band, 0.0, 255.0, out=band)
        out[r0:r0 + BAND] = band
    return out


def make_texture(spec: TextureSpec) -> Image:
    """The wall's ground-truth colour image (B, G, R), deterministic for ``spec.seed``.

    Fine detail (grain, aggregate, air voids, joints, cracks) is made at full resolution;
    the slowly varying colour (patchiness, rust streaks, algae) at an eighth of it, then
    enlarged once.
    """
    import cv2

    rng = np.random.default_rng([spec.seed, 2002])
    h, w = spec.shape
    px_per_m = 1000.0 / spec.mm_per_px
    # concrete: grain at a few mm, aggregate at a few cm, air voids
    grey: Any = rng.standard_normal((h, w), dtype=np.float32)
    grey = cv2.GaussianBlur(grey, (0, 0), 0.8)
    concrete(grey, _noise32(rng, (h, w), 0.02 * px_per_m),
              _noise32(rng, (h, w), 0.08 * px_per_m), _noise32(rng, (h, w), 0.012 * px_per_m))
    # formwork joints: lift joints every 1.5 m in depth, panel joints every 3 m along the wall
    for z in np.arange(math.ceil(spec.z_range[0] / 1.5) * 1.5, spec.z_range[1], 1.5):
        r = int((z - spec.z_range[0]) * px_per_m)
        grey[max(r - 2, 0):r + 2, :] -= 50.0
    for y in np.arange(math.ceil(spec.y_range[0] / 3.0) * 3.0, spec.y_range[1], 3.0):
        c = int((y - spec.y_range[0]) * px_per_m)
        grey[:, max(c - 1, 0):c + 2] -= 50.0
    # cracks: thin dark random walks
    cracks = np.zeros((h, w), np.uint8)
    area = (spec.y_range[1] - spec.y_range[0]) * (spec.z_range[1] - spec.z_range[0])
    for _ in range(int(area / 5.0)):
        x, y0 = rng.uniform(0, w), rng.uniform(0, h)
        heading = rng.uniform(0, 2 * math.pi)
        pts = [(x, y0)]
        for _ in range(int(rng.integers(30, 120))):
            heading += rng.normal(0.0, 0.35)
            step = rng.uniform(3.0, 8.0)
            x, y0 = x + step * math.cos(heading), y0 + step * math.sin(heading)
            pts.append((x, y0))
        cv2.polylines(cracks, [np.array(pts, np.int32)], False, 255,
                      int(rng.integers(1, 3)), cv2.LINE_AA)
    grey = cv2.scaleAdd(cracks.astype(np.float32), -70.0 / 255.0, grey)
    grey = cv2.GaussianBlur(grey, (0, 0), 0.5)
    # slowly varying colour, at 1/8 resolution: patchiness, rust streaks down from the lift
    # joints, algae (denser with depth)
    lh, lw = h // 8 + 1, w // 8 + 1
    lpx = px_per_m / 8.0
    patch = 12.0 * _noise(rng, (lh, lw), 0.8 * lpx)
    streak = cv2.resize(rng.standard_normal((max(2, lh // 8), max(2, lw // 3))).astype(np.float32),
                        (lw, lh), interpolation=cv2.INTER_CUBIC)
    stain = np.clip(streak - 1.0, 0.0, None) * np.clip(_noise(rng, (lh, lw), 1.0 * lpx), 0, None)
    depth = np.linspace(spec.z_range[0], spec.z_range[1], lh, dtype=np.float32)[:, None]
    algae = _noise(rng, (lh, lw), 0.35 * lpx) + 0.6 * _noise(rng, (lh, lw), 0.06 * lpx)
    algae = np.clip(algae + 0.25 * depth - 1.2, 0.0, 1.2)
    low: Any = np.stack([patch - 22.0 * stain - 40.0 * algae, patch - 14.0 * stain - 5.0 * algae,
                    patch - 2.0 * stain - 45.0 * algae], axis=-1).astype(np.float32)
    return colour(cv2.resize(low, (w, h), interpolation=cv2.INTER_LINEAR), grey)


class WallTexture:
    """The ground-truth wall image, made on first use (a quarter of a second)."""

    def __init__(self, spec: TextureSpec | None = None, image: Image | None = None) -> None:
        """``image``: the texture of ``spec`` already made (by another process), else it is
        made on first use."""
        self.spec = spec or TextureSpec()
        self._image: Image | None = image
        self._padded: Image | None = None

    @property
    def image(self) -> Image:
        if self._image is None:
            self._image = make_texture(self.spec)
        return self._image

    @property
    def padded(self) -> Image:
        """The texture with a fourth channel (opaque) after B, G, R, made on first use: what
        :meth:`sample` reads, for OpenCV's remap reads four channels faster than three
        (0.17 ms a camera image against 0.42; the same B, G, R)."""
        import cv2

        if self._padded is None:
            self._padded = np.asarray(cv2.cvtColor(self.image, cv2.COLOR_BGR2BGRA),
                                      dtype=np.uint8)
        return self._padded

    def sample(self, y: FloatArray, z: FloatArray) -> Image:
        """The texture at wall points (m), bilinear, mirrored beyond its edges."""
        import cv2

        col, row = self.spec.to_pixel(y, z)  # y or z may be a row: broadcast
        # one map of (column, row) pairs, which remap reads a little faster than two maps
        # (0.17 ms a camera image against 0.19; the same pixels)
        where: Any = np.empty(np.broadcast_shapes(col.shape, row.shape) + (2,), np.float32)
        where[..., 0] = col
        where[..., 1] = row
        no_second_map: Any = None  # the pairs are the one map (cv2's stubs want two)
        out = cv2.remap(self.padded, where, no_second_map, cv2.INTER_LINEAR,
                        borderMode=cv2.BORDER_REFLECT_101)
        return np.asarray(cv2.cvtColor(out, cv2.COLOR_BGRA2BGR), dtype=np.uint8)

    def crop(self, y0: float, z0: float, mm_per_px: float, shape: tuple[int, int]) -> Image:
        """The texture resampled on a grid: pixel (r, c) centred at (y0 + (c + 0.5) s,
        z0 + (r + 0.5) s), s = mm_per_px / 1000 (the mosaic's grid)."""
        import cv2

        s = mm_per_px / 1000.0
        rows, cols = shape
        ys = y0 + (np.arange(cols) + 0.5) * s
        zs = z0 + (np.arange(rows) + 0.5) * s
        col, row = self.spec.to_pixel(ys, zs)
        ratio = mm_per_px / self.spec.mm_per_px
        src: Any = self.image
        if ratio > 1.5:  # shrink first, so that the resampling does not alias
            src = cv2.resize(src, None, fx=1.0 / ratio, fy=1.0 / ratio,
                             interpolation=cv2.INTER_AREA)
            col, row = (col + 0.5) / ratio - 0.5, (row + 0.5) / ratio - 0.5
        mc = np.broadcast_to(col[None, :], shape).astype(np.float32)
        mr = np.broadcast_to(row[:, None], shape).astype(np.float32)
        out = cv2.remap(src, mc, mr, cv2.INTER_LINEAR, borderMode=cv2.BORDER_REFLECT_101)
        return np.asarray(out, dtype=np.uint8)
