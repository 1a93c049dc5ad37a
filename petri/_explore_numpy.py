"""The breadth-first search of :mod:`petri.reachability` in plain numpy (no numba).

It expands one BFS level at a time with array operations: for every transition, the enabled
rows of the level and their successors; then candidates are put in (marking, transition) order
and looked up among the known markings, kept as a sorted array of row keys (each row seen as one
fixed-width ``void`` value, compared bytewise). New markings are numbered in order of first
discovery, so the numbering, arcs and parents are exactly those of the numba kernel.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import numpy.typing as npt

_DONE, _MARKING_LIMIT, _TOKEN_LIMIT = 0, 1, 2

Array = npt.NDArray[Any]


def _keys(cells: Array) -> Array:
    """Each row of ``cells`` as one void scalar (bytewise comparable)."""
    rows = np.ascontiguousarray(cells)
    return rows.view(np.dtype((np.void, rows.shape[1] * rows.itemsize))).ravel()


def explore_rows(m0: Array, in_ptr: Array, in_place: Array, in_w: Array, eff_ptr: Array,
                 eff_place: Array, eff_delta: Array, max_markings: int,
                 max_tokens: int) -> tuple[Array, Array, Array, Array, Array, Array, int, int,
                                           int]:
    """Same contract as :func:`petri._explore_numba.explore_rows`."""
    n_trans = len(in_ptr) - 1
    width = len(m0)
    pre = np.zeros((n_trans, width), dtype=np.int64)
    effect = np.zeros((n_trans, width), dtype=np.int64)
    for t in range(n_trans):
        pre[t, in_place[in_ptr[t]:in_ptr[t + 1]]] = in_w[in_ptr[t]:in_ptr[t + 1]]
        effect[t, eff_place[eff_ptr[t]:eff_ptr[t + 1]]] = eff_delta[eff_ptr[t]:eff_ptr[t + 1]]

    levels = [m0[None, :].copy()]
    parents: list[Array] = [np.array([-1], dtype=np.int64)]
    parent_ts: list[Array] = [np.array([-1], dtype=np.int32)]
    arcs: list[tuple[Array, Array, Array]] = []
    known = _keys(levels[0])  # sorted keys of all numbered markings ...
    known_id = np.zeros(1, dtype=np.int64)  # ... and their numbers
    n, lo = 1, 0
    status, at, stop_t = _DONE, -1, -1
    for _ in range(max_markings):  # one BFS level per round; each level adds a marking
        frontier = levels[-1].astype(np.int64)
        if not len(frontier):
            break
        src, trans, succ = _successors(frontier, pre, effect, lo)
        cut = len(src)
        over = np.flatnonzero((succ > max_tokens).any(axis=1))
        if over.size:
            cut = int(over[0])
            status, at, stop_t = _TOKEN_LIMIT, int(src[cut]), int(trans[cut])
        src, trans = src[:cut], trans[:cut]
        rows = succ[:cut].astype(m0.dtype)
        keys = _keys(rows)
        dst = _find(known, known_id, keys)
        new = dst < 0
        _, first, inverse = np.unique(keys[new], return_index=True, return_inverse=True)
        order = np.argsort(first, kind="stable")  # number new markings by first discovery
        rank = np.empty(len(order), dtype=np.int64)
        rank[order] = np.arange(len(order))
        dst[new] = n + rank[inverse.ravel()]
        if n + len(order) > max_markings:
            keep = np.flatnonzero(new)[first[order[max_markings - n]]]
            status, at, stop_t = _MARKING_LIMIT, int(src[keep]), -1
            src, trans, dst, rows, new = src[:keep], trans[:keep], dst[:keep], rows[:keep], \
                new[:keep]
            order = order[: max_markings - n]
        arcs.append((src, dst, trans))
        new_rows = np.flatnonzero(new)[first[order]]
        levels.append(rows[new_rows])
        parents.append(src[new_rows])
        parent_ts.append(trans[new_rows].astype(np.int32))
        known, known_id = _merge(known, known_id, keys[new_rows], n + np.arange(len(order)))
        lo, n = n, n + len(order)
        if status != _DONE:
            break
    cells = np.concatenate(levels)
    src = np.concatenate([a[0] for a in arcs]).astype(np.int32) if arcs else _none()
    dst = np.concatenate([a[1] for a in arcs]).astype(np.int32) if arcs else _none()
    trans = np.concatenate([a[2] for a in arcs]).astype(np.int32) if arcs else _none()
    return (cells, np.concatenate(parents), np.concatenate(parent_ts), src, dst, trans,
            status, at, stop_t)


def _none() -> Array:
    return np.zeros(0, dtype=np.int32)


def _successors(frontier: Array, pre: Array, effect: Array,
                lo: int) -> tuple[Array, Array, Array]:
    """All firings from the frontier rows (numbered from ``lo``), in (marking, t) order."""
    srcs, ts, succs = [], [], []
    for t in range(len(pre)):
        enabled = np.flatnonzero((frontier >= pre[t]).all(axis=1))
        srcs.append(enabled + lo)
        ts.append(np.full(len(enabled), t, dtype=np.int64))
        succs.append(frontier[enabled] + effect[t])
    src, trans = np.concatenate(srcs), np.concatenate(ts)
    order = np.lexsort((trans, src))
    return src[order], trans[order], np.concatenate(succs)[order]


def _find(known: Array, known_id: Array, keys: Array) -> Array:
    """Number of each key among the known markings, -1 where unknown."""
    pos = np.searchsorted(known, keys)
    pos_ok = np.minimum(pos, len(known) - 1)
    found = known[pos_ok] == keys
    return np.where(found, known_id[pos_ok], -1).astype(np.int64)


def _merge(known: Array, known_id: Array, keys: Array, ids: Array) -> tuple[Array, Array]:
    all_keys = np.concatenate([known, keys])
    all_ids = np.concatenate([known_id, ids])
    order = np.argsort(all_keys, kind="stable")
    return all_keys[order], all_ids[order]
