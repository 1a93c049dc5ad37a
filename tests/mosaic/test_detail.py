"""The cheap proof of the wall's detail (mosaic/detail.py): its matrices are what OpenCV does,
its bound holds, and the texture check answers as the exact band-pass does."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from mosaic import detail, illumination

SHAPE = (240, 320)


def _std(a: np.ndarray) -> float:
    return float(cv2.meanStdDev(a)[1][0, 0])


def _images() -> list[np.ndarray]:
    """Noise, fine stripes, a bright right and bottom border, smooth ramps: float32 grey."""
    rng = np.random.default_rng(7)
    h, w = SHAPE
    yy, xx = np.mgrid[0:h, 0:w].astype(np.float32)
    border = np.full(SHAPE, 128, np.float32)
    border[:, -3:] = 255
    border[-3:, :] = 0
    return [(rng.random(SHAPE) * 255).astype(np.float32),
            (128 + 100 * np.sin(xx * 2.9 + yy * 0.4)).astype(np.float32),
            border,
            (xx * 0.7 + yy * 0.3).astype(np.float32),
            cv2.GaussianBlur((rng.random(SHAPE) * 255).astype(np.float32), (0, 0), 3.0)]


@pytest.mark.parametrize("smooth", [detail.exact, detail.coarse])
def test_the_axis_matrices_are_what_opencv_does(smooth: object) -> None:
    assert callable(smooth)
    rows = detail.axis_matrix(smooth, SHAPE[1], 1)
    cols = detail.axis_matrix(smooth, SHAPE[0], 0)
    for g in _images():
        got = smooth(g)
        assert np.abs(got - cols @ g.astype(float) @ rows.T).max() < 1e-3


def test_the_bound_holds_and_is_small() -> None:
    b = detail.bound(SHAPE)
    assert 0 < b < 5e-3  # the pyramid's smoothing is the sigma-8 blur, nearly
    for g in _images():
        fine = cv2.GaussianBlur(g, (0, 0), 1.5)
        gap = abs(_std(fine - detail.exact(g)) - _std(fine - detail.coarse(g)))
        assert gap <= b * _std(g) + 1e-3


def test_the_texture_check_answers_as_the_exact_band_pass() -> None:
    rng = np.random.default_rng(3)
    noise = cv2.GaussianBlur((rng.random(SHAPE) - 0.5).astype(np.float32), (0, 0), 2.0)
    cheap = 0
    for scale in np.linspace(0, 200, 81):  # the detail from 0 through the level to ~10
        g = (128 + scale * noise).astype(np.float32)
        fine = cv2.GaussianBlur(g, (0, 0), 1.5)
        std = _std(fine - cv2.GaussianBlur(g, (0, 0), 8.0))
        want = f"no texture (detail {std:.1f} grey levels)" if std < illumination.FLAT else None
        assert illumination.textureless(g) == want
        sure = detail.surely_at_least(g, fine, illumination.FLAT)
        assert not sure or std >= illumination.FLAT
        cheap += sure
    assert cheap > 40  # most images with texture are told so without the sigma-8 blur


def test_small_images_take_the_exact_way() -> None:
    g = (np.random.default_rng(1).random((60, 60)) * 255).astype(np.float32)
    assert not detail.surely_at_least(g, cv2.GaussianBlur(g, (0, 0), 1.5), 0.0)
    assert illumination.textureless(g) is None
