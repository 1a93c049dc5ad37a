"""The breadth-first search of :mod:`petri.verification.reachability` with each marking packed
into one 64-bit word (:mod:`petri.verification.packed_words`): plain numpy, no compiler, both
cores. What ``auto`` takes for a search without its arcs (``mclc NET.pnml``'s), or any when numba
is missing, whose markings fit.

A level at a time: the frontier's words, sorted, are cut into slices of at most
:data:`SLICE_ROWS`; each slice fires every transition at once, merges its successors into
distinct sorted words and looks them up among the visited words (sorted, ``np.searchsorted``).
With two cores (and one idle, see :func:`threads`) two slices are expanded at a time, on two
threads: numpy releases the interpreter's lock in all of a slice's work. The slices' new words
are then merged, each with the first firing that found it, and numbered in the order the
sequential search finds them (by source marking, then transition), so the numbering, the arcs
and the parents are exactly those of :mod:`petri.verification.explore_numpy` and of the numba
kernel. They are merged into the visited words in place (:func:`merge_sorted`).

Fields start with the bits of the net's largest initial count (each place's own count's if
those do not fit) and are widened when a firing would overflow one (the search then repacks
what it holds and expands the level again), up to the bits of ``max_tokens``; past that the
firing is over the token limit. (On FMS-PT-00005, 22 places bounded by 1 to 5 tokens, eight
widenings, where widening one bit at a time took fourteen and 1.4 s more of CPU.) When the fields no longer fit in
64 bits the search gives up (None) and the caller takes another engine, so a widening never
loses a marking.

What it holds per marking: its word twice (sorted, and by number: 16 bytes), its parent and
the transition from it, its number of successors (12), and its row of token counts, made from
the words by number once the sorted ones are dropped. On Kanban-PT-00005 (2,546,432 markings,
24,460,016 arcs, 16 places) ``mclc`` peaks at 129 MB of resident memory, 1.79 times the C
peer's (bench/peers/bfs.c), in 0.44 times its CPU time (``make bench``, load 5.3 on 2 cores).
"""

from __future__ import annotations

import ctypes
import math
import os
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from typing import Any

import numpy as np
import numpy.typing as npt

from petri.verification.packed_words import (WORD_BITS, Array, Ints, Packing, Rules, Slice,
                                             Words, distinct, expand_slice, first_packing,
                                             groups, rules, widened)

_DONE, _MARKING_LIMIT, _TOKEN_LIMIT, _MEMORY_LIMIT = 0, 1, 2, 4
SLICE_ROWS = 1 << 13  # frontier markings expanded at a time (at most a thread's share of a level)
UNPACK_ROWS = 1 << 16  # markings unpacked at a time at the end
ARC_BYTES = 12 * 2  # an arc (three int32), and its copy when the level's arcs are joined

# -- the search -------------------------------------------------------------------------------

# Whether to expand a level's slices on two threads: None decides by the machine (two cores or
# more, and one idle: see threads), True always, False never.
PARALLEL: bool | None = None
# The per-marking arrays are reserved for at most this many bytes (and max_markings markings)
# up front: memory is only taken as they are written, and a search that stays within them
# never holds an array and its grown copy at once.
RESERVE_BYTES = 256 << 20
MERGE_ROWS = 1 << 16  # visited markings moved at a time when a level is merged in
MERGE_CANDIDATES = 1 << 20  # a level's new markings waiting before they are merged


def release_freed_memory() -> None:
    """Give the memory freed in the C heap back to the system (glibc's ``malloc_trim``;
    nothing elsewhere). glibc keeps what a level's work arrays took once they are freed (up
    to 64 MiB at the heap's top), to serve the next level; the search calls this when its
    levels have shrunk, and before the markings are unpacked: on Kanban-PT-00005 (in one
    process, one thread) the peak resident memory is 125-127 MB with it, 140 MB without, for
    the same CPU time."""
    try:
        trim = ctypes.CDLL(None).malloc_trim
    except (OSError, AttributeError, TypeError):  # no such C library (TypeError: Windows')
        return
    trim.argtypes = [ctypes.c_size_t]
    trim(0)


