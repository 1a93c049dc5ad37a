"""Global alignment (paper 002 §6.5): every image's camera pose by least squares.

Unknowns: each image's camera pose (y, z, d, yaw) (:mod:`mosaic.projection`). Residuals: for
every registered pair and each of its kept correspondences, the distance on the wall between
where the two images put the same feature (in units of ``match_std`` metres), and for every
image its pose minus the navigation data's (in units of the navigator's standard deviations,
the prior). The Jacobian is analytic and sparse (each residual touches one or two images);
Gauss-Newton steps, each a sparse direct solve of the normal equations (SciPy's SuperLU),
minimise — the paper's "large-scale methods for nonlinear least squares". (SciPy's
``least_squares`` with its sparse LSMR trust region reached the same solutions but needed a
minute for the dam mission's 1,329 images, where these steps take a few seconds.) A pair whose correspondences
disagree with the solution by more than 5 match_std (median) slipped through registration
wrongly: it is dropped, reported, and the problem solved again without it (the worst first,
since a wrong pair also strains its neighbours; at most 8 rounds).

Without the navigation prior (``use_prior=False``) the images' positions along the wall and in
depth come from the image chain alone: only the first image is held at its navigation data
(else the whole mosaic could slide), the others on a 100 m leash; the distance to the wall
(sonar) and the heading (FOG) still hold each image's scale and yaw. What the navigation
prior is for shows in the difference.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt
import scipy.sparse as sp
from scipy.sparse.linalg import spsolve

from mosaic.projection import FloatArray, Intrinsics, wall_jacobian, wall_points
from mosaic.registration import Pair


@dataclass
class Alignment:
    poses: FloatArray  # (n, 4) y, z, d, yaw of each image
    cost: float
    iterations: int
    rejected: list[tuple[int, int]]  # pairs whose residual stayed beyond 5 match_std


def align(prior: FloatArray, prior_std: FloatArray, pairs: Sequence[Pair], k: Intrinsics,
          use_prior: bool = True, match_std: float = 0.003, anchor: int = 0,
          x0: FloatArray | None = None, max_iterations: int = 20) -> Alignment:
    """Poses (n, 4) of all images from the pairs' correspondences and the prior."""
    n = len(prior)
    prior = np.asarray(prior, dtype=float)
    std = np.asarray(prior_std, dtype=float).copy()
    if not use_prior:  # only the anchor keeps its position; the others, a loose leash
        std[:, :2] = 100.0
        std[anchor, :2] = prior_std[anchor, :2]
    sizes = np.array([len(p.pi) for p in pairs], dtype=np.intp)  # each pair's points, in order
    starts = np.concatenate([[0], np.cumsum(sizes)[:-1]]).astype(np.intp)
    ii = np.repeat(np.array([p.i for p in pairs], dtype=int), sizes)
    jj = np.repeat(np.array([p.j for p in pairs], dtype=int), sizes)
    pi = np.concatenate([p.pi for p in pairs]) if pairs else np.zeros((0, 2))
    pj = np.concatenate([p.pj for p in pairs]) if pairs else np.zeros((0, 2))
    ai, bi = k.slopes(pi)
    aj, bj = k.slopes(pj)
    m = len(ii)

    def residuals(q: FloatArray) -> FloatArray:
        poses = q.reshape(n, 4)
        wi = wall_points(poses[ii], ai, bi)
        wj = wall_points(poses[jj], aj, bj)
        rm = ((wi - wj) / match_std).ravel()
        rp = ((poses - prior) / std).ravel()
        return np.concatenate([rm, rp])

    rows_m = np.repeat(np.arange(2 * m), 4)

    def jacobian(q: FloatArray) -> sp.csr_matrix:
        poses = q.reshape(n, 4)
        ji = wall_jacobian(poses[ii], ai, bi) / match_std  # (m, 2, 4)
        jj_ = -wall_jacobian(poses[jj], aj, bj) / match_std
        cols_i = (4 * ii[:, None, None] + np.arange(4)[None, None, :]).repeat(2, axis=1)
        cols_j = (4 * jj[:, None, None] + np.arange(4)[None, None, :]).repeat(2, axis=1)
        rows = np.concatenate([rows_m, rows_m, 2 * m + np.arange(4 * n)])
        cols = np.concatenate([cols_i.ravel(), cols_j.ravel(), np.arange(4 * n)])
        vals = np.concatenate([ji.ravel(), jj_.ravel(), 1.0 / std.ravel()])
        return sp.csr_matrix((vals, (rows, cols)), shape=(2 * m + 4 * n, 4 * n))

    direct = RowsOfJacobian(ii, jj, std) if m and not (ii == jj).any() else None
    q = (prior if x0 is None else x0).ravel().copy()
    keep = np.ones(m, bool)
    rejected: list[tuple[int, int]] = []
    iterations = 0
    for _ in range(8):  # solve; drop the pairs that disagree most with the rest; solve again
        rows = np.flatnonzero(np.concatenate([np.repeat(keep, 2), np.ones(4 * n, bool)]))
        kept = keep.copy()

        def fun(x: FloatArray, rows: npt.NDArray[np.intp] = rows) -> FloatArray:
            return residuals(x)[rows]

        def jac(x: FloatArray, rows: npt.NDArray[np.intp] = rows,
                kept: npt.NDArray[np.bool_] = kept) -> sp.csr_matrix:
            if direct is not None:
                poses = x.reshape(n, 4)
                return direct.matrix(wall_jacobian(poses[ii], ai, bi) / match_std,
                                     -wall_jacobian(poses[jj], aj, bj) / match_std, kept)
            return jacobian(x)[rows]

        q, its = _gauss_newton(fun, jac, q, max_iterations)
        iterations += its
        r = residuals(q)[:2 * m].reshape(-1, 2)
        medians = pair_medians(np.hypot(r[:, 0], r[:, 1]), sizes)
        bad = [(p, at, size, float(med)) for p, at, size, med in zip(pairs, starts, sizes, medians)
               if keep[at] and med > 5.0]
        if not bad:
            break
        worst = max(med for *_, med in bad)
        for p, at, size, med in bad:  # the worst first: a wrong pair also strains its neighbours
            if med < 0.5 * worst:
                continue
            keep[at:at + size] = False
            rejected.append((p.i, p.j))
    rows = np.flatnonzero(np.concatenate([np.repeat(keep, 2), np.ones(4 * n, bool)]))
    cost = 0.5 * float(np.sum(residuals(q)[rows] ** 2))
    return Alignment(q.reshape(n, 4), cost, iterations, rejected)


