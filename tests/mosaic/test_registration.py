"""mosaic/registration.py's matching in numpy is OpenCV's brute-force knnMatch, and its choice
of non-consecutive pairs is the pair-by-pair rule it replaced, to the last bit."""

from __future__ import annotations

import cv2
import numpy as np
from scipy.spatial import cKDTree

from mosaic import registration


def _knn_ratio(query: np.ndarray, train: np.ndarray) -> list[tuple[int, int]]:
    """(query, train) indices of the matches passing Lowe's ratio test, by cv2.BFMatcher."""
    knn = cv2.BFMatcher(cv2.NORM_HAMMING).knnMatch(query, train, k=2)
    return [(m[0].queryIdx, m[0].trainIdx) for m in knn
            if len(m) == 2 and m[0].distance < 0.8 * m[1].distance]


def test_hamming_and_the_two_nearest_are_knnmatch_s() -> None:
    rng = np.random.default_rng(11)
    for trial in range(40):
        train = rng.integers(0, 256, (int(rng.integers(8, 300)), 32), dtype=np.uint8)
        query = train[rng.integers(0, len(train), int(rng.integers(8, 300)))].copy()
        flips = rng.random(query.shape) < 0.04 * (trial % 5)  # near copies, some exact
        query ^= (flips * rng.integers(1, 256, query.shape)).astype(np.uint8)
        if trial % 3 == 0:  # equal train descriptors: ties for the nearest
            train[1::7] = train[0]
        qw, tw = registration.descriptor_words(query), registration.descriptor_words(train)
        assert qw is not None and tw is not None
        dist = registration.hamming(qw, tw)
        want = cv2.batchDistance(query, train, cv2.CV_32S, normType=cv2.NORM_HAMMING, K=2)[0]
        best, d0, d1 = registration.two_nearest(dist)
        assert np.array_equal(np.stack([d0, d1], axis=1), want)
        good = np.flatnonzero(d0 < 0.8 * d1)
        assert list(zip(good.tolist(), best[good].tolist())) == _knn_ratio(query, train)


def _candidates_pair_by_pair(centres: np.ndarray, footprint: tuple[float, float],
                             usable: list[bool], per_image: int, min_overlap: float = 0.5,
                             gap: int = 8) -> list[tuple[int, int]]:
    """The rule as it was written before (a Python loop over the tree's pairs)."""
    fw, fh = footprint
    idx = np.flatnonzero(np.asarray(usable))
    tree = cKDTree(centres[idx] / [fw, fh])
    out = []
    for a, b in tree.query_pairs(1.0 - min_overlap):
        i, j = sorted((int(idx[a]), int(idx[b])))
        if j - i < gap:
            continue
        ov = max(0.0, 1 - abs(centres[i, 0] - centres[j, 0]) / fw) * \
            max(0.0, 1 - abs(centres[i, 1] - centres[j, 1]) / fh)
        if ov >= min_overlap:
            out.append((ov, i, j))
    out.sort(reverse=True)
    taken: dict[int, list[int]] = {}
    pairs = []
    for _, i, j in out:
        mine = taken.setdefault(i, [])
        if len(mine) >= per_image or any(abs(j - k) < gap for k in mine):
            continue
        mine.append(j)
        pairs.append((i, j))
    return sorted(pairs)


def test_candidates_are_the_pair_by_pair_rule_s() -> None:
    rng = np.random.default_rng(4)
    for trial in range(6):
        centres = np.cumsum(rng.normal(0, 0.05, (600, 2)), axis=0)
        if trial % 2:
            centres = np.round(centres, 2)  # equal overlaps
        usable = list(rng.random(600) > 0.05)
        for per_image in (1, 3):
            got = registration.candidates(centres, (0.5, 0.4), usable, per_image=per_image)
            assert got == _candidates_pair_by_pair(centres, (0.5, 0.4), usable, per_image)
            assert got
