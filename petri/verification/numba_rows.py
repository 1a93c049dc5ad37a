"""Markings as rows of 64-bit words, for the numba kernels of the explicit search
(:mod:`petri.verification.explore_numba`, :mod:`petri.verification.explore_parallel`): the hash
of a row, the open-addressing hash table of rows seen, and the candidate transitions of a row.

Importing this module fails with ImportError when numba is missing.
"""

# numba types these kernels when it compiles them; mypy cannot see through its decorators.
# mypy: disable-error-code="no-untyped-def,no-untyped-call,call-arg"

from __future__ import annotations

import numpy as np
from llvmlite import ir
from numba import njit, types
from numba.core import cgutils
from numba.extending import intrinsic

_C1 = np.uint64(0x9E3779B97F4A7C15)  # golden-ratio multiplier
_C2 = np.uint64(0xBF58476D1CE4E5B9)  # splitmix64 finaliser constants
_C3 = np.uint64(0x94D049BB133111EB)


@njit(cache=True, inline="always")
def hash_row(row: np.ndarray) -> np.uint64:
    """Hash of a row of words: multiply-xor per word, then the splitmix64 finaliser."""
    h = np.uint64(len(row))
    for k in range(len(row)):
        h = (h ^ row[k]) * _C1
        h ^= h >> np.uint64(29)
    h = (h ^ (h >> np.uint64(30))) * _C2
    h = (h ^ (h >> np.uint64(27))) * _C3
    return h ^ (h >> np.uint64(31))


@intrinsic
def prefetch(typingctx, table, row):
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
# Two layouts, chosen by row width. Small rows (at most INLINE_WORDS words) are stored in the
# table itself, so a lookup touches one cache line: table[slot] = [row number + 1, words...].
# Otherwise table[slot, 0] = (high 32 bits of the hash) << 32 | (row number + 1), and a
# matching fingerprint is confirmed against words[row].
# In both layouts 0 in column 0 means an empty slot. The table is kept at most 70% full
# (too_full), so every probe sequence ends at an empty slot.
# The inline layout is not used (INLINE_WORDS = 0): on Kanban-PT-00005 (rows of two words) the
# fingerprint table is a third of the size (32 MB instead of 100) and the search took 1.8-2.0 s
# of CPU instead of 2.2-2.4 s (issue 27): a smaller table misses the caches and the TLB less,
# and a row that matches was often written recently.

INLINE_WORDS = 0
_LOW32 = np.uint64(0xFFFFFFFF)


@njit(cache=True, inline="always")
def lookup(table, mask, h, row, words):
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
def store(table, slot, j, h, row):
    if table.shape[1] > 1:
        table[slot, 0] = np.uint64(j + 1)
        for k in range(row.shape[0]):
            table[slot, k + 1] = row[k]
    else:
        table[slot, 0] = ((h >> np.uint64(32)) << np.uint64(32)) | np.uint64(j + 1)


@njit(cache=True, inline="always")
def too_full(rows, size):
    """Whether a table of ``size`` slots is too small for ``rows`` rows (load above 0.7)."""
    return 10 * rows > 7 * size


def new_table(size: int, n_words: int) -> np.ndarray:
    width = n_words + 1 if n_words <= INLINE_WORDS else 1
    return np.zeros((size, width), dtype=np.uint64)


@njit(cache=True)
def rehash(table, words, n):
    """Insert rows 0..n-1 into the empty ``table``."""
    mask = np.uint64(table.shape[0] - 1)
    for i in range(n):
        h = hash_row(words[i])
        slot = h & mask
        while table[slot, 0] != 0:  # never full: a free slot exists
            slot = (slot + np.uint64(1)) & mask
        store(table, slot, i, h, words[i])



SORT_BELOW = 24  # candidate lists shorter than this are insertion-sorted


@njit(cache=True, inline="always")
def candidates(i, cells, words, per_word, rd_ptr, rd_t, sources, cand):
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
    if nc < SORT_BELOW:  # the successors in transition order (the BFS numbering)
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


# What fire_into says of a transition at a marking.
NOT_ENABLED, FIRED, OVER_TOKENS = 0, 1, 2


@njit(cache=True, inline="always")
def fire_into(i, t, cells, words, row, row_cells, in_ptr, in_place, in_w, eff_ptr, eff_place,
              eff_delta, max_tokens):
    """Marking ``i``'s successor by transition ``t`` into ``row`` (its words; ``row_cells``
    the same memory as token counts): NOT_ENABLED (nothing written), FIRED, or OVER_TOKENS
    (written, but some place would hold more than ``max_tokens``). The one firing rule of
    both the sequential and the parallel search."""
    for a in range(in_ptr[t], in_ptr[t + 1]):
        if cells[i, in_place[a]] < in_w[a]:
            return NOT_ENABLED
    for w in range(words.shape[1]):
        row[w] = words[i, w]
    fired = FIRED
    for a in range(eff_ptr[t], eff_ptr[t + 1]):
        value = np.int64(cells[i, eff_place[a]]) + eff_delta[a]
        if value > max_tokens:
            fired = OVER_TOKENS
        row_cells[eff_place[a]] = value
    return fired
