"""Registration of image pairs (paper 002 §6.2) and the choice of pairs (§6.4).

Features: ORB (OpenCV; the paper used SURF, which OpenCV ships only in its non-free build),
matched by Hamming distance with Lowe's ratio test, outliers rejected by RANSAC under a planar
projective motion (a homography). The homography is then verified as the paper does: it is a
proper motion (no reflection), close to the motion of a camera moving abreast of a plane
(scale within 25 %, rotation within 10 deg, little perspective), with enough inliers and
enough overlap. Pairs: every consecutive pair, then non-consecutive pairs whose predicted
footprints (from the navigation data) overlap enough, a few per image from other passages.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import numpy.typing as npt

from mosaic.projection import FloatArray

Image = npt.NDArray[np.uint8]

MIN_INLIERS = 20
MIN_OVERLAP = 0.2  # share of the image
RANSAC_PX = 2.0
POINTS_KEPT = 16  # correspondences per pair passed to the global alignment


@dataclass
class Features:
    points: FloatArray  # (n, 2) pixels
    descriptors: npt.NDArray[np.uint8] | None
    words: npt.NDArray[np.uint64] | None = field(init=False, repr=False)  # for hamming()

    def __post_init__(self) -> None:
        self.words = descriptor_words(self.descriptors)


def descriptor_words(descriptors: npt.NDArray[np.uint8] | None) -> npt.NDArray[np.uint64] | None:
    """Binary descriptors (n, bytes) as 64-bit words, one row a word: (bytes / 8, n), what
    :func:`hamming` takes (None if there are none, or their length is not whole words)."""
    if descriptors is None or descriptors.ndim != 2 or descriptors.shape[1] % 8:
        return None
    return np.ascontiguousarray(np.ascontiguousarray(descriptors).view(np.uint64).T)


@dataclass
class Pair:
    i: int  # frame positions in the survey's list
    j: int
    h: FloatArray  # homography: pixels of j -> pixels of i
    pi: FloatArray  # (m, 2) inlier points in i (a spread-out subset)
    pj: FloatArray  # (m, 2) the same points in j
    inliers: int
    consecutive: bool


class Detector:
    def __init__(self, n: int = 300) -> None:
        import cv2

        # two pyramid levels: consecutive images differ in scale by a few per cent at most
        orb_create: Any = cv2.ORB_create  # type: ignore[attr-defined]
        self.orb = orb_create(nfeatures=n, scaleFactor=1.3, nlevels=2, edgeThreshold=15,
                              patchSize=15, fastThreshold=8)

    def detect(self, grey: Image) -> Features:
        kps, desc = self.orb.detectAndCompute(grey, None)
        pts = np.array([kp.pt for kp in kps], dtype=np.float64).reshape(-1, 2)
        return Features(pts, desc)

    def match(self, fi: Features, fj: Features, shape: tuple[int, int], i: int, j: int,
              consecutive: bool, guess: FloatArray | None = None) -> Pair | str:
        """Register j onto i; a Pair, or why not (words). ``guess``: a predicted homography
        j -> i (from the navigation data); matches far from it are dropped before RANSAC."""
        import cv2

        if fi.words is None or fj.words is None or len(fi.points) < 8 or len(fj.points) < 8:
            return "too few features"
        best, d0, d1 = two_nearest(hamming(fj.words, fi.words))
        good = np.flatnonzero(d0 < 0.8 * d1)  # Lowe's ratio test
        if len(good) < MIN_INLIERS:
            return f"{len(good)} matches"
        sj = fj.points[good]
        si = fi.points[best[good]]
        if guess is not None:
            q = sj @ guess[:, :2].T + guess[:, 2]
            near = np.hypot(*(q[:, :2] / q[:, 2:3] - si).T) < 0.25 * shape[1]
            sj, si = sj[near], si[near]
            if len(sj) < MIN_INLIERS:
                return f"{len(sj)} matches near the predicted motion"
        found, mask = cv2.findHomography(sj, si, cv2.RANSAC, RANSAC_PX, maxIters=500,
                                         confidence=0.995)
        if found is None:
            return "no homography"
        h = np.asarray(found, dtype=np.float64)
        inl = mask.ravel().astype(bool)
        why = verify(h, int(inl.sum()), shape)
        if why is not None:
            return why
        pi, pj = si[inl], sj[inl]
        keep = spread(pj, POINTS_KEPT, shape)
        return Pair(i, j, h, pi[keep], pj[keep], int(inl.sum()), consecutive)


def hamming(query: npt.NDArray[np.uint64],
            train: npt.NDArray[np.uint64]) -> npt.NDArray[np.uint16]:
    """The Hamming distance of every query descriptor (rows) to every train descriptor
    (columns), each given as :func:`descriptor_words`: the distances OpenCV's brute-force
    matcher finds, in 0.35 ms for 300 x 300 ORB descriptors where its ``knnMatch`` took 0.66
    ms (and the Python objects of its answer 0.07 more)."""
    x = np.empty((query.shape[1], train.shape[1]), np.uint64)
    sums = []  # the bits differing in each two words: at most 128, a byte
    for w in range(0, query.shape[0], 2):
        np.bitwise_xor(query[w][:, None], train[w][None, :], out=x)
        two = np.bitwise_count(x)
        if w + 1 < query.shape[0]:
            np.bitwise_xor(query[w + 1][:, None], train[w + 1][None, :], out=x)
            two += np.bitwise_count(x)
        sums.append(two)
    total = np.add(sums[0], sums[1], dtype=np.uint16) if len(sums) > 1 else \
        sums[0].astype(np.uint16)
    for more in sums[2:]:
        total += more
    return total


def two_nearest(distances: npt.NDArray[np.uint16]) -> tuple[npt.NDArray[np.intp],
                                                          npt.NDArray[np.uint16],
                                                          npt.NDArray[np.uint16]]:
    """For each row of ``distances`` (changed here): the column nearest (the first of equals),
    its distance and the second smallest distance (equal to the first on a tie), as
    ``knnMatch(k=2)`` gives them."""
    rows = np.arange(distances.shape[0])
    best = distances.argmin(axis=1)
    first = distances[rows, best]
    distances[rows, best] = np.iinfo(distances.dtype).max
    return best, first, distances.min(axis=1)


def verify(h: FloatArray, inliers: int, shape: tuple[int, int]) -> str | None:
    """The paper's checks of a homography (§6.2); None if it passes, else why not."""
    if inliers < MIN_INLIERS:
        return f"{inliers} inliers"
    a = h[:2, :2] / h[2, 2]
    det = float(np.linalg.det(a))
    if det <= 0:
        return "improper (reflecting) motion"
    scale = math.sqrt(det)
    if not 0.8 < scale < 1.25:
        return f"scale {scale:.2f}"
    angle = math.degrees(math.atan2(a[1, 0] - a[0, 1], a[0, 0] + a[1, 1]))
    if abs(angle) > 10.0:
        return f"rotation {angle:.0f} deg"
    rows, cols = shape
    if abs(h[2, 0] / h[2, 2]) * cols > 0.1 or abs(h[2, 1] / h[2, 2]) * rows > 0.1:
        return "too much perspective"
    if overlap(h, shape) < MIN_OVERLAP:
        return "overlap under 20 %"
    return None


