"""Blending (paper 002 §6.7): every image projected onto the wall plane and merged.

The mosaic is a grid in the wall frame: column c at y = y0 + (c + 0.5) s, row r at depth
z = z0 + (r + 0.5) s, s = mm_per_px / 1000. Each illumination-corrected image is warped onto it
by its aligned pose's homography, weighted by a function that falls from its centre to its
border (central pixels are the best exposed: the paper's rule), sharpened so that the central
image dominates and seams stay narrow. The paper then removes the remaining seams in the
gradient domain (a Poisson solve); here the flat-field correction leaves seams faint and that
step is left out. The coverage map counts the images that see each cell.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np
import numpy.typing as npt

from mosaic.projection import FloatArray, Intrinsics, homography, wall_points

Image = npt.NDArray[np.uint8]
FloatImage = npt.NDArray[np.float32]

MM_PER_PX = 4.0  # the mosaic's default scale: about the camera's at 1.5 m (4.4 mm/px)
NO_DATA = (40, 40, 40)  # B G R of wall no image saw


class Warped(NamedTuple):
    """An image warped onto the canvas: its box (rows y0:y1, columns x0:x1), the weighted
    B, G, R and the weight there, and where it saw the wall (the weight above 1e-7)."""

    y0: int
    y1: int
    x0: int
    x1: int
    out: FloatImage
    seen: npt.NDArray[np.bool_]


@dataclass
class Canvas:
    y0: float  # m, left edge
    z0: float  # m, top edge
    mm_per_px: float
    rows: int
    cols: int

    @property
    def s(self) -> float:
        return self.mm_per_px / 1000.0

    def wall_to_px(self) -> FloatArray:
        """Homography wall metres -> canvas pixels (pixel centres at integers)."""
        return np.array([[1 / self.s, 0, -self.y0 / self.s - 0.5],
                         [0, 1 / self.s, -self.z0 / self.s - 0.5], [0, 0, 1.0]])

    def to_px(self, y: float, z: float) -> tuple[float, float]:
        return (y - self.y0) / self.s - 0.5, (z - self.z0) / self.s - 0.5


def canvas_for(boxes: Iterable[tuple[float, float, float, float]], mm_per_px: float,
               margin: float = 0.05, max_pixels: int = 60_000_000) -> Canvas:
    """The canvas holding the boxes (y_min, y_max, z_min, z_max) in m."""
    b = np.array(list(boxes), dtype=float).reshape(-1, 4)
    y0, y1 = b[:, 0].min() - margin, b[:, 1].max() + margin
    z0, z1 = b[:, 2].min() - margin, b[:, 3].max() + margin
    s = mm_per_px / 1000.0
    cols, rows = int(np.ceil((y1 - y0) / s)), int(np.ceil((z1 - z0) / s))
    if rows * cols > max_pixels:
        raise ValueError(f"a {cols} x {rows} mosaic at {mm_per_px:g} mm/pixel is too large; "
                         "choose a coarser scale")
    return Canvas(y0, z0, mm_per_px, rows, cols)


def centre_weight(k: Intrinsics, power: float = 4.0) -> FloatImage:
    """Weight of each pixel of an image: 1 at the centre, 0 at the border."""
    u = np.abs(np.arange(k.width) - k.cx) / (k.cx + 1.0)
    v = np.abs(np.arange(k.height) - k.cy) / (k.cy + 1.0)
    w = np.outer(1.0 - v, 1.0 - u) ** power
    return np.asarray(np.maximum(w, 1e-6), dtype=np.float32)


def footprint(pose: FloatArray, k: Intrinsics) -> tuple[float, float, float, float]:
    """Bounding box (y_min, y_max, z_min, z_max) of an image's pose on the wall."""
    c = k.corners()
    a, b = k.slopes(c)
    w = wall_points(np.asarray(pose, dtype=float)[None, :], a, b)
    return float(w[:, 0].min()), float(w[:, 0].max()), float(w[:, 1].min()), float(w[:, 1].max())