class RowsOfJacobian:
    """The alignment's Jacobian, rows of the kept correspondences and then the prior's, made
    as a CSR matrix at once: the arrays ``csr_matrix((vals, (rows, cols)))[kept rows]`` gives
    (each correspondence's two rows hold the four columns of one image and the four of the
    other, the lower image first; then one entry a pose unknown), without building the COO
    matrix, converting and indexing it on every Gauss-Newton step. Images ``ii`` and ``jj``
    of each correspondence differ."""

    def __init__(self, ii: npt.NDArray[np.intp], jj: npt.NDArray[np.intp],
                 std: FloatArray) -> None:
        four = np.arange(4)
        lo, hi = np.minimum(ii, jj), np.maximum(ii, jj)
        cols = np.concatenate([4 * lo[:, None] + four, 4 * hi[:, None] + four], axis=1)
        self.cols = np.repeat(cols[:, None, :], 2, axis=1)  # (m, 2, 8)
        self.swap = ii > jj  # the j block comes first in these rows
        self.prior = 1.0 / std.ravel()
        self.unknowns = self.prior.size
        self.cached: tuple[bytes, npt.NDArray[np.intp], npt.NDArray[np.intp]] | None = None

    def matrix(self, di: FloatArray, dj: FloatArray,
               kept: npt.NDArray[np.bool_]) -> sp.csr_matrix:
        """The Jacobian's rows for derivatives ``di``, ``dj`` (m, 2, 4) of the correspondences
        against their two images' poses, of the correspondences ``kept``."""
        both = np.concatenate([di, dj], axis=2)
        if self.swap.any():
            both[self.swap] = both[self.swap][:, :, [4, 5, 6, 7, 0, 1, 2, 3]]
        key = kept.tobytes()
        if self.cached is None or self.cached[0] != key:
            k = int(kept.sum())
            indices = np.concatenate([self.cols[kept].ravel(), np.arange(self.unknowns)])
            indptr = np.concatenate([np.arange(0, 16 * k, 8),
                                     16 * k + np.arange(self.unknowns + 1)])
            self.cached = (key, indices, indptr)
        _, indices, indptr = self.cached
        data = np.concatenate([both[kept].ravel(), self.prior])
        return sp.csr_matrix((data, indices, indptr),
                             shape=(indptr.size - 1, self.unknowns))


def pair_medians(e: FloatArray, sizes: npt.NDArray[np.intp]) -> FloatArray:
    """The median of each pair's errors, ``e`` holding the pairs' errors one pair after
    another (``sizes`` of them each): the numbers ``np.median`` gives pair by pair (the middle
    one, or the mean of the middle two), at once — 2,863 calls of it took 0.17 s a round for the
    dam mission."""
    if sizes.size == 0:
        return np.zeros(0)
    if not np.isfinite(e).all() or sizes.min() < 1:  # np.median's own handling of NaN
        bounds = np.concatenate([[0], np.cumsum(sizes)])
        return np.array([np.median(e[a:b]) if b > a else np.nan
                         for a, b in zip(bounds[:-1], bounds[1:])])
    table = np.full((sizes.size, int(sizes.max())), np.inf)
    table[np.arange(table.shape[1])[None, :] < sizes[:, None]] = e
    table.sort(axis=1)
    rows = np.arange(sizes.size)
    return np.asarray((table[rows, (sizes - 1) // 2] + table[rows, sizes // 2]) / 2.0)


def _gauss_newton(fun: Callable[[FloatArray], FloatArray],
                  jac: Callable[[FloatArray], sp.csr_matrix], x: FloatArray,
                  max_iterations: int) -> tuple[FloatArray, int]:
    """Minimise |fun(x)|^2 by Gauss-Newton steps, each a sparse direct solve of the normal
    equations (J'J + mu I) dx = -J'r, halving a step that does not lower the cost."""
    r = fun(x)
    cost = float(r @ r)
    for it in range(1, max_iterations + 1):
        j = jac(x)
        jtj = (j.T @ j).tocsc()
        g = j.T @ r
        mu = 1e-9 * float(jtj.diagonal().max())
        dx = spsolve(jtj + mu * sp.identity(jtj.shape[0], format="csc"), -g)
        step = 1.0
        for _ in range(10):
            xn = x + step * dx
            rn = fun(xn)
            cn = float(rn @ rn)
            if cn <= cost:
                break
            step *= 0.5
        else:
            return x, it
        done = cost - cn <= 1e-10 * max(cost, 1.0) or float(np.abs(step * dx).max()) < 1e-9
        x, r, cost = xn, rn, cn
        if done:
            return x, it
    return x, max_iterations
