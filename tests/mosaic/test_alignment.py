"""mosaic/alignment.py's pair_medians: the median of each pair's errors, all pairs at once,
is the number np.median gives pair by pair (the alignment drops the pairs whose median is
over 5 match_std, so a different number could drop another pair)."""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from mosaic.alignment import RowsOfJacobian, pair_medians


def _one_by_one(e: np.ndarray, sizes: np.ndarray) -> np.ndarray:
    bounds = np.concatenate([[0], np.cumsum(sizes)])
    return np.array([np.median(e[a:b]) for a, b in zip(bounds[:-1], bounds[1:])])


def test_pair_medians_are_np_median_pair_by_pair() -> None:
    rng = np.random.default_rng(5)
    for _ in range(300):
        sizes = rng.integers(1, 17, rng.integers(1, 40)).astype(np.intp)
        e = rng.exponential(2.0, int(sizes.sum()))
        if rng.random() < 0.3:  # ties
            e = np.round(e)
        got = pair_medians(e, sizes)
        assert got.shape == sizes.shape
        assert np.array_equal(got, _one_by_one(e, sizes))  # to the last bit


def test_pair_medians_of_odd_and_even_sizes() -> None:
    e = np.array([3.0, 1.0, 2.0, 10.0, 4.0, 6.0, 1.0, 7.0])
    assert pair_medians(e, np.array([3, 2, 3], dtype=np.intp)).tolist() == [2.0, 7.0, 6.0]


def test_pair_medians_with_a_nan_are_np_median_s() -> None:
    e = np.array([1.0, np.nan, 2.0, 3.0, 4.0])
    got = pair_medians(e, np.array([2, 3], dtype=np.intp))
    assert np.isnan(got[0]) and got[1] == 3.0
    assert pair_medians(np.zeros(0), np.zeros(0, dtype=np.intp)).size == 0


def test_the_jacobian_made_at_once_is_the_coo_matrix_s_rows() -> None:
    """RowsOfJacobian gives the arrays that building the COO matrix, converting it to CSR and
    taking the kept rows gives (so the normal equations, and the poses, are the same bits),
    whichever of a correspondence's two images comes first."""
    rng = np.random.default_rng(0)
    n, m = 30, 200
    ii = rng.integers(0, n, m)
    jj = (ii + rng.integers(1, n, m)) % n  # some above ii, some below
    std = rng.random((n, 4)) + 0.1
    di, dj = rng.normal(0, 300, (m, 2, 4)), rng.normal(0, 300, (m, 2, 4))
    rows_m = np.repeat(np.arange(2 * m), 4)
    cols_i = (4 * ii[:, None, None] + np.arange(4)).repeat(2, axis=1)
    cols_j = (4 * jj[:, None, None] + np.arange(4)).repeat(2, axis=1)
    coo = sp.csr_matrix((np.concatenate([di.ravel(), dj.ravel(), 1.0 / std.ravel()]),
                         (np.concatenate([rows_m, rows_m, 2 * m + np.arange(4 * n)]),
                          np.concatenate([cols_i.ravel(), cols_j.ravel(), np.arange(4 * n)]))),
                        shape=(2 * m + 4 * n, 4 * n))
    direct = RowsOfJacobian(ii, jj, std)
    for share in (1.0, 0.7, 0.3):
        keep = rng.random(m) < share
        want = coo[np.flatnonzero(np.concatenate([np.repeat(keep, 2), np.ones(4 * n, bool)]))]
        got = direct.matrix(di, dj, keep)
        assert got.shape == want.shape
        for part in ("data", "indices", "indptr"):
            assert np.array_equal(getattr(got, part), getattr(want, part))
        assert np.array_equal((got.T @ got).tocsc().data, (want.T @ want).tocsc().data)
