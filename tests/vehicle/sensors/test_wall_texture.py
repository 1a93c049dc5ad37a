"""The wall's texture (vehicle/sensors/wall_texture.py) worked out the fast way gives the
numbers of the plain whole-image formulas, to the last bit: made in bands of rows, sampled
from a copy with four channels."""

from __future__ import annotations

import numpy as np
import pytest

cv2 = pytest.importorskip("cv2")

from vehicle.sensors import wall_texture
from vehicle.sensors.wall_texture import TextureSpec, WallTexture

SPEC = TextureSpec(seed=7, y_range=(-1.0, 1.0), z_range=(0.0, 0.6))
ROWS = 2 * wall_texture.BAND + 9  # three bands, the last one short


def test_the_concrete_made_in_bands_is_the_whole_image_formula() -> None:
    rng = np.random.default_rng(3)
    grey = rng.standard_normal((ROWS, 50), dtype=np.float32)
    grain, aggregate, voids = (rng.normal(0, s, (ROWS, 50)).astype(np.float32)
                               for s in (1.0, 1.0, 1.5))
    whole = grey.copy()
    whole *= 14.0
    whole += 9.0 * grain.astype(np.float64)
    whole += 7.0 * aggregate.astype(np.float64)
    whole += 140.0
    whole[voids.astype(np.float64) > 2.1] -= 45.0
    assert (voids > 2.1).any() and (voids <= 2.1).any()
    wall_texture.concrete(grey, grain, aggregate, voids)
    assert grey.dtype == np.float32 and np.array_equal(grey.view(np.uint32),
                                                       whole.view(np.uint32))


def test_the_colour_made_in_bands_is_the_whole_image_formula() -> None:
    rng = np.random.default_rng(4)
    low = rng.normal(0, 60, (ROWS, 50, 3)).astype(np.float32)
    grey = rng.normal(140, 90, (ROWS, 50)).astype(np.float32)
    whole = low + grey[:, :, None]
    np.minimum(whole, 255.0, out=whole)
    np.maximum(whole, 0.0, out=whole)
    expected = whole.astype(np.uint8)
    assert (expected == 0).any() and (expected == 255).any()  # both clips are tested
    assert np.array_equal(wall_texture.colour(low, grey), expected)


def test_sampling_the_four_channel_copy_gives_the_texture_s_pixels() -> None:
    """Bilinear, mirrored beyond the edges: what OpenCV's remap gives from the B, G, R image
    with a map of columns and one of rows, at points inside and beyond the texture."""
    tex = WallTexture(SPEC)
    assert tex.padded.shape == tex.image.shape[:2] + (4,)
    assert np.array_equal(tex.padded[:, :, :3], tex.image)
    rng = np.random.default_rng(5)
    y = rng.uniform(-1.3, 1.3, (1, 90))  # a row of columns, as the camera gives them
    z = rng.uniform(-0.2, 0.8, (60, 90))
    col, row = SPEC.to_pixel(y, z)
    col, row = np.broadcast_arrays(col, row)
    expected = cv2.remap(tex.image, col.astype(np.float32), row.astype(np.float32),
                         cv2.INTER_LINEAR, borderMode=cv2.BORDER_REFLECT_101)
    got = tex.sample(y, z)
    assert got.shape == (60, 90, 3) and np.array_equal(got, expected)
