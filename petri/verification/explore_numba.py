"""The breadth-first successor loop of :mod:`petri.verification.reachability`, compiled with numba.

Importing this module fails with ImportError when numba is missing; the caller then falls back
to :mod:`petri.verification.explore_numpy`, which numbers markings the same way.

Layout: marking ``i`` is row ``cells[i]`` of token counts (uint8, or wider when a place may hold
more than 255 tokens), padded to whole 64-bit words; ``words`` is the same memory seen as uint64,
which is how rows are hashed, compared and copied (a row's hash is computed again when the
hash table grows, rather than kept: a word per marking saved). The compiled code is cached in ``__pycache__`` (numba
``cache=True``): the first run in a fresh checkout spends several seconds compiling.
"""

# numba types these kernels when it compiles them; mypy cannot see through its decorators.
# mypy: disable-error-code="no-untyped-def,no-untyped-call,call-arg"

from __future__ import annotations

import math
import os
from typing import Any

import numpy as np
from numba import get_num_threads, njit

from petri.verification.explore_parallel import WIDE, expand_chunk, insert_chunk
from petri.verification.numba_rows import (NOT_ENABLED, OVER_TOKENS, candidates, fire_into,
                                         hash_row, lookup, new_table, prefetch, rehash, store,
                                         too_full)

# -- the search ---------------------------------------------------------------------------
# The hot loop (_expand) runs over arrays it never reallocates; when the next batch of markings
# might not fit, it returns and explore_rows, in Python, grows the arrays. Allocating in Python
# has two benefits: numpy backs big arrays with transparent huge pages (madvise), which spares
# the hash table most TLB misses, and numba does not reference-count arrays that a loop
# reassigns (that more than doubled the time per arc).

_RUNNING, _DONE, _MARKING_LIMIT, _TOKEN_LIMIT, _GROW_BATCH, _MEMORY_LIMIT = -1, 0, 1, 2, 3, 4
_BATCH = 256  # successors computed before they are looked up (see _expand)


@njit(cache=True)
def _expand(i, n, e, wide, cells, words, parent, parent_t, keep, src, dst, tr, degree, fired,
            table, batch_cells, batch, batch_h, batch_src, batch_t, cand, in_ptr, in_place,
            in_w, eff_ptr, eff_place, eff_delta, rd_ptr, rd_t, sources, max_markings,
            max_tokens):
    """Expand markings i, i+1, ... while every successor surely fits in the arrays.

    Returns (i, n, e, status, at, t): the next marking to expand, the numbers of markings and
    arcs, and _RUNNING (grow the arrays, or ``wide`` markings or more wait for the parallel
    chunks: call again), _GROW_BATCH (marking i has ``at``
    candidate successors: grow the batch to hold them) or a final status; on a limit, the
    markings before ``at`` have all their arcs recorded (see explore_rows).

    With ``keep`` the arcs are recorded in src, dst, tr; without, only each marking's number
    of successors (``degree``) and each transition's number of firings (``fired``).

    Markings are expanded a batch at a time: first the successors of a few markings are
    computed and the hash-table slot of each is prefetched, so that the processor fetches
    those slots from memory in parallel (the table is far bigger than the caches); then they
    are looked up and inserted in order, which keeps the BFS numbering.
    """
    n_words = words.shape[1]
    per_word = cells.shape[1] // n_words
    mask = np.uint64(table.shape[0] - 1)
    capacity = batch.shape[0]
    while i < n:
        if (n + capacity > words.shape[0] or (keep and e + capacity > src.shape[0])
                or too_full(n + capacity, table.shape[0]) or n - i >= wide):
            return i, n, e, _RUNNING, -1, -1
        # 1. successors of markings i, i+1, ... (whole markings only) into the batch
        b = 0
        over_at, over_t = -1, -1  # a firing that would exceed max_tokens
        while i < n and over_at < 0:
            nc = candidates(i, cells, words, per_word, rd_ptr, rd_t, sources, cand)
            if b + nc > capacity:
                if b == 0:
                    return i, n, e, _GROW_BATCH, nc, -1
                break
            for c in range(nc):
                t = cand[c]
                outcome = fire_into(i, t, cells, words, batch[b], batch_cells[b], in_ptr,
                                  in_place, in_w, eff_ptr, eff_place, eff_delta, max_tokens)
                if outcome == NOT_ENABLED:
                    continue
                if outcome == OVER_TOKENS:
                    over_at, over_t = i, t
                    break
                h = hash_row(batch[b])
                batch_h[b] = h
                batch_src[b] = i
                batch_t[b] = t
                prefetch(table, np.int64(h & mask))
                b += 1
            i += 1
        # 2. look up and insert them in order
        for s in range(b):
            row = batch[s]
            h = batch_h[s]
            slot, j = lookup(table, mask, h, row, words)
            if j < 0:
                if n >= max_markings:
                    return i, n, e, _MARKING_LIMIT, batch_src[s], -1
                j = n
                for k in range(n_words):
                    words[j, k] = row[k]
                parent[j] = batch_src[s]
                parent_t[j] = batch_t[s]
                if not keep:
                    degree[j] = 0
                store(table, slot, j, h, row)
                n += 1
            if keep:
                src[e] = batch_src[s]
                dst[e] = j
                tr[e] = batch_t[s]
            else:
                degree[batch_src[s]] += 1
                fired[batch_t[s]] += 1
            e += 1
        if over_at >= 0:  # the firings before it are recorded; stop here
            return i, n, e, _TOKEN_LIMIT, over_at, over_t
    return i, n, e, _DONE, -1, -1