def threads() -> int:
    """The threads a level's slices are expanded on: 2 when :data:`PARALLEL` is True, or is
    None and the machine has two cores and the 1-minute load average leaves one idle; else 1."""
    if PARALLEL is not None:
        return 2 if PARALLEL else 1
    cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else 1
    return 2 if cores >= 2 and os.getloadavg()[0] <= cores - 0.5 else 1


@dataclass
class Search:
    """What the search holds for its ``n`` markings: their words, sorted (``visited``), with
    the number of each when arcs are kept (``numbers``); by number, each one's word
    (``words``: unpacked at the end, when ``visited`` is no longer held), parent and
    transition from it, and number of successors (``degree``, when the arcs are not kept:
    then ``fired`` counts each transition's firings); the arcs found so far, a level at a
    time."""

    packing: Packing
    rule: Rules
    visited: Words
    numbers: npt.NDArray[np.int32] | None
    words: Words
    parent: npt.NDArray[np.int32]
    parent_t: npt.NDArray[np.int32]
    degree: npt.NDArray[np.int32] | None
    fired: Ints
    arcs: list[tuple[npt.NDArray[np.int32], ...]]
    n: int = 1

    def held(self, n: int, row_bytes: int) -> int:
        """The bytes held for ``n`` markings and the arcs found, at the end (when each
        marking's word is unpacked into ``row_bytes``) or before, whichever is more."""
        per = sum(a.itemsize for a in (self.visited, self.numbers, self.words, self.parent,
                                        self.parent_t, self.degree) if a is not None)
        per += max(0, row_bytes - self.visited.itemsize)
        return n * per + sum(len(a[0]) for a in self.arcs) * ARC_BYTES

    def grow(self, n: int) -> None:
        """Room for ``n`` markings in the per-marking arrays (twice as many, if they grow)."""
        size = len(self.parent)
        if n <= size:
            return
        while size < n:
            size *= 2
        for name in ("visited", "numbers", "words", "parent", "parent_t", "degree"):
            old = getattr(self, name)
            if old is not None:
                new = np.zeros((size,) + old.shape[1:], dtype=old.dtype)
                new[: self.n] = old[: self.n]
                setattr(self, name, new)


def explore_rows(net: Any, max_markings: int, max_tokens: int, arcs: bool = True,
                 max_bytes: float = math.inf) -> tuple[Any, ...] | None:
    """Same contract as :func:`petri.verification.explore_numba.explore_rows` (the markings'
    rows are ``len(net.row)`` cells wide), or None when the markings do not fit one 64-bit
    word: the caller then takes another engine. Before a level's new markings are numbered,
    the bytes the search would then hold are estimated; past ``max_bytes`` it stops before the
    level, with status 4 (memory limit)."""
    top = max(1, int(max_tokens).bit_length())
    packing = first_packing(net, top)
    if packing.width > WORD_BITS:
        return None
    search = _start(net, packing, max_markings, max_tokens, top, arcs)
    frontier, ids = search.visited[:1].copy(), np.zeros(1, dtype=np.int64)
    lo = busiest = 0  # busiest: the widest level since memory was last released
    status, at, stop_t = _DONE, -1, -1
    pool = ThreadPoolExecutor(2) if threads() > 1 else None
    try:
        while len(frontier):
            small = len(frontier) * search.rule.n_trans < 2**31  # orders fit int32
            rel: Ints = (ids - lo).astype(np.int32 if small else np.int64)
            slices = _expand_level(search, frontier, rel, pool, max_bytes,
                                   len(net.row) * net.row.itemsize)
            if slices is None:
                status, at = _MEMORY_LIMIT, lo
                break
            need = {p: k for s in slices for p, k in s.need.items()}
            if need:  # a field overflowed: widen it, repack, expand the level again
                hint = max(int(x) for x in net.row).bit_length()  # the largest initial count
                wider = widened(search.packing, need, top, hint)
                if wider.width > WORD_BITS:
                    return None
                _repack(search, wider)
                search.rule = rules(net, wider, max_tokens, top)
                order = np.argsort(search.packing.repack(frontier, wider))
                frontier, ids = search.packing.repack(frontier, wider)[order], ids[order]
                search.packing = wider
                continue
            step = _number_level(search, slices, lo, max_markings, max_bytes,
                                 len(net.row) * net.row.itemsize)
            if step is None:
                status, at = _MEMORY_LIMIT, lo
                break
            lo += len(frontier)
            work = sum(len(s.rel) for s in slices)
            if 2 * work < busiest:  # the levels shrink: return what the busiest one took
                release_freed_memory()
                busiest = work
            busiest = max(busiest, work)
            frontier, ids, status, at, stop_t = step
            if status != _DONE:
                break
    finally:
        if pool is not None:
            pool.shutdown()
    return _result(net, search, status, at, stop_t)