def overlap(h: FloatArray, shape: tuple[int, int]) -> float:
    """Share of image i covered by image j under h (j -> i), from the corners' bounding box."""
    rows, cols = shape
    c = np.array([[0, 0], [cols, 0], [cols, rows], [0, rows]], dtype=float)
    q = c @ h[:, :2].T + h[:, 2]
    q = q[:, :2] / q[:, 2:3]
    w = min(cols, q[:, 0].max()) - max(0.0, q[:, 0].min())
    hh = min(rows, q[:, 1].max()) - max(0.0, q[:, 1].min())
    return float(max(0.0, w) * max(0.0, hh) / (rows * cols))


def spread(pts: FloatArray, n: int, size: tuple[int, int] = (240, 320)) -> npt.NDArray[np.intp]:
    """Indices of up to n points spread over the image: one per cell of a grid of about n
    cells (the first found in each)."""
    if len(pts) <= n:
        return np.arange(len(pts))
    side = max(1, int(math.sqrt(n)))
    rows, cols = size
    cell = (np.clip((pts[:, 1] * side / rows).astype(int), 0, side - 1) * side
            + np.clip((pts[:, 0] * side / cols).astype(int), 0, side - 1))
    _, first = np.unique(cell, return_index=True)
    return np.asarray(first[:n])


def candidates(centres: FloatArray, footprint: tuple[float, float], usable: list[bool],
               per_image: int = 4, min_overlap: float = 0.5,
               gap: int = 8) -> list[tuple[int, int]]:
    """Non-consecutive pairs (i < j) whose predicted footprints (width, height in m, centred
    on ``centres``) overlap by at least min_overlap, from other passages: at most per_image
    per image i, each at least ``gap`` images away from i and from one another."""
    from scipy.spatial import cKDTree

    fw, fh = footprint
    idx = np.flatnonzero(np.asarray(usable))
    if len(idx) < 2:
        return []
    tree = cKDTree(centres[idx] / [fw, fh])
    r = 1.0 - min_overlap  # (1 - |dy|)(1 - |dz|) >= m implies |(dy, dz)| <= 1 - m
    near = tree.query_pairs(r, output_type="ndarray")  # index pairs a < b, so idx[a] < idx[b]
    i, j = idx[near[:, 0]], idx[near[:, 1]]
    far = j - i >= gap
    i, j = i[far], j[far]
    dy = 1 - np.abs(centres[i, 0] - centres[j, 0]) / fw
    dz = 1 - np.abs(centres[i, 1] - centres[j, 1]) / fh
    ov = np.where(dy > 0.0, dy, 0.0) * np.where(dz > 0.0, dz, 0.0)  # max(0.0, ...) each
    enough = ov >= min_overlap
    i, j, ov = i[enough], j[enough], ov[enough]
    order = np.lexsort((j, i, ov))[::-1]  # the largest overlap first (then i, j: the largest)
    out = zip(i[order].tolist(), j[order].tolist())
    taken: dict[int, list[int]] = {}
    pairs = []
    for a, b in out:
        mine = taken.setdefault(a, [])
        if len(mine) >= per_image or any(abs(b - k) < gap for k in mine):
            continue
        mine.append(b)
        pairs.append((a, b))
    return sorted(pairs)