@njit(cache=True)
def _start(table, cells, words, parent, parent_t, m0):
    cells[0] = m0
    h = hash_row(words[0])
    parent[0] = -1
    parent_t[0] = -1
    store(table, h & np.uint64(table.shape[0] - 1), 0, h, words[0])


# The rows are reserved up front for at most RESERVE_BYTES (and max_markings) markings: the
# memory is only taken as rows are written, and a search that stays within it never copies its
# rows to a grown array (which held two copies at once: Kanban-PT-00005 peaked 60 MB higher).
RESERVE_BYTES = 128 << 20
# Each thread's buffer of successors in a parallel chunk (explore_parallel): at most this many
# successors, and at most BUFFER_BYTES of rows (at least one marking's successors).
BUFFER_SUCCESSORS = 65536
BUFFER_BYTES = 4 << 20


# Whether to expand wide frontiers in parallel: None decides by the machine's load (see
# parallel_threads), True always (on numba's threads, even one: the tests), False never.
PARALLEL: bool | None = None


def parallel_threads() -> int:
    """The threads of the parallel phase, 0 for none.

    None when :data:`PARALLEL` is False, or is None and the machine has no idle core (1-minute load average above the cores less one
    half): every chunk waits for its slowest thread, and on a busy machine a thread can wait a
    whole time slice for a core. Kanban-PT-00005 at load 10 on 2 cores took 7-12 s of wall
    time in parallel against 5.7-7.5 s on one core, measured in alternation (issue 27); its
    parallel phase is 1.5 s of the 2.1 s of CPU, the rest is the sequential insertion.
    """
    if PARALLEL is False:
        return 0
    if PARALLEL is None:
        cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else 1
        if cores < 2 or get_num_threads() < 2 or os.getloadavg()[0] > cores - 0.5:
            return 0
    return int(get_num_threads())


