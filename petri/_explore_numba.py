"""The breadth-first successor loop of :mod:`petri.reachability`, compiled with numba.

Importing this module fails with ImportError when numba is missing; the caller then falls back
to :mod:`petri._explore_numpy`, which numbers markings the same way.

Layout (see reachability.py): marking ``i`` is ``words[i]``, a row of K uint64 words that hold
the token counts as bytes (or wider integers); ``hashes[i]`` is its hash (kept to
rebuild the hash table when it grows).
"""

from __future__ import annotations

import numpy as np
from numba import njit

_C1 = np.uint64(0x9E3779B97F4A7C15)  # golden-ratio multiplier
_C2 = np.uint64(0xBF58476D1CE4E5B9)  # splitmix64 finaliser constants
_C3 = np.uint64(0x94D049BB133111EB)


@njit(cache=True, inline="always")
def _hash(row: np.ndarray) -> np.uint64:
    """Hash of a row of words: multiply-xor per word, then the splitmix64 finaliser."""
    h = np.uint64(len(row))
    for k in range(len(row)):
        h = (h ^ row[k]) * _C1
        h ^= h >> np.uint64(29)
    h = (h ^ (h >> np.uint64(30))) * _C2
    h = (h ^ (h >> np.uint64(27))) * _C3
    return h ^ (h >> np.uint64(31))


@njit(cache=True)
def _grow_rows(a: np.ndarray, n: int) -> np.ndarray:
    b = np.empty((2 * a.shape[0], a.shape[1]), dtype=a.dtype)
    b[:n] = a[:n]
    return b


@njit(cache=True)
def _grow(a: np.ndarray, n: int) -> np.ndarray:
    b = np.empty(2 * a.shape[0], dtype=a.dtype)
    b[:n] = a[:n]
    return b


# -- the hash table ---------------------------------------------------------------------
# Two layouts, chosen by row width. Small rows (at most _INLINE_WORDS words) are stored in the
# table itself, so a lookup touches one cache line: table[slot] = [row number + 1, words...].
# Wider rows would make the table too big; then table[slot, 0] = (high 32 bits of the hash)
# << 32 | (row number + 1), and a matching fingerprint is confirmed against words[row].
# In both layouts 0 in column 0 means an empty slot. The table is kept at most half full, so
# every probe sequence ends at an empty slot.

_INLINE_WORDS = 4
_LOW32 = np.uint64(0xFFFFFFFF)


@njit(cache=True, inline="always")
def _lookup(table, mask, h, row, words):  # type: ignore[no-untyped-def]
    """(slot, row number) of ``row``, or (the empty slot where it belongs, -1)."""
    inline = table.shape[1] > 1
    fingerprint = h >> np.uint64(32)
    slot = h & mask
    entry = table[slot, 0]
    while entry != 0:
        if inline:
            same = True
            for k in range(row.shape[0]):
                if table[slot, k + 1] != row[k]:
                    same = False
                    break
            if same:
                return slot, np.int64(entry) - 1
        elif entry >> np.uint64(32) == fingerprint:
            j = np.int64(entry & _LOW32) - 1
            same = True
            for k in range(row.shape[0]):
                if words[j, k] != row[k]:
                    same = False
                    break
            if same:
                return slot, j
        slot = (slot + np.uint64(1)) & mask
        entry = table[slot, 0]
    return slot, np.int64(-1)


@njit(cache=True, inline="always")
def _store(table, slot, j, h, row):  # type: ignore[no-untyped-def]
    if table.shape[1] > 1:
        table[slot, 0] = np.uint64(j + 1)
        for k in range(row.shape[0]):
            table[slot, k + 1] = row[k]
    else:
        table[slot, 0] = ((h >> np.uint64(32)) << np.uint64(32)) | np.uint64(j + 1)


@njit(cache=True)
def _new_table(size, n_words):  # type: ignore[no-untyped-def]
    width = n_words + 1 if n_words <= _INLINE_WORDS else 1
    return np.zeros((size, width), dtype=np.uint64)


@njit(cache=True)
def _rehash(words, hashes, n, size):  # type: ignore[no-untyped-def]
    table = _new_table(size, words.shape[1])
    mask = np.uint64(size - 1)
    for i in range(n):
        slot = hashes[i] & mask
        while table[slot, 0] != 0:  # at most half full: a free slot exists
            slot = (slot + np.uint64(1)) & mask
        _store(table, slot, i, hashes[i], words[i])
    return table


# -- the search ---------------------------------------------------------------------------
# The search alternates between _expand, which runs the hot loop over arrays it never
# reallocates, and explore_rows, which grows the arrays whenever _expand stops because the next
# marking might not fit. (Reassigning arrays inside the hot loop makes numba reference-count
# them on every iteration, which more than doubled the time per arc.)

_RUNNING, _DONE, _MARKING_LIMIT, _TOKEN_LIMIT = -1, 0, 1, 2


