"""The wall camera (vehicle/sensors/camera.py) worked out the fast way — arrays written in
place, the range for each colour by cv2.merge, the texture's four-channel copy — gives the
numbers of the plain formulas, to the last bit, and its noise drawn into a kept array is the
noise drawn into a new one."""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import pytest

cv2 = pytest.importorskip("cv2")

from vehicle.sensors.camera import WallCamera
from vehicle.sensors.wall_texture import TextureSpec, WallTexture

SPEC = TextureSpec(seed=7, y_range=(-1.0, 4.0), z_range=(0.0, 3.5))
POSES = [(-1.5, 1.0, 1.5, 0.0), (-1.43, 2.2, 0.9, 0.12), (-0.8, 0.3, 2.6, -0.3),
         (-3.2, 1.5, 1.0, 0.4),  # part of the view beyond the visibility
         (-1.5, 1.0, 1.5, 1.45)]  # looking along the wall: rays that miss it


def plain_hits(pose: tuple[float, float, float, float], a: Any, b: Any,
               curvature: float) -> tuple[Any, Any, Any]:
    """Where the rays meet the wall x = c y**2, pixel by pixel, each step a new array."""
    x0, y0, z0, psi = pose
    c, s = math.cos(psi), math.sin(psi)
    dx, dy, dz = c - s * a, s + c * a, b
    with np.errstate(divide="ignore", invalid="ignore"):
        if curvature == 0.0:
            t = np.where(dx > 1e-9, -x0 / dx, np.nan)
        else:
            qa = curvature * dy * dy
            qb = 2.0 * curvature * y0 * dy - dx
            qc = curvature * y0 * y0 - x0
            disc = qb * qb - 4.0 * qa * qc
            root = np.sqrt(np.where(disc >= 0, disc, np.nan))
            t1 = np.where(np.abs(qa) > 1e-12, (-qb - root) / (2 * qa), -qc / qb)
            t2 = np.where(np.abs(qa) > 1e-12, (-qb + root) / (2 * qa), np.nan)
            t = np.where(t1 > 0, t1, np.where(t2 > 0, t2, np.nan))
    t = np.where(t > 0, t, np.nan)
    norm = np.sqrt(dx * dx + dy * dy + dz * dz)
    return y0 + t * dy, z0 + t * dz, t * norm


def plain_lit(cam: WallCamera, pose: tuple[float, float, float, float]) -> Any:
    """The light that reaches the sensor, by the plain formulas."""
    y, z, r = plain_hits(pose, cam.a_row, cam.b_column, cam.wall_curvature)
    seen = np.isfinite(r) & (r <= cam.visibility)
    col, row = np.broadcast_arrays(*cam.texture.spec.to_pixel(np.where(seen, y, 0.0),
                                                               np.where(seen, z, 0.0)))
    wall = cv2.remap(cam.texture.image, col.astype(np.float32), row.astype(np.float32),
                     cv2.INTER_LINEAR, borderMode=cv2.BORDER_REFLECT_101)
    r3 = np.repeat(np.where(seen, r, cam.visibility).astype(np.float32)[:, :, None], 3, axis=2)
    light, r0 = cam.light, cam.light.reference_range
    k = np.asarray(light.attenuation, np.float32)[None, None, :]
    lamp = (light.gain * cam.pattern * r0 * r0 * np.exp(2.0 * k * r0)).astype(np.float32)
    back = (np.asarray(light.water, np.float32)[None, None, :]
            * (0.35 + 0.65 * cam.pattern)).astype(np.float32)
    lost = np.exp(-k * r3)
    transmit = lost * lost * (lamp / (r3 * r3))
    transmit[~seen] = 0.0
    img = wall.astype(np.float32) * transmit + (lost - 1.0) * -back
    return cv2.GaussianBlur(img, (0, 0), cam.light.blur)


@pytest.mark.parametrize("curvature", [0.0, 0.02])
def test_the_light_is_that_of_the_plain_formulas(curvature: float) -> None:
    cam = WallCamera(WallTexture(SPEC), curvature)
    partial = 0
    for pose in POSES:
        lit, plain = cam.lit(pose), plain_lit(cam, pose)
        assert lit.dtype == np.float32 and lit.shape == plain.shape
        assert np.array_equal(lit.view(np.uint32), plain.view(np.uint32)), pose
        y, z, r = plain_hits(pose, cam.a_row, cam.b_column, curvature)
        partial += not bool((np.isfinite(r) & (r <= cam.visibility)).all())
    assert 0 < partial < len(POSES)  # views filled by the wall and views that are not


def test_noise_drawn_into_a_kept_array_is_the_noise_drawn_into_a_new_one() -> None:
    cam = WallCamera(WallTexture(SPEC))
    new, kept = np.random.default_rng([7, 6]), np.random.default_rng([7, 6])
    into = np.full((cam.k.height, cam.k.width, 3), np.nan, np.float32)
    for _ in range(3):
        a = cam.noise(new)
        b = cam.noise(kept, into)
        assert b is into and np.array_equal(a, b)
    assert np.array_equal(new.standard_normal(4), kept.standard_normal(4))  # the same place