class _Buffers:
    """Per-thread buffers of the parallel phase (see :mod:`petri.verification.explore_parallel`)."""

    def __init__(self, threads: int, width: int, dtype: Any, n_trans: int) -> None:
        n_words = width * np.dtype(dtype).itemsize // 8
        size = max(1, n_trans, min(BUFFER_SUCCESSORS, BUFFER_BYTES // (8 * n_words)))
        self.threads, self.size = threads, size
        self.cells = np.empty((threads, size, width), dtype=dtype)
        self.rows = self.cells.view(np.uint64)
        self.h = np.empty((threads, size), dtype=np.uint64)
        self.src = np.empty((threads, size), dtype=np.int64)
        self.t = np.empty((threads, size), dtype=np.int64)
        self.j = np.empty((threads, size), dtype=np.int64)
        self.counts = np.empty(threads, dtype=np.int64)
        self.stops = np.empty(threads, dtype=np.int64)
        self.overs = np.empty(threads, dtype=np.int64)
        self.cands = np.empty((threads, max(1, n_trans)), dtype=np.int64)

    def starts(self, i: int, n: int, e: int) -> np.ndarray:
        """The first marking of each thread's range, and the chunk's end: the markings from
        ``i`` whose successors should fit the buffers (``e`` arcs from ``i`` markings so far)."""
        per_marking = e / i if i else self.cands.shape[1]
        per_thread = max(1, int(self.size / (1.25 * max(1.0, per_marking))))
        end = min(n, i + self.threads * per_thread)
        return i + (end - i) * np.arange(self.threads + 1, dtype=np.int64) // self.threads


def _grown(a: np.ndarray, n: int, rows: int) -> np.ndarray:
    """A copy of ``a`` with at least ``rows`` rows (twice as many, or more); the first ``n``
    rows are kept."""
    size = a.shape[0]
    while size < rows:
        size *= 2
    b = np.empty((size,) + a.shape[1:], dtype=a.dtype)
    b[:n] = a[:n]
    return b


def growth_peak(n: int, e: int, slack: int, arcs: bool, cells: np.ndarray,
                parent: np.ndarray, parent_t: np.ndarray, src: np.ndarray,
                degree: np.ndarray, table: np.ndarray) -> int:
    """An upper bound of the bytes the arrays hold while explore_rows grows them for
    ``slack`` more markings and arcs: an array that grows is held with its copy, and the
    hash table is dropped before its larger successor is made."""
    per_marking = cells.nbytes + parent.nbytes + parent_t.nbytes + degree.nbytes
    held = per_marking + 3 * src.nbytes
    grow = (per_marking if n + slack > len(cells) else 0) + \
        (3 * src.nbytes if arcs and e + slack > len(src) else 0)
    peak = held + 2 * grow + table.nbytes  # the old arrays and their copies, at worst
    if too_full(n + slack, len(table)):
        size = 1 << (10 * (n + slack) // 7).bit_length()
        peak = max(peak, held + grow + size * table.shape[1] * 8)
    return peak


def explore_rows(net: Any, max_markings: int, max_tokens: int, arcs: bool = True,
                 max_bytes: float = math.inf) -> tuple:  # type: ignore[type-arg]
    """BFS from the padded row ``net.row`` of a :class:`petri.verification.reachability._Compiled` net.

    Returns (cells, parent, parent_t, src, dst, tr, status, at, t, degree, fired), where
    ``status`` is 0 (complete), 1 (marking limit: a firing from row ``at`` would make one
    marking too many), 2 (token limit: firing ``t`` from row ``at`` would exceed
    ``max_tokens``) or 4 (memory limit: growing the arrays would take the bytes held, the
    old copy included, past ``max_bytes``; the search stops before row ``at``). Either way
    the rows before ``at`` have all their arcs recorded. With
    ``arcs`` the arcs are src, dst, tr (views of larger buffers) and degree, fired are None;
    without, src, dst, tr are empty and degree (successors of each marking) and fired
    (firings of each transition) count them.

    While at least :data:`WIDE` markings wait to be expanded, and a core is idle (see
    :data:`PARALLEL`), they are expanded a chunk at a time on numba's threads
    (:mod:`petri.verification.explore_parallel`); the numbering is the same.
    """
    m0 = net.row
    n_trans = len(net.in_ptr) - 1
    capacity = _BATCH
    threads = parallel_threads()
    buffers = _Buffers(threads, len(m0), m0.dtype, n_trans) if threads else None
    slack = capacity if buffers is None else max(capacity, threads * buffers.size)
    reserve = RESERVE_BYTES if math.isinf(max_bytes) else min(RESERVE_BYTES,
                                                                 int(max_bytes) // 4)
    cap = max(1024 + 2 * slack, min(max_markings + slack, reserve // m0.nbytes))
    cells = np.empty((cap, len(m0)), dtype=m0.dtype)
    parent = np.empty(cap, dtype=np.int32)
    parent_t = np.empty(cap, dtype=np.int32)
    src, dst, tr = (np.empty(4 * (1024 + 2 * slack) if arcs else 0, dtype=np.int32)
                    for _ in range(3))
    degree = np.zeros(0 if arcs else cap, dtype=np.int32)
    fired = np.zeros(0 if arcs else max(1, n_trans), dtype=np.int64)
    n_words = cells.view(np.uint64).shape[1]
    table = new_table(1 << (4 * (1024 + 2 * slack) - 1).bit_length(), n_words)
    batch_cells = np.empty((capacity, len(m0)), dtype=m0.dtype)
    batch_h = np.empty(capacity, dtype=np.uint64)
    batch_src, batch_t = np.empty(capacity, dtype=np.int64), np.empty(capacity, dtype=np.int64)
    cand = np.empty(max(1, n_trans), dtype=np.int64)  # a marking's candidate transitions
    _start(table, cells, cells.view(np.uint64), parent, parent_t, m0)
    if not arcs:
        degree[0] = 0

    wide = WIDE if buffers is not None else 2**62
    i, n, e, status, at, t = 0, 1, 0, _RUNNING, -1, -1
    while status == _RUNNING:  # each round expands a marking or more, or grows an array
        if growth_peak(n, e, slack, arcs, cells, parent, parent_t, src, degree,
                       table) > max_bytes:
            status, at, t = _MEMORY_LIMIT, i, -1
            break
        if n + slack > len(cells):
            cells = _grown(cells, n, n + slack)
            parent, parent_t = _grown(parent, n, n + slack), _grown(parent_t, n, n + slack)
            if not arcs:
                degree = _grown(degree, n, n + slack)
        if arcs and e + slack > len(src):
            src, dst, tr = (_grown(a, e, e + slack) for a in (src, dst, tr))
        if too_full(n + slack, len(table)):
            del table  # the old table goes before the new one comes
            size = 1 << (10 * (n + slack) // 7).bit_length()
            table = new_table(size, n_words)
            rehash(table, cells.view(np.uint64), n)
        if buffers is not None and n - i >= WIDE:
            starts = buffers.starts(i, n, e)
            expand_chunk(starts, cells, cells.view(np.uint64), table, buffers.cells,
                         buffers.rows, buffers.h, buffers.src, buffers.t, buffers.j,
                         buffers.counts, buffers.stops, buffers.overs, buffers.cands,
                         net.in_ptr, net.in_place, net.in_w, net.eff_ptr, net.eff_place,
                         net.eff_delta, net.rd_ptr, net.rd_t, net.sources, max_tokens)
            i, n, e, status, at, t = insert_chunk(
                starts, n, e, cells.view(np.uint64), parent, parent_t, arcs, src, dst, tr,
                degree, fired, table, buffers.rows, buffers.h, buffers.src, buffers.t,
                buffers.j, buffers.counts, buffers.stops, buffers.overs, max_markings)
            if status == _RUNNING and i >= n:
                status = _DONE
            continue
        i, n, e, status, at, t = _expand(
            i, n, e, wide, cells, cells.view(np.uint64), parent, parent_t, arcs, src, dst, tr,
            degree, fired, table, batch_cells, batch_cells.view(np.uint64), batch_h,
            batch_src, batch_t, cand, net.in_ptr, net.in_place, net.in_w, net.eff_ptr,
            net.eff_place, net.eff_delta, net.rd_ptr, net.rd_t, net.sources, max_markings,
            max_tokens)
        if status == _GROW_BATCH:  # marking i has more candidates than the batch holds
            capacity = max(2 * capacity, at)
            slack = max(slack, capacity)
            batch_cells = np.empty((capacity, len(m0)), dtype=m0.dtype)
            batch_h = np.empty(capacity, dtype=np.uint64)
            batch_src = np.empty(capacity, dtype=np.int64)
            batch_t = np.empty(capacity, dtype=np.int64)
            status = _RUNNING
    del table
    return (cells[:n], parent[:n], parent_t[:n], src[:e], dst[:e], tr[:e], status, at, t,
            None if arcs else degree[:n], None if arcs else fired[:n_trans])
