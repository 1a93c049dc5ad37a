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
from typing import Any

import numpy as np
from llvmlite import ir
from numba import njit, types
from numba.core import cgutils
from numba.extending import intrinsic

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


@intrinsic
def _prefetch(typingctx, table, row):
    """Ask the processor to start loading ``table[row, 0]`` into the cache (LLVM's
    ``llvm.prefetch``: read, high locality, data cache) and go on without waiting for it.

    numba has no prefetch of its own; a plain read would make the loop wait for the value.
    """
    if not (isinstance(table, types.Array) and table.ndim == 2):
        return None

    def codegen(context, builder, signature, args):
        array_type, _ = signature.args
        array = context.make_array(array_type)(context, builder, args[0])
        zero = context.get_constant(types.intp, 0)
        pointer = cgutils.get_item_pointer(context, builder, array_type, array,
                                           [args[1], zero])
        byte_pointer = ir.IntType(8).as_pointer()
        i32 = ir.IntType(32)
        function = cgutils.get_or_insert_function(
            builder.module, ir.FunctionType(ir.VoidType(), [byte_pointer, i32, i32, i32]),
            "llvm.prefetch.p0")
        builder.call(function, [builder.bitcast(pointer, byte_pointer), i32(0), i32(3),
                                i32(1)])
        return context.get_dummy_value()

    return types.void(table, types.intp), codegen


# -- the hash table ---------------------------------------------------------------------
# Two layouts, chosen by row width. Small rows (at most _INLINE_WORDS words) are stored in the
# table itself, so a lookup touches one cache line: table[slot] = [row number + 1, words...].
# Wider rows would make the table too big; then table[slot, 0] = (high 32 bits of the hash)
# << 32 | (row number + 1), and a matching fingerprint is confirmed against words[row].
# In both layouts 0 in column 0 means an empty slot. The table is kept at most 70% full
# (_full), so every probe sequence ends at an empty slot.

_INLINE_WORDS = 4
_LOW32 = np.uint64(0xFFFFFFFF)


@njit(cache=True, inline="always")
def _lookup(table, mask, h, row, words):
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
def _store(table, slot, j, h, row):
    if table.shape[1] > 1:
        table[slot, 0] = np.uint64(j + 1)
        for k in range(row.shape[0]):
            table[slot, k + 1] = row[k]
    else:
        table[slot, 0] = ((h >> np.uint64(32)) << np.uint64(32)) | np.uint64(j + 1)


@njit(cache=True, inline="always")
def _full(rows, size):
    """Whether a table of ``size`` slots is too small for ``rows`` rows (load above 0.7)."""
    return 10 * rows > 7 * size


def _new_table(size: int, n_words: int) -> np.ndarray:
    width = n_words + 1 if n_words <= _INLINE_WORDS else 1
    return np.zeros((size, width), dtype=np.uint64)


@njit(cache=True)
def _rehash(table, words, n):
    """Insert rows 0..n-1 into the empty ``table``."""
    mask = np.uint64(table.shape[0] - 1)
    for i in range(n):
        h = _hash(words[i])
        slot = h & mask
        while table[slot, 0] != 0:  # never full: a free slot exists
            slot = (slot + np.uint64(1)) & mask
        _store(table, slot, i, h, words[i])


# -- the search ---------------------------------------------------------------------------
# The hot loop (_expand) runs over arrays it never reallocates; when the next batch of markings
# might not fit, it returns and explore_rows, in Python, grows the arrays. Allocating in Python
# has two benefits: numpy backs big arrays with transparent huge pages (madvise), which spares
# the hash table most TLB misses, and numba does not reference-count arrays that a loop
# reassigns (that more than doubled the time per arc).

_RUNNING, _DONE, _MARKING_LIMIT, _TOKEN_LIMIT, _GROW_BATCH, _MEMORY_LIMIT = -1, 0, 1, 2, 3, 4
_BATCH = 256  # successors computed before they are looked up (see _expand)
_SORT_BELOW = 24  # candidate lists shorter than this are insertion-sorted


