"""The wide part of the explicit search on every core: a parallel frontier expansion.

When many markings wait to be expanded (:data:`WIDE` or more), :func:`petri.verification.
explore_numba.explore_rows` takes them a chunk at a time in two phases:

1. :func:`expand_chunk`, in parallel (numba ``prange``): the chunk is cut into one contiguous
   range of markings per thread; each thread computes the successors of its range, in marking
   and transition order, into its own buffer, hashes them and looks each up in the hash table
   of markings found so far. The table is only read in this phase.
2. :func:`insert_chunk`, on one core: the buffers are walked in thread order, that is in the
   order of the sequential search; a successor the table did not hold is looked up again
   (another successor of the chunk may have added it) and otherwise numbered and inserted.

So the markings are numbered, and the arcs and parents recorded, exactly as by the sequential
kernel; the costly lookups of markings already known (nine in ten on Kanban-PT-00005) are
shared among the cores. A thread whose buffer fills, or that meets a firing beyond the token
limit, stops at that marking; phase 2 then stops there too (the next chunk starts from it).

Importing this module fails with ImportError when numba is missing.
"""

# numba types these kernels when it compiles them; mypy cannot see through its decorators.
# mypy: disable-error-code="no-untyped-def,no-untyped-call,call-arg"

from __future__ import annotations

import numpy as np
from numba import njit, prange

from petri.verification.numba_rows import (NOT_ENABLED, OVER_TOKENS, candidates, fire_into,
                                         hash_row, lookup, prefetch, store)

WIDE = 1024  # markings waiting to be expanded from which a chunk is expanded in parallel
LAG = 32  # successors hashed (and their slots prefetched) before the first is looked up
NO_STOP = -1
# What insert_chunk returns (the codes of explore_numba and reachability).
RUNNING, MARKING_LIMIT, TOKEN_LIMIT = -1, 1, 2


@njit(cache=True, parallel=True)
def expand_chunk(starts, cells, words, table, buf_cells, buf, buf_h, buf_src, buf_t, buf_j,
                 counts, stops, overs, cands, in_ptr, in_place, in_w, eff_ptr, eff_place,
                 eff_delta, rd_ptr, rd_t, sources, max_tokens):
    """Phase 1: thread k expands markings ``starts[k]`` to ``starts[k+1] - 1`` into its buffer.

    For thread k: ``counts[k]`` successors in ``buf[k]`` (rows; ``buf_cells[k]`` the same memory
    as token counts), with their hash, source marking, transition, and ``buf_j`` the number of
    the marking when the table already held it, else -1. ``stops[k]`` is the marking it
    stopped at (NO_STOP when it finished its range) and ``overs[k]`` the transition whose
    firing from that marking exceeds ``max_tokens`` (-1: the buffer was full).
    """
    n_words = words.shape[1]
    per_word = cells.shape[1] // n_words
    mask = np.uint64(table.shape[0] - 1)
    capacity = buf.shape[1]
    for k in prange(starts.shape[0] - 1):
        b, done = 0, 0
        stop, over_t = NO_STOP, -1
        i = starts[k]
        while i < starts[k + 1] and stop == NO_STOP:
            nc = candidates(i, cells, words, per_word, rd_ptr, rd_t, sources, cands[k])
            if b + nc > capacity:
                stop = i
                break
            for c in range(nc):
                t = cands[k, c]
                outcome = fire_into(i, t, cells, words, buf[k, b], buf_cells[k, b], in_ptr,
                                  in_place, in_w, eff_ptr, eff_place, eff_delta, max_tokens)
                if outcome == NOT_ENABLED:
                    continue
                if outcome == OVER_TOKENS:
                    stop, over_t = i, t
                    break
                h = hash_row(buf[k, b])
                buf_h[k, b] = h
                buf_src[k, b] = i
                buf_t[k, b] = t
                prefetch(table, np.int64(h & mask))
                b += 1
            while done + LAG < b:  # look up what was prefetched a while ago
                buf_j[k, done] = lookup(table, mask, buf_h[k, done], buf[k, done], words)[1]
                done += 1
            i += 1
        while done < b:
            buf_j[k, done] = lookup(table, mask, buf_h[k, done], buf[k, done], words)[1]
            done += 1
        counts[k], stops[k], overs[k] = b, stop, over_t


@njit(cache=True)
def insert_chunk(starts, n, e, words, parent, parent_t, keep, src, dst, tr, degree, fired,
                 table, buf, buf_h, buf_src, buf_t, buf_j, counts, stops, overs,
                 max_markings):
    """Phase 2: number and insert the new successors in the sequential search's order.

    Returns (i, n, e, status, at, t) as :func:`petri.verification.explore_numba` ``_expand``
    does: status RUNNING (go on from marking i), MARKING_LIMIT (a firing from ``at`` would
    make one marking too many) or TOKEN_LIMIT (firing ``t`` from ``at`` exceeds the limit).
    """
    n_words = words.shape[1]
    mask = np.uint64(table.shape[0] - 1)
    for k in range(starts.shape[0] - 1):
        ahead = 0  # the next successor whose slot is to be prefetched
        for s in range(counts[k]):
            while ahead < counts[k] and ahead < s + 16:
                if buf_j[k, ahead] < 0:
                    prefetch(table, np.int64(buf_h[k, ahead] & mask))
                ahead += 1
            j = buf_j[k, s]
            if j < 0:
                row = buf[k, s]
                slot, j = lookup(table, mask, buf_h[k, s], row, words)
                if j < 0:
                    if n >= max_markings:
                        return buf_src[k, s], n, e, MARKING_LIMIT, buf_src[k, s], -1
                    j = n
                    for w in range(n_words):
                        words[j, w] = row[w]
                    parent[j] = buf_src[k, s]
                    parent_t[j] = buf_t[k, s]
                    if not keep:
                        degree[j] = 0
                    store(table, slot, j, buf_h[k, s], row)
                    n += 1
            if keep:
                src[e] = buf_src[k, s]
                dst[e] = j
                tr[e] = buf_t[k, s]
            else:
                degree[buf_src[k, s]] += 1
                fired[buf_t[k, s]] += 1
            e += 1
        if stops[k] != NO_STOP:
            if overs[k] >= 0:
                return stops[k], n, e, TOKEN_LIMIT, stops[k], overs[k]
            return stops[k], n, e, RUNNING, -1, -1
    return starts[-1], n, e, RUNNING, -1, -1