@njit(cache=True)
def _expand(i, n, e, words, hashes, parent, parent_t, src, dst, tr, table, cur, nxt,
            in_ptr, in_place, in_w, eff_ptr, eff_place, eff_delta, max_markings,
            max_tokens):  # type: ignore[no-untyped-def]
    """Expand markings i, i+1, ... while every successor surely fits in the arrays.

    Returns (i, n, e, status, at, t): the next marking to expand, the numbers of markings and
    arcs, and _RUNNING (grow the arrays and call again) or a final status.
    """
    n_words = words.shape[1]
    n_trans = in_ptr.shape[0] - 1
    mask = np.uint64(table.shape[0] - 1)
    cur_w = cur.view(np.uint64)  # the marking being expanded, as words
    nxt_w = nxt.view(np.uint64)
    while i < n:
        if (n + n_trans > words.shape[0] or e + n_trans > src.shape[0]
                or 2 * (n + n_trans) > table.shape[0]):
            return i, n, e, _RUNNING, -1, -1
        for k in range(n_words):
            cur_w[k] = words[i, k]
        for t in range(n_trans):
            enabled = True
            for a in range(in_ptr[t], in_ptr[t + 1]):
                if cur[in_place[a]] < in_w[a]:
                    enabled = False
                    break
            if not enabled:
                continue
            for k in range(n_words):
                nxt_w[k] = cur_w[k]
            for a in range(eff_ptr[t], eff_ptr[t + 1]):
                value = np.int64(cur[eff_place[a]]) + eff_delta[a]
                if value > max_tokens:
                    return i, n, e, _TOKEN_LIMIT, i, t
                nxt[eff_place[a]] = value
            h = _hash(nxt_w)
            slot, j = _lookup(table, mask, h, nxt_w, words)
            if j < 0:
                if n >= max_markings:
                    return i, n, e, _MARKING_LIMIT, n - 1, -1
                j = n
                for k in range(n_words):
                    words[j, k] = nxt_w[k]
                hashes[j] = h
                parent[j] = i
                parent_t[j] = t
                _store(table, slot, j, h, nxt_w)
                n += 1
            src[e] = i
            dst[e] = j
            tr[e] = t
            e += 1
        i += 1
    return i, n, e, _DONE, -1, -1


@njit(cache=True)
def explore_rows(m0_words, row_template, in_ptr, in_place, in_w, eff_ptr, eff_place,
                 eff_delta, max_markings, max_tokens):  # type: ignore[no-untyped-def]
    """BFS from ``m0_words``; returns (words, parent, parent_t, src, dst, tr, status, at, t).

    ``status`` is 0 (complete), 1 (marking limit: ``at`` = last row) or 2 (token limit:
    firing ``t`` from row ``at`` would exceed ``max_tokens``).
    """
    n_words = m0_words.shape[0]
    n_trans = in_ptr.shape[0] - 1
    cap = 1024 + n_trans
    words = np.empty((cap, n_words), dtype=np.uint64)
    hashes = np.empty(cap, dtype=np.uint64)
    parent = np.empty(cap, dtype=np.int64)
    parent_t = np.empty(cap, dtype=np.int32)
    src = np.empty(4 * cap, dtype=np.int32)
    dst = np.empty(4 * cap, dtype=np.int32)
    tr = np.empty(4 * cap, dtype=np.int32)
    size = 1
    while size < 4 * cap:  # a power of two, at most 8 * cap
        size *= 2
    table = _new_table(size, n_words)
    cur = row_template.copy()
    nxt = row_template.copy()

    words[0] = m0_words
    hashes[0] = _hash(m0_words)
    parent[0] = -1
    parent_t[0] = -1
    _store(table, hashes[0] & np.uint64(size - 1), 0, hashes[0], m0_words)
    i, n, e, status, at, t = 0, 1, 0, _RUNNING, -1, -1
    while status == _RUNNING:  # each round grows some array: at most ~60 rounds
        i, n, e, status, at, t = _expand(
            i, n, e, words, hashes, parent, parent_t, src, dst, tr, table, cur, nxt,
            in_ptr, in_place, in_w, eff_ptr, eff_place, eff_delta, max_markings, max_tokens)
        if status != _RUNNING:
            break
        if n + n_trans > words.shape[0]:
            words = _grow_rows(words, n)
            hashes = _grow(hashes, n)
            parent = _grow(parent, n)
            parent_t = _grow(parent_t, n)
        if e + n_trans > src.shape[0]:
            src = _grow(src, e)
            dst = _grow(dst, e)
            tr = _grow(tr, e)
        if 2 * (n + n_trans) > table.shape[0]:
            table = _rehash(words, hashes, n, 2 * table.shape[0])
    return (words[:n].copy(), parent[:n].copy(), parent_t[:n].copy(), src[:e].copy(),
            dst[:e].copy(), tr[:e].copy(), status, at, t)