class Blender:
    """Accumulates weighted images on the canvas."""

    def __init__(self, canvas: Canvas, k: Intrinsics) -> None:
        self.canvas, self.k = canvas, k
        self.acc = np.zeros((canvas.rows, canvas.cols, 4), np.float32)  # B G R (weighted), w
        self.count = np.zeros((canvas.rows, canvas.cols), np.uint16)
        self.w = centre_weight(k)
        self.w4 = np.dstack([self.w] * 4)

    def add(self, img: Image | FloatImage, pose: FloatArray) -> None:
        """Weight the image, warp it onto the canvas at ``pose`` and add it."""
        warped = self.warp(img, pose)
        if warped is not None:
            self.accumulate(warped)

    def warp(self, img: Image | FloatImage, pose: FloatArray) -> Warped | None:
        """The weighted image (B, G, R, weight) warped onto its box of the canvas; None if
        it misses the canvas. Independent of the other images: threads may warp several at
        once (OpenCV releases the GIL), :meth:`accumulate` then adds them in order."""
        import cv2

        c = self.canvas
        h = c.wall_to_px() @ homography(pose, self.k)
        corners = self.k.corners()
        q = corners @ h[:, :2].T + h[:, 2]
        q = q[:, :2] / q[:, 2:3]
        x0, y0 = max(int(np.floor(q[:, 0].min())), 0), max(int(np.floor(q[:, 1].min())), 0)
        x1 = min(int(np.ceil(q[:, 0].max())) + 1, c.cols)
        y1 = min(int(np.ceil(q[:, 1].max())) + 1, c.rows)
        if x1 <= x0 or y1 <= y0:
            return None
        shift = np.array([[1, 0, -x0], [0, 1, -y0], [0, 0, 1.0]]) @ h
        src = cv2.multiply(cv2.cvtColor(img, cv2.COLOR_BGR2BGRA), self.w4, dtype=cv2.CV_32F)
        src[:, :, 3] = self.w  # B, G, R weighted, then the weight (0.1 ms, where splitting
        # the weighted image and merging it with the weight took 0.4)
        out = cv2.warpPerspective(src, shift, (x1 - x0, y1 - y0), flags=cv2.INTER_LINEAR,
                                  borderMode=cv2.BORDER_CONSTANT, borderValue=0)
        warped: FloatImage = np.asarray(out, dtype=np.float32)
        return Warped(y0, y1, x0, x1, warped, warped[:, :, 3] > 1e-7)  # in the warping thread

    def accumulate(self, warped: Warped) -> None:
        """Add a warped image to the canvas (in the images' order: the sums, to the last
        bit, do not depend on how many threads warped them)."""
        y0, y1, x0, x1, out, seen = warped
        self.acc[y0:y1, x0:x1] += out
        self.count[y0:y1, x0:x1] += seen

    @property
    def weight(self) -> FloatImage:
        return np.asarray(self.acc[:, :, 3])

    def mosaic(self) -> Image:
        w = self.acc[:, :, 3:4]
        out = self.acc[:, :, :3] / np.maximum(w, 1e-7)
        np.clip(out, 0, 255, out=out)
        img = out.astype(np.uint8)
        img[self.count == 0] = NO_DATA
        return img


def coverage_image(count: npt.NDArray[np.uint16], canvas: Canvas,
                   plan: Callable[[Image], None] | None = None) -> Image:
    """The coverage map: images per cell in colour (black: none), with a legend."""
    import cv2

    top = max(int(count.max()), 1)
    scaled = np.clip(count.astype(np.float32) * (255.0 / top), 0, 255).astype(np.uint8)
    img = cv2.applyColorMap(scaled, cv2.COLORMAP_VIRIDIS)
    img[count == 0] = (0, 0, 0)
    if plan is not None:
        plan(img)
    bar = np.zeros((28, img.shape[1], 3), np.uint8)
    n = min(256, img.shape[1] // 3)
    ramp = cv2.applyColorMap(np.linspace(0, 255, n).astype(np.uint8)[None, :], cv2.COLORMAP_VIRIDIS)
    bar[6:20, 8:8 + n] = cv2.resize(ramp, (n, 14), interpolation=cv2.INTER_NEAREST)
    cv2.putText(bar, f"images per cell: 0 (black) .. {top}", (16 + n, 19),
                cv2.FONT_HERSHEY_SIMPLEX, 0.45, (255, 255, 255), 1, cv2.LINE_AA)
    return np.vstack([img, bar])