@njit(cache=True, inline="always")
def _candidates(i, cells, words, per_word, rd_ptr, rd_t, sources, cand):
    """The transitions that may be enabled at marking ``i`` (those whose first input is
    marked, and those without inputs) into ``cand``, in increasing order; their number.

    Only the non-zero words of the row are looked into, so the cost is that of scanning the
    row plus the transitions indexed under its marked places, not of every transition."""
    nc = 0
    for w in range(words.shape[1]):
        if words[i, w] == 0:
            continue
        for k in range(w * per_word, (w + 1) * per_word):
            if cells[i, k] != 0:
                for r in range(rd_ptr[k], rd_ptr[k + 1]):
                    cand[nc] = rd_t[r]
                    nc += 1
    for r in range(sources.shape[0]):
        cand[nc] = sources[r]
        nc += 1
    if nc < _SORT_BELOW:  # the successors in transition order (the BFS numbering)
        for a in range(1, nc):
            x = cand[a]
            b = a - 1
            while b >= 0 and cand[b] > x:
                cand[b + 1] = cand[b]
                b -= 1
            cand[b + 1] = x
    else:
        cand[:nc] = np.sort(cand[:nc])
    return nc


@njit(cache=True)
def _expand(i, n, e, cells, words, parent, parent_t, keep, src, dst, tr, degree, fired,
            table, batch_cells, batch, batch_h, batch_src, batch_t, cand, in_ptr, in_place,
            in_w, eff_ptr, eff_place, eff_delta, rd_ptr, rd_t, sources, max_markings,
            max_tokens):
    """Expand markings i, i+1, ... while every successor surely fits in the arrays.

    Returns (i, n, e, status, at, t): the next marking to expand, the numbers of markings and
    arcs, and _RUNNING (grow the arrays and call again), _GROW_BATCH (marking i has ``at``
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
                or _full(n + capacity, table.shape[0])):
            return i, n, e, _RUNNING, -1, -1
        # 1. successors of markings i, i+1, ... (whole markings only) into the batch
        b = 0
        over_at, over_t = -1, -1  # a firing that would exceed max_tokens
        while i < n and over_at < 0:
            nc = _candidates(i, cells, words, per_word, rd_ptr, rd_t, sources, cand)
            if b + nc > capacity:
                if b == 0:
                    return i, n, e, _GROW_BATCH, nc, -1
                break
            for c in range(nc):
                t = cand[c]
                enabled = True
                for a in range(in_ptr[t], in_ptr[t + 1]):
                    if cells[i, in_place[a]] < in_w[a]:
                        enabled = False
                        break
                if not enabled:
                    continue
                for k in range(n_words):
                    batch[b, k] = words[i, k]
                for a in range(eff_ptr[t], eff_ptr[t + 1]):
                    value = np.int64(cells[i, eff_place[a]]) + eff_delta[a]
                    if value > max_tokens:
                        over_at, over_t = i, t
                    batch_cells[b, eff_place[a]] = value
                if over_at >= 0:
                    break
                h = _hash(batch[b])
                batch_h[b] = h
                batch_src[b] = i
                batch_t[b] = t
                _prefetch(table, np.int64(h & mask))
                b += 1
            i += 1
        # 2. look up and insert them in order
        for s in range(b):
            row = batch[s]
            h = batch_h[s]
            slot, j = _lookup(table, mask, h, row, words)
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
                _store(table, slot, j, h, row)
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
    h = _hash(words[0])
    parent[0] = -1
    parent_t[0] = -1
    _store(table, h & np.uint64(table.shape[0] - 1), 0, h, words[0])


def _growth_peak(n: int, e: int, capacity: int, arcs: bool, cells: np.ndarray,
                 parent: np.ndarray, parent_t: np.ndarray, src: np.ndarray,
                 degree: np.ndarray, table: np.ndarray) -> int:
    """An upper bound of the bytes the arrays hold while explore_rows grows them for
    ``capacity`` more markings and arcs: an array that doubles is held with its copy, and
    the hash table is dropped before its larger successor is made."""
    per_marking = cells.nbytes + parent.nbytes + parent_t.nbytes + degree.nbytes
    held = per_marking + 3 * src.nbytes
    grow = (per_marking if n + capacity > len(cells) else 0) + \
        (3 * src.nbytes if arcs and e + capacity > len(src) else 0)
    peak = held + 2 * grow + table.nbytes  # the old arrays and their doubles, at worst
    if _full(n + capacity, len(table)):
        size = 1 << (10 * (n + capacity) // 7).bit_length()
        peak = max(peak, held + grow + size * table.shape[1] * 8)
    return peak


def _grown(a: np.ndarray, n: int) -> np.ndarray:
    """A copy of ``a`` with twice the rows; the first ``n`` rows are kept."""
    b = np.empty((2 * a.shape[0],) + a.shape[1:], dtype=a.dtype)
    b[:n] = a[:n]
    return b


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
    """
    m0 = net.row
    n_trans = len(net.in_ptr) - 1
    capacity = _BATCH
    cap = 1024 + 2 * capacity
    cells = np.empty((cap, len(m0)), dtype=m0.dtype)
    parent = np.empty(cap, dtype=np.int32)
    parent_t = np.empty(cap, dtype=np.int32)
    src, dst, tr = (np.empty(4 * cap if arcs else 0, dtype=np.int32) for _ in range(3))
    degree = np.zeros(0 if arcs else cap, dtype=np.int32)
    fired = np.zeros(0 if arcs else max(1, n_trans), dtype=np.int64)
    n_words = cells.view(np.uint64).shape[1]
    table = _new_table(1 << (4 * cap - 1).bit_length(), n_words)  # a power of two
    batch_cells = np.empty((capacity, len(m0)), dtype=m0.dtype)
    batch_h = np.empty(capacity, dtype=np.uint64)
    batch_src, batch_t = np.empty(capacity, dtype=np.int64), np.empty(capacity, dtype=np.int64)
    cand = np.empty(max(1, n_trans), dtype=np.int64)  # a marking's candidate transitions
    _start(table, cells, cells.view(np.uint64), parent, parent_t, m0)
    if not arcs:
        degree[0] = 0

    i, n, e, status, at, t = 0, 1, 0, _RUNNING, -1, -1
    for _ in range(400):  # each round doubles an array; 2**200 is beyond any memory
        i, n, e, status, at, t = _expand(
            i, n, e, cells, cells.view(np.uint64), parent, parent_t, arcs, src, dst, tr,
            degree, fired, table, batch_cells, batch_cells.view(np.uint64), batch_h,
            batch_src, batch_t, cand, net.in_ptr, net.in_place, net.in_w, net.eff_ptr,
            net.eff_place, net.eff_delta, net.rd_ptr, net.rd_t, net.sources, max_markings,
            max_tokens)
        if status == _GROW_BATCH:  # marking i has more candidates than the batch holds
            capacity = max(2 * capacity, at)
            batch_cells = np.empty((capacity, len(m0)), dtype=m0.dtype)
            batch_h = np.empty(capacity, dtype=np.uint64)
            batch_src = np.empty(capacity, dtype=np.int64)
            batch_t = np.empty(capacity, dtype=np.int64)
            status = _RUNNING
            continue
        if status != _RUNNING:
            break
        if _growth_peak(n, e, capacity, arcs, cells, parent, parent_t, src, degree,
                        table) > max_bytes:
            status, at, t = _MEMORY_LIMIT, i, -1
            break
        if n + capacity > len(cells):
            cells = _grown(cells, n)
            parent, parent_t = _grown(parent, n), _grown(parent_t, n)
            if not arcs:
                degree = _grown(degree, n)
        if arcs and e + capacity > len(src):
            src, dst, tr = _grown(src, e), _grown(dst, e), _grown(tr, e)
        if _full(n + capacity, len(table)):
            del table  # the old table goes before the new one comes
            size = 1 << (10 * (n + capacity) // 7).bit_length()
            table = _new_table(size, n_words)
            _rehash(table, cells.view(np.uint64), n)
    del table
    return (cells[:n], parent[:n], parent_t[:n], src[:e], dst[:e], tr[:e], status, at, t,
            None if arcs else degree[:n], None if arcs else fired[:n_trans])
