"""The wall's detail in an image, and a cheap proof that it is there (the texture check of
:func:`mosaic.illumination.textureless`: open water, the wall out of sight).

The detail is a band-pass of the corrected grey image ``g``: its Gaussian smoothing of
sigma 1.5 px minus that of sigma 8 px (``G``), and an image has texture when the detail's
standard deviation reaches :data:`mosaic.illumination.FLAT`. The sigma-8 smoothing is most of
the check's cost (0.64 ms of 0.82 for a 320 x 240 image). :func:`surely_at_least` decides
"the detail reaches ``level``" from a cheaper smoothing ``C`` (:func:`coarse`: the image
reflected outwards at its last rows and columns as the blur reflects it, halved twice by
``pyrDown``, smoothed with sigma sqrt(3.375) px, doubled twice by ``pyrUp``, cropped; 0.12 ms)
when it can prove it, and else says nothing (the exact detail is then worked out, as before):

* The standard deviation is a seminorm: |std(a) - std(b)| <= std(a - b).
* ``C`` and ``G`` are linear, keep constant images constant, and act on rows and columns
  apart (one matrix per axis: C = Cc (x) Cr, G = Gc (x) Gr). So, m being the mean of g and N
  its pixels, std(Cg - Gg) <= |(C - G)(g - m)| / sqrt(N) <= |C - G| std(g) (spectral norms);
  C - G = (Cc - Gc) (x) Cr + Gc (x) (Cr - Gr) gives |C - G| <= |Cc - Gc| |Cr| + |Gc| |Cr - Gr|,
  each bounded by the square root of its largest absolute column sum times its largest
  absolute row sum (Schur's test); and std(g) <= (max g - min g) / 2 (Popoviciu).
* The four matrices are measured once for each image size, by putting unit impulses through
  the same OpenCV calls (:func:`axis_matrix`).

So the exact detail's deviation is at least the cheap one's minus ``bound(shape)`` times
half the grey's range; when that still reaches the level with :data:`MARGIN` to spare (for
floating-point rounding), the image has texture. For 320 x 240 images the bound is 1.9e-3
(under 0.25 grey levels for any image of grey levels 0 to 255; the dam mission's images have
a detail of 5 to 6 grey levels against a level of 2). With one halving (sigma sqrt(15.5) at
half size) the bound is 2.2e-4 but the smoothing takes 0.17 ms.
"""

from __future__ import annotations

import math
import threading
from collections.abc import Callable
from typing import Any

import numpy as np
import numpy.typing as npt

FloatImage = npt.NDArray[np.float32]
Grey = npt.NDArray[Any]  # a grey image as OpenCV gives it

REACH = 50  # px beyond which a pixel does not move either smoothing: the quarter-size
# sigma's 8 taps (32 px), the two pyrDowns' 2 and 4 px, the two pyrUps' 4 and 2, and some to
# spare (the impulses' spacing in axis_matrix is twice this and more)
PAD = REACH + 6  # px each image is reflected outwards at its end, beyond the reach of the
# pyramid's own border there
QUARTER_SIGMA = math.sqrt(3.375)  # each pyrDown and pyrUp adds a variance of 1 px² of its
# finer image: 1 + 4 + 16 * 3.375 + 4 + 1 = 64 = 8²
MARGIN = 0.05  # grey levels kept to spare for the rounding of float32 arithmetic (under 0.005)


def exact(grey: Grey) -> Grey:
    """The sigma-8 smoothing of the detail's band-pass."""
    import cv2

    return np.asarray(cv2.GaussianBlur(grey, (0, 0), 8.0))


def coarse(grey: FloatImage) -> FloatImage:
    """The cheap smoothing close to :func:`exact` (see the module's docstring)."""
    import cv2

    h, w = grey.shape
    padded = cv2.copyMakeBorder(grey, 0, PAD, 0, PAD, cv2.BORDER_REFLECT_101)
    half = cv2.pyrDown(padded)
    quarter = cv2.GaussianBlur(cv2.pyrDown(half), (0, 0), QUARTER_SIGMA)
    half = cv2.pyrUp(quarter, dstsize=(half.shape[1], half.shape[0]))
    return np.asarray(cv2.pyrUp(half, dstsize=(padded.shape[1], padded.shape[0]))[:h, :w],
                      dtype=np.float32)


def axis_matrix(smooth: Callable[[FloatImage], Grey], n: int, axis: int,
                other: int = 4) -> npt.NDArray[np.float64]:
    """The n x n matrix of what ``smooth`` does along ``axis`` (1: along each row, 0: along
    each column) of an image n long that way, measured: impulses 2 * REACH + 6 px apart, in
    an image ``other`` px the other way and constant that way (which the other axis's
    matrix, keeping constants, leaves alone)."""
    step = 2 * REACH + 6
    out = np.zeros((n, n))
    for first in range(min(step, n)):
        at = np.arange(first, n, step)
        line = np.zeros(n, np.float32)
        line[at] = 1.0
        img = np.tile(line, (other, 1)) if axis == 1 else np.tile(line[:, None], (1, other))
        got = smooth(np.ascontiguousarray(img))
        seen = got[other // 2] if axis == 1 else got[:, other // 2]
        for j in at:
            lo, hi = max(0, j - step // 2), min(n, j + step // 2)
            out[lo:hi, j] = seen[lo:hi]
    return out


def schur(a: npt.NDArray[np.float64]) -> float:
    """An upper bound of the spectral norm of ``a``: sqrt(max column sum * max row sum) of
    its absolute values."""
    m = np.abs(a)
    return math.sqrt(float(m.sum(axis=0).max()) * float(m.sum(axis=1).max()))


_bounds: dict[tuple[int, int], float] = {}
_lock = threading.Lock()


def bound(shape: tuple[int, int]) -> float:
    """|C - G| for images of ``shape`` (rows, columns), measured once for each shape."""
    with _lock:
        if shape not in _bounds:
            h, w = shape
            cr, gr = axis_matrix(coarse, w, 1), axis_matrix(exact, w, 1)
            cc, gc = axis_matrix(coarse, h, 0), axis_matrix(exact, h, 0)
            _bounds[shape] = schur(cc - gc) * schur(cr) + schur(gc) * schur(cr - gr)
        return _bounds[shape]


def surely_at_least(grey: Grey, fine: Grey, level: float) -> bool:
    """Whether the standard deviation of ``fine - exact(grey)`` (``fine``: the sigma-1.5
    smoothing) is surely ``level`` or more, known without :func:`exact`; False when it
    cannot be told so (the image too small for the pyramid, or the detail too near the
    level)."""
    import cv2

    if min(grey.shape) < 2 * PAD:
        return False
    low, high = cv2.minMaxLoc(grey)[:2]  # std(grey) <= (high - low) / 2
    cheap = float(cv2.meanStdDev(fine - coarse(grey))[1][0, 0])
    return cheap >= level + 1.01 * bound(grey.shape[:2]) * (high - low) / 2 + MARGIN