def _start(net: Any, packing: Packing, max_markings: int, max_tokens: int, top: int,
           arcs: bool) -> Search:
    """The search with the initial marking numbered 0."""
    per = 8 + 4 * arcs + 8 + 8 + 4 * (not arcs)
    reserve = max(1024, min(max_markings, RESERVE_BYTES // per))

    def ints() -> npt.NDArray[np.int32]:
        return np.zeros(reserve, dtype=np.int32)

    search = Search(packing, rules(net, packing, max_tokens, top),
                    np.zeros(reserve, dtype=np.uint64), ints() if arcs else None,
                    np.zeros(reserve, dtype=np.uint64), ints(), ints(),
                    None if arcs else ints(), np.zeros(len(net.in_ptr) - 1, np.int64), [])
    search.visited[0] = packing.pack(net.row)
    search.words[0] = search.visited[0]
    search.parent[0] = search.parent_t[0] = -1
    return search


def _expand_level(search: Search, frontier: Words, rel: Ints, pool: ThreadPoolExecutor | None,
                  max_bytes: float, row_bytes: int) -> list[Slice] | None:
    """The level's slices, expanded in frontier order (two at a time on the pool's threads
    if any), or None when what they found would take the search past ``max_bytes``.

    Without the arcs, the slices' new markings are merged into distinct ones (into the first
    slice's keys) whenever those waiting outnumber :data:`MERGE_CANDIDATES` and the merged
    ones: a wide level holds about its new markings, not every firing that finds them (on a
    level of 28 two-state cycles, 21 firings find each)."""
    rows = SLICE_ROWS
    if pool is not None:  # at least two slices on a wide level, so both threads work
        rows = max(1024, min(rows, -(-len(frontier) // 2)))
    cuts = range(0, len(frontier), rows)
    n = search.n
    numbers = None if search.numbers is None else search.numbers[:n]

    def one(a: int) -> Slice:
        return expand_slice(frontier[a:a + rows], rel[a:a + rows], search.rule,
                            search.packing, search.visited[:n], numbers)

    width = 1 if pool is None else 2
    slices: list[Slice] = []
    merged = waiting = 0  # new markings in the first slice's keys, and in the others'
    for k in range(0, len(cuts), width):
        batch = cuts[k:k + width]
        slices += [one(a) for a in batch] if len(batch) < 2 or pool is None else \
            list(pool.map(one, batch))
        if any(s.need for s in slices[-len(batch):]):
            return slices  # the caller widens the fields and expands the level again
        waiting += sum(len(s.keys) for s in slices[-len(batch):])
        if numbers is None and waiting > max(MERGE_CANDIDATES, merged):
            first = slices[0]
            first.keys, first.order = distinct(np.concatenate([s.keys for s in slices]),
                                               np.concatenate([s.order for s in slices]))[:2]
            for s in slices[1:]:
                s.keys, s.order = first.keys[:0], first.order[:0]
            merged, waiting = len(first.keys), 0
        found = sum(s.keys.nbytes + s.order.nbytes for s in slices) + sum(
            s.arc_order.nbytes + s.arc_target.nbytes for s in slices
            if s.arc_order is not None and s.arc_target is not None)
        if search.held(n + merged + waiting, row_bytes) + 3 * found > max_bytes:
            return None
    return slices


def _repack(search: Search, wider: Packing) -> None:
    """The words packed by ``wider``, the visited ones sorted again (with their numbers)."""
    n = search.n
    search.words[:n] = search.packing.repack(search.words[:n], wider)
    words = search.packing.repack(search.visited[:n], wider)
    order = np.argsort(words)
    search.visited[:n] = words[order]
    if search.numbers is not None:
        search.numbers[:n] = search.numbers[:n][order]


def merge_sorted(keys: Words, n: int, new: Words, along: list[tuple[Array, Array]]) -> None:
    """Put the sorted words ``new`` (none among ``keys[:n]``, sorted) in their places among
    ``keys[:n]``, in place (``keys`` has room for them), moving each array ``a`` of
    ``along`` with its values ``v`` for the new words in the same way. The words above the
    first new one move up, a block at a time from the top: no copy of the arrays."""
    if not len(new):
        return
    pos = np.searchsorted(keys[:n], new)  # where each goes, among the old words
    hi, first = n, int(pos[0])
    while hi > first:  # old word i moves up by the new words before it: (pos <= i).sum()
        lo = max(first, hi - MERGE_ROWS)
        below, upto = np.searchsorted(pos, [lo, hi])  # the new words before lo, before hi
        count = np.bincount(pos[below:upto] - lo, minlength=hi - lo)
        dest = np.arange(lo, hi) + below + np.cumsum(count)
        keys[dest] = keys[lo:hi]
        for a, _ in along:
            a[dest] = a[lo:hi]
        hi = lo
    at = pos + np.arange(len(new))
    keys[at] = new
    for a, values in along:
        a[at] = values


def _number_level(search: Search, slices: list[Slice], lo: int, max_markings: int,
                  max_bytes: float, row_bytes: int) -> tuple[Any, ...] | None:
    """Number the level's new markings in the order the sequential search finds them, record
    the firings up to the first one a limit stops, and merge the new markings into the
    visited ones. (next frontier, its numbers, status, at, t), or None when the markings
    would take the search past ``max_bytes``."""
    n_trans, n = search.rule.n_trans, search.n
    keys = np.concatenate([s.keys for s in slices])  # a sorted run per slice
    order = np.concatenate([s.order for s in slices])
    bases = np.cumsum([0] + [len(s.keys) for s in slices])  # where each slice's keys begin
    for s in slices:  # held once, not twice
        s.keys, s.order = keys[:0], order[:0]
    unique, found, by_key, first = distinct(keys, order)
    del keys, order
    rank = np.argsort(found, kind="stable")  # the new markings in discovery order
    over = min((s.over for s in slices if s.over >= 0), default=-1)
    stop = over if over >= 0 else n_trans * sum(len(s.rel) for s in slices)  # none
    cut = int(np.searchsorted(found[rank], stop))
    status, at, stop_t = (_TOKEN_LIMIT, lo + over // n_trans, over % n_trans) if over >= 0 \
        else (_DONE, -1, -1)
    if n + cut > max_markings:
        cut = max_markings - n
        stop = int(found[rank[cut]])
        status, at, stop_t = _MARKING_LIMIT, lo + stop // n_trans, -1
    work = len(by_key) * 24 + sum(s.fires.size for s in slices)
    if search.held(n + cut, row_bytes) + work > max_bytes:
        return None
    new = rank[:cut]
    search.grow(n + cut)
    discovered = found[new]
    search.parent[n:n + cut] = lo + discovered // n_trans
    search.parent_t[n:n + cut] = discovered % n_trans
    search.words[n:n + cut] = unique[new]
    ids = np.full(len(unique), -1, dtype=np.int64)
    ids[new] = n + np.arange(cut)
    if search.numbers is not None:
        _record_arcs(search, slices, bases, ids[groups(by_key, first)], lo, stop)
    else:
        _count_firings(search, slices, lo, stop)
    del by_key, first
    new.sort()  # back in key order: the next frontier, sorted
    frontier, ids = unique[new], ids[new]
    merge_sorted(search.visited, n, frontier, [] if search.numbers is None else
                 [(search.numbers, ids.astype(np.int32))])
    search.n += cut
    return frontier, ids, status, at, stop_t


def _count_firings(search: Search, slices: list[Slice], lo: int, stop: int) -> None:
    """Each frontier marking's number of successors and each transition's firings, those
    before ``stop`` (in the sequential order) only."""
    assert search.degree is not None
    n_trans = search.rule.n_trans
    for s in slices:
        if s.rel.size and (int(s.rel.max()) + 1) * n_trans <= stop:  # all of them
            search.degree[lo + s.rel] = s.fires.sum(axis=0)
            search.fired += s.fires.sum(axis=1)
            continue
        t_of, r_of = np.nonzero(s.fires)
        rel = s.rel[r_of].astype(np.int64)
        kept = rel * n_trans + t_of < stop
        search.degree[lo + s.rel] = 0
        np.add.at(search.degree, lo + rel[kept], 1)
        search.fired += np.bincount(t_of[kept], minlength=n_trans)


def _record_arcs(search: Search, slices: list[Slice], bases: Ints, number: Ints, lo: int,
                 stop: int) -> None:
    """The level's arcs before ``stop``, in the sequential order (``number``: the number of
    each slice's new successors, slice k's from ``bases[k]``)."""
    n_trans = search.rule.n_trans
    orders, targets = [], []
    for s, base in zip(slices, bases):
        assert s.arc_order is not None and s.arc_target is not None
        target = s.arc_target
        new = target < 0
        target[new] = number[base - 1 - target[new]]
        orders.append(s.arc_order)
        targets.append(target)
    order, target = np.concatenate(orders), np.concatenate(targets)
    kept = np.flatnonzero(order < stop)
    kept = kept[np.argsort(order[kept])]
    arc = order[kept].astype(np.int64)
    search.arcs.append(((lo + arc // n_trans).astype(np.int32), target[kept].astype(np.int32),
                        (arc % n_trans).astype(np.int32)))


def _result(net: Any, search: Search, status: int, at: int, stop_t: int) -> tuple[Any, ...]:
    """The contract's tuple, the markings unpacked."""
    n = search.n
    search.visited = search.visited[:0].copy()  # no longer needed: its memory goes first
    search.numbers = None
    release_freed_memory()
    cells = np.empty((n, len(net.row)), dtype=net.row.dtype)
    for a in range(0, n, UNPACK_ROWS):  # a block at a time: no temporary of n words
        b = min(n, a + UNPACK_ROWS)
        cells[a:b] = search.packing.unpack(search.words[a:b], net.row.dtype)
    search.words = search.words[:0].copy()
    if search.degree is None:
        src, dst, tr = (np.concatenate([a[k] for a in search.arcs]) if search.arcs
                        else np.zeros(0, dtype=np.int32) for k in range(3))
        degree = fired = None
    else:
        src = dst = tr = np.zeros(0, dtype=np.int32)
        degree, fired = search.degree[:n], search.fired
    return (cells, search.parent[:n], search.parent_t[:n], src, dst, tr, status,
            at, stop_t, degree, fired)
