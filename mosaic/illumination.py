"""Illumination correction (paper 002 §6.7: non-uniform lighting, attenuation, scattering).

The vehicle's lamp lights the wall unevenly and always the same way in the image, so the
lighting is estimated as a flat field: the mean of the survey's images, smoothed far beyond
the wall's detail, per colour channel. Each image is divided by it (and brought to the survey's
mean brightness). Images that cannot be used — black (a lost frame), saturated, or without any
texture (open water) — are set aside with the reason, never blended.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import numpy.typing as npt

from mosaic import detail

Image = npt.NDArray[np.uint8]
FloatImage = npt.NDArray[np.float32]

BLACK = 12.0  # mean grey below which a frame is black
SATURATED = 0.25  # share of pixels at 250+ above which a frame is saturated
FLAT = 2.0  # band-pass grey std (after correction) below which a frame has no texture: the
# dam mission's images have 5 to 6, open water under 1


def damaged(img: Image | None) -> str | None:
    """Why the raw image cannot be used (None if it can)."""
    import cv2

    if img is None:
        return "unreadable"
    grey = cv2.cvtColor(img, cv2.COLOR_BGR2GRAY) if img.ndim == 3 else img
    mean = float(cv2.mean(grey)[0])
    if mean < BLACK:
        return f"black (mean {mean:.0f}/255)"
    share = float(np.count_nonzero(grey >= 250)) / grey.size
    if share > SATURATED:
        return f"saturated ({100 * share:.0f} % of pixels at 250+)"
    return None


def flat_field(images: Sequence[Image], sigma_fraction: float = 0.12) -> FloatImage:
    """The lamp's pattern: the smoothed mean image (per channel), normalised to mean 1."""
    import cv2

    acc = np.zeros(images[0].shape, np.float64)
    for img in images:
        acc += img
    mean = (acc / max(len(images), 1)).astype(np.float32)
    sigma = sigma_fraction * max(mean.shape[0], mean.shape[1])
    smooth = cv2.GaussianBlur(mean, (0, 0), sigma, borderType=cv2.BORDER_REPLICATE)
    smooth = np.maximum(smooth, 1.0)
    out = smooth / smooth.reshape(-1, smooth.shape[-1] if smooth.ndim == 3 else 1).mean(axis=0)
    return np.asarray(out, dtype=np.float32)


def correct(img: Image, field: FloatImage, level: float = 128.0) -> FloatImage:
    """The image divided by the flat field, its mean brought to ``level``."""
    import cv2

    out = np.asarray(cv2.divide(img.astype(np.float32), field), dtype=np.float32)
    m = float(np.mean(cv2.mean(out)[:3]))
    if m > 1e-3:
        out *= level / m
    return out


def grey(img: FloatImage) -> FloatImage:
    """A corrected colour image's grey (float), which :func:`grey_u8` and :func:`textureless`
    also take (converted once where both are wanted)."""
    import cv2

    return np.asarray(cv2.cvtColor(img, cv2.COLOR_BGR2GRAY), dtype=np.float32)


def grey_u8(img: FloatImage) -> Image:
    """A corrected colour image as 8-bit grey with local contrast stretched (for features)."""
    import cv2

    grey = cv2.cvtColor(img, cv2.COLOR_BGR2GRAY) if img.ndim == 3 else img
    g = np.asarray(np.clip(grey, 0, 255), dtype=np.uint8)
    clahe = cv2.createCLAHE(clipLimit=2.5, tileGridSize=(4, 4))
    return np.asarray(clahe.apply(g), dtype=np.uint8)


def textureless(img: FloatImage) -> str | None:
    """Why a corrected image has nothing to register (None if it has): the detail between
    a few millimetres and a few centimetres on the wall (a band-pass of its grey: Gaussian
    sigma 1.5 px minus sigma 8 px) is too faint — open water, the wall out of sight. The
    sigma-8 smoothing is skipped where a cheaper one proves the detail there
    (:func:`mosaic.detail.surely_at_least`); the answer is the same."""
    import cv2

    grey = cv2.cvtColor(img, cv2.COLOR_BGR2GRAY) if img.ndim == 3 else img
    fine = cv2.GaussianBlur(grey, (0, 0), 1.5)
    if grey.dtype == np.float32 and detail.surely_at_least(grey, fine, FLAT):
        return None
    band = fine - detail.exact(grey)
    std = float(cv2.meanStdDev(band)[1][0, 0])
    return f"no texture (detail {std:.1f} grey levels)" if std < FLAT else None
