"""The pinhole camera of paper 002 §6.1 (Eq. 33) looking at the wall plane.

A camera pose is (y, z, d, yaw): the camera at depth z, abreast of y along the wall, at
distance d from the wall plane x = x_wall, turned by yaw from the wall's normal (the Ictineu is
stable in roll and pitch, so 4 degrees of freedom describe it; the paper's 6 reduce to these).
A pixel (u, v) has the body-frame ray (1, a, b), a = (u - cx)/fx, b = (v - cy)/fy; it meets
the wall at

    Y = y + d tan(yaw + atan a),    Z = z + d b / (cos yaw - a sin yaw).

The map from image to wall is a homography (:func:`homography`); :func:`wall_points` and its
Jacobian are what the global alignment minimises over.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
import numpy.typing as npt

FloatArray = npt.NDArray[np.float64]


@dataclass(frozen=True)
class Intrinsics:
    width: int
    height: int
    fx: float
    fy: float
    cx: float
    cy: float

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> Intrinsics:
        return cls(int(d["width"]), int(d["height"]), float(d["fx"]), float(d["fy"]),
                   float(d["cx"]), float(d["cy"]))

    def slopes(self, uv: FloatArray) -> tuple[FloatArray, FloatArray]:
        return (uv[..., 0] - self.cx) / self.fx, (uv[..., 1] - self.cy) / self.fy

    def corners(self) -> FloatArray:
        w, h = self.width - 1.0, self.height - 1.0
        return np.array([[0.0, 0.0], [w, 0.0], [w, h], [0.0, h]])


def wall_points(pose: FloatArray, a: FloatArray, b: FloatArray) -> FloatArray:
    """Wall (Y, Z) in m of rays (a, b) from poses (..., 4) = (y, z, d, yaw), broadcast."""
    y, z, d, psi = pose[..., 0], pose[..., 1], pose[..., 2], pose[..., 3]
    c, s = np.cos(psi), np.sin(psi)
    den = c - s * a
    return np.stack([y + d * (s + c * a) / den, z + d * b / den], axis=-1)


def wall_jacobian(pose: FloatArray, a: FloatArray, b: FloatArray) -> FloatArray:
    """d(Y, Z)/d(y, z, d, yaw): shape (..., 2, 4)."""
    d, psi = pose[..., 2], pose[..., 3]
    c, s = np.cos(psi), np.sin(psi)
    den = c - s * a
    num = s + c * a
    one, zero = np.ones_like(den), np.zeros_like(den)
    jy = np.stack([one, zero, num / den, d * (1.0 + a * a) / den**2], axis=-1)
    jz = np.stack([zero, one, b / den, d * b * num / den**2], axis=-1)
    return np.stack([jy, jz], axis=-2)


def homography(pose: FloatArray, k: Intrinsics) -> FloatArray:
    """3 x 3 homography from image pixels to wall metres (Y, Z) for one pose."""
    import cv2

    src = k.corners()
    a, b = k.slopes(src)
    dst = wall_points(np.asarray(pose, dtype=float)[None, :], a, b)
    return np.asarray(cv2.getPerspectiveTransform(src.astype(np.float32),
                                                  dst.astype(np.float32)), dtype=np.float64)


def apply(h: FloatArray, pts: FloatArray) -> FloatArray:
    """Apply a homography to points (n, 2)."""
    p = np.asarray(pts, dtype=float)
    q = p @ h[:, :2].T + h[:, 2]
    return q[:, :2] / q[:, 2:3]


def pose_from_world(x: float, y: float, z: float, psi: float,
                    wall_x: float = 0.0) -> tuple[float, float, float, float]:
    """A vehicle's world pose (x, y, z, yaw) as a camera pose (y, z, d, yaw)."""
    return (y, z, wall_x - x, math.remainder(psi, 2 * math.pi))
