"""The breadth-first search of :mod:`petri.verification.reachability` in plain numpy (no numba).

It expands one BFS level at a time with array operations: the marked places of the level's rows
give the candidate transitions (those indexed under a marked place, see
:func:`petri.verification.reachability.compile_net`), their input arcs are checked, and the enabled ones fire
through their sparse effects; then successors are put in (marking, transition) order
and looked up among the known markings, kept as a sorted array of row keys (each row seen as one
fixed-width ``void`` value, compared bytewise). New markings are numbered in order of first
discovery, so the numbering, arcs and parents are exactly those of the numba kernel.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import numpy.typing as npt

_DONE, _MARKING_LIMIT, _TOKEN_LIMIT, _MEMORY_LIMIT = 0, 1, 2, 4
# The work arrays of a slice, per candidate firing, beyond its rows (as int64, as stored, the
# new ones' keys and their sorted copy: 11 row widths): its row number, transition, number,
# order and rank, 8 bytes each, and numpy's temporaries.
WORK_BYTES = 8 * 8

Array = npt.NDArray[Any]


def _keys(cells: Array) -> Array:
    """Each row of ``cells`` as one void scalar (bytewise comparable)."""
    rows = np.ascontiguousarray(cells)
    return rows.view(np.dtype((np.void, rows.shape[1] * rows.itemsize))).ravel()


# The successors of a BFS level are computed a slice of the level at a time, each slice's
# candidate firings holding at most CHUNK_BYTES (an eighth of the memory budget if less) as
# int64 rows: a wide level of a large net
# (Philosophers-PT-000050: 14.7 million candidates of 256 places, 28 GiB at once) never
# allocates more than that. Slices are taken in row order, so the numbering is unchanged.
CHUNK_BYTES = 64 << 20


def explore_rows(net: Any, max_markings: int, max_tokens: int, arcs: bool = True,
                 max_bytes: float = math.inf) -> tuple[Any, ...]:
    """Same contract as :func:`petri.verification.explore_numba.explore_rows`: before each
    slice of a level, the bytes it would hold after it (what is kept, the slice's work
    arrays, the copy the sorted keys make as they grow) are estimated, and past
    ``max_bytes`` the search stops there with status 4 (memory limit)."""
    m0 = net.row
    width = m0.shape[0] * m0.itemsize
    levels = [m0[None, :].copy()]
    parents: list[Array] = [np.array([-1], dtype=np.int64)]
    parent_ts: list[Array] = [np.array([-1], dtype=np.int32)]
    found: list[tuple[Array, Array, Array]] = []  # arcs, int32 (arcs=True)
    degrees: list[Array] = []  # successors of each expanded row, in order (arcs=False)
    fired = np.zeros(len(net.in_ptr) - 1, dtype=np.int64)
    known = _keys(levels[0])  # sorted keys of all numbered markings ...
    known_id = np.zeros(1, dtype=np.int64)  # ... and their numbers
    n, lo = 1, 0
    held = width + 28  # bytes kept: rows, parents, keys, numbers, and arcs or degrees
    chunk = int(min(CHUNK_BYTES, max(1 << 16, max_bytes / 8)))  # a slice's candidates
    status, at, stop_t = _DONE, -1, -1
    for _ in range(max_markings):  # one BFS level per round; each level adds a marking
        level = levels[-1]
        if not len(level):
            break
        new_levels: list[Array] = []
        for first_row, last_row, candidates in _slices(level, net, chunk):
            need = held + known.nbytes + known_id.nbytes + 8 * width * (
                last_row - first_row) + candidates * (11 * width + WORK_BYTES + 12 * arcs)
            if need > max_bytes:  # the rows before this slice have all their arcs
                status, at = _MEMORY_LIMIT, lo + first_row
                break
            frontier = level[first_row:last_row].astype(np.int64)
            src, trans, succ = _successors(frontier, net, lo + first_row)
            cut = len(src)
            over = np.flatnonzero((succ > max_tokens).any(axis=1))
            if over.size:
                cut = int(over[0])
                status, at, stop_t = _TOKEN_LIMIT, int(src[cut]), int(trans[cut])
            src, trans = src[:cut], trans[:cut]
            rows = succ[:cut].astype(m0.dtype)
            del succ
            keys = _keys(rows)
            dst = _find(known, known_id, keys)
            new = dst < 0
            _, first, inverse = np.unique(keys[new], return_index=True, return_inverse=True)
            order = np.argsort(first, kind="stable")  # number new markings by discovery
            rank = np.empty(len(order), dtype=np.int64)
            rank[order] = np.arange(len(order))
            dst[new] = n + rank[inverse.ravel()]
            if n + len(order) > max_markings:
                keep = np.flatnonzero(new)[first[order[max_markings - n]]]
                status, at, stop_t = _MARKING_LIMIT, int(src[keep]), -1
                src, trans, dst, rows, new = src[:keep], trans[:keep], dst[:keep], \
                    rows[:keep], new[:keep]
                order = order[: max_markings - n]
            if arcs:
                found.append((src.astype(np.int32), dst.astype(np.int32),
                              trans.astype(np.int32)))
            else:  # the same counts the numba kernel keeps instead of the arcs
                base = lo + first_row
                degrees.append(np.bincount(src - base, minlength=last_row - first_row)
                               .astype(np.int32))
                fired += np.bincount(trans, minlength=len(fired))
            new_rows = np.flatnonzero(new)[first[order]]
            new_levels.append(rows[new_rows])
            parents.append(src[new_rows])
            parent_ts.append(trans[new_rows].astype(np.int32))
            known, known_id = _merge(known, known_id, keys[new_rows],
                                     n + np.arange(len(order)))
            n += len(order)
            held += len(order) * (2 * width + 20) + len(src) * (12 if arcs else 0) + \
                (0 if arcs else 4 * (last_row - first_row))
            if status != _DONE:
                break
        lo += len(level)
        levels.append(np.concatenate(new_levels) if new_levels else level[:0])
        if status != _DONE:
            break
    cells = np.concatenate(levels)
    src = np.concatenate([a[0] for a in found]) if found else _none()
    dst = np.concatenate([a[1] for a in found]) if found else _none()
    trans = np.concatenate([a[2] for a in found]) if found else _none()
    degree = fired_out = None
    if not arcs:
        degree = np.zeros(len(cells), dtype=np.int32)
        counted = np.concatenate(degrees)[: len(cells)] if degrees else degree[:0]
        degree[: len(counted)] = counted
        fired_out = fired
    return (cells, np.concatenate(parents), np.concatenate(parent_ts), src, dst, trans,
            status, at, stop_t, degree, fired_out)


def _slices(level: Array, net: Any, chunk: int = CHUNK_BYTES) -> list[tuple[int, int, int]]:
    """Row ranges of ``level`` whose candidate firings fit ``chunk`` bytes each (a single
    row may exceed it: it is a slice of its own), with their numbers of candidates."""
    per_row = np.empty(len(level), dtype=np.int64)
    block = max(1, chunk // (32 * max(1, level.shape[1])))  # its nonzero cells' work
    for a in range(0, len(level), block):  # a block at a time: a level's marked cells
        rows, places = np.nonzero(level[a:a + block])  # may take many times its size
        per_row[a:a + block] = np.bincount(
            rows, weights=net.rd_ptr[places + 1] - net.rd_ptr[places],
            minlength=min(block, len(level) - a))
    per_row += len(net.sources)
    cap = max(1, chunk // (8 * level.shape[1]))
    ends = np.cumsum(per_row)
    cuts = [0]
    while cuts[-1] < len(level):
        base = ends[cuts[-1] - 1] if cuts[-1] else 0
        nxt = int(np.searchsorted(ends, base + cap, side="right"))
        cuts.append(min(len(level), max(nxt, cuts[-1] + 1)))
    return [(a, b, int(ends[b - 1] - (ends[a - 1] if a else 0)))
            for a, b in zip(cuts[:-1], cuts[1:])]


def _none() -> Array:
    return np.zeros(0, dtype=np.int32)


def _ranges(starts: Array, counts: Array) -> Array:
    """The concatenation of arange(s, s + c) for each (s, c)."""
    total = int(counts.sum())
    if not total:
        return np.zeros(0, dtype=np.int64)
    ends = np.cumsum(counts)
    shift = np.repeat(starts - (ends - counts), counts)
    return shift + np.arange(total, dtype=np.int64)


def _successors(frontier: Array, net: Any, lo: int) -> tuple[Array, Array, Array]:
    """All firings from the frontier rows (numbered from ``lo``), in (marking, t) order."""
    rows, places = np.nonzero(frontier)
    counts = net.rd_ptr[places + 1] - net.rd_ptr[places]
    cand_row = np.repeat(rows, counts)
    cand_t = net.rd_t[_ranges(net.rd_ptr[places], counts)]
    # every candidate has an input (its first one is marked): check all of them
    n_in = net.in_ptr[cand_t + 1] - net.in_ptr[cand_t]
    arcs = _ranges(net.in_ptr[cand_t], n_in)
    ok = frontier[np.repeat(cand_row, n_in), net.in_place[arcs]] >= net.in_w[arcs]
    if len(cand_t):
        enabled = np.logical_and.reduceat(ok, np.cumsum(n_in) - n_in)
        cand_row, cand_t = cand_row[enabled], cand_t[enabled]
    if len(net.sources):  # transitions without inputs fire everywhere
        cand_row = np.concatenate([cand_row, np.repeat(np.arange(len(frontier)),
                                                       len(net.sources))])
        cand_t = np.concatenate([cand_t, np.tile(net.sources, len(frontier))])
    order = np.lexsort((cand_t, cand_row))
    cand_row, cand_t = cand_row[order], cand_t[order]
    succ = frontier[cand_row]
    n_eff = net.eff_ptr[cand_t + 1] - net.eff_ptr[cand_t]
    eff = _ranges(net.eff_ptr[cand_t], n_eff)
    succ[np.repeat(np.arange(len(cand_t)), n_eff), net.eff_place[eff]] += net.eff_delta[eff]
    return cand_row + lo, cand_t.astype(np.int64), succ


def _find(known: Array, known_id: Array, keys: Array) -> Array:
    """Number of each key among the known markings, -1 where unknown."""
    pos = np.searchsorted(known, keys)
    pos_ok = np.minimum(pos, len(known) - 1)
    found = known[pos_ok] == keys
    return np.where(found, known_id[pos_ok], -1).astype(np.int64)


def _merge(known: Array, known_id: Array, keys: Array, ids: Array) -> tuple[Array, Array]:
    """The known keys with ``keys`` (new, unique) put in their sorted places: one pass."""
    order = np.argsort(keys, kind="stable")
    at = np.searchsorted(known, keys[order])
    return np.insert(known, at, keys[order]), np.insert(known_id, at, ids[order])
