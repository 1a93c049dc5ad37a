"""Reachability of safe nets without a compiler: the engine for mission nets, which are
1-safe, where a marking has a handful of tokens among hundreds or thousands of places, and where
starting numba would cost more than the search itself.

A marking is an integer with one bit per place on nets of at most :data:`WIDE` places (an
operation costs a few machine words), and the frozenset of its marked places on wider ones (an
operation costs the number of tokens, not of places). A transition is looked up by its most
selective input place (:func:`petri.net.triggers`): only the transitions indexed under a
marked place are examined. It is enabled when its inputs are all marked; firing removes them
and adds its outputs. If a firing would put a second token in a place, or a weight is not 1,
or a transition has no input, the net is not for this engine: ``None`` is returned and the
caller uses the general one.

Successors are numbered by each transition's lowest input place, then by transition, whatever
the representation, so breadth-first numbers and shortest paths are the same either way.
"""

from __future__ import annotations

import math
import sys
from array import array
from typing import Any

from petri.net import Net, triggers


WIDE = 4096  # above this many places, markings are sets; below, integers (bit per place)
# What the search holds per marking besides the marking itself (bytes): its entry in the
# index (a dict) and in the list of markings, its parent and parent transition, and, without
# arcs, its number of successors; per arc, three int32 in arrays that grow by doubling.
HELD_PER_MARKING = 80
ARC_BYTES = 24


def explore_bits(net: Net, max_markings: int, dense: bool = True, arcs: bool = True,
                 max_bytes: float = math.inf) -> tuple[object, ...] | None:
    """(markings (n, places) uint8, src, dst, transition, parent, parent_transition, expanded,
    complete) or None when the net is not 1-safe with unit weights; markings before
    ``expanded`` have all their arcs (all of them when complete). With ``dense=False`` the
    markings are the list of marked-place frozensets instead (no n x places array). With
    ``arcs=False`` src, dst and transition are empty and two more items follow: each
    marking's number of successors and each transition's number of firings. The search
    stops, incomplete with fewer than ``max_markings`` markings, where the next marking would
    take what it holds (:data:`HELD_PER_MARKING` and the marking itself, the dense array made
    at the end included) past ``max_bytes``."""
    found = search(net, max_markings, arcs, max_bytes)
    return None if found is None else arrays(net, found, dense, arcs)


def arrays(net: Net, found: Found, dense: bool = True, arcs: bool = True
           ) -> tuple[object, ...]:
    """What :func:`search` found as :func:`explore_bits` gives it (numpy arrays)."""
    import numpy as np  # lazy for start-up speed: search() alone needs no numpy (mclc)

    wide = len(net.places) > WIDE
    order, src, dst, trs, parent, parent_t, head, complete, degree, fired = found
    counts: tuple[object, ...] = () if arcs else (
        np.asarray(degree + [0] * (len(order) - len(degree)), dtype=np.int32),
        np.asarray(fired, dtype=np.int64))
    if not dense:
        if not wide:
            order = [frozenset(i for i in range(len(net.places)) if m >> i & 1)
                     for m in order]
        return (order, np.frombuffer(src, np.int32), np.frombuffer(dst, np.int32),
                np.frombuffer(trs, np.int32), np.frombuffer(parent, np.int64),
                np.frombuffer(parent_t, np.int32), head, *counts, complete)
    width = len(net.places)
    if wide:
        markings = np.zeros((len(order), width), dtype=np.uint8)
        sizes = np.fromiter((len(m) for m in order), dtype=np.int64, count=len(order))
        flat = np.fromiter((p for m in order for p in m), dtype=np.int64,
                           count=int(sizes.sum()))
        markings[np.repeat(np.arange(len(order)), sizes), flat] = 1
    else:
        nbytes = (width + 7) // 8
        packed = np.frombuffer(b"".join(m.to_bytes(nbytes, "little") for m in order),
                               dtype=np.uint8).reshape(len(order), nbytes)
        markings = np.unpackbits(packed, axis=1, bitorder="little")[:, :width]
    return (markings, np.frombuffer(src, np.int32), np.frombuffer(dst, np.int32),
            np.frombuffer(trs, np.int32), np.frombuffer(parent, np.int64),
            np.frombuffer(parent_t, np.int32), head, *counts, complete)


Found = tuple[list[Any], "array[int]", "array[int]", "array[int]", "array[int]", "array[int]",
              int, bool, list[int], list[int]]
"""What :func:`search` finds: the markings in breadth-first order (integers, one bit per
place, on nets of at most :data:`WIDE` places; frozensets of marked places on wider ones), the
arcs (src, dst, transition), each marking's parent and the transition fired from it, how many
markings were expanded, whether the search is complete, and without arcs each marking's number
of successors and each transition's number of firings."""


def search(net: Net, max_markings: int, arcs: bool = True, max_bytes: float = math.inf
           ) -> Found | None:
    """The breadth-first search of :func:`explore_bits` in Python's own containers (no numpy:
    what a small mission's verification needs), or None when the net is not 1-safe with unit
    weights."""
    if any(w != 1 for tr in net.transitions for _, w in tr.inputs + tr.outputs) or \
            any(n > 1 for n in net.initial.values()) or \
            any(not tr.inputs for tr in net.transitions):  # a source fills a place twice
        return None
    n_trans = len(net.transitions)
    inputs = [[p for p, _ in tr.inputs] for tr in net.transitions]
    rank = [min(ins) * n_trans + t for t, ins in enumerate(inputs)]  # successor order
    readers: list[tuple[int, ...]] = [() for _ in net.places]
    for t, p in enumerate(triggers(net)):
        readers[p] += (t,)  # examined when its most selective input is marked
    wide = len(net.places) > WIDE
    searcher = _search_sets if wide else _search_ints
    return searcher(net, readers, rank, max_markings, arcs, max_bytes)


def _search_ints(net: Net, readers: list[tuple[int, ...]], rank: list[int], max_markings: int,
                 arcs: bool, max_bytes: float = math.inf) -> Found | None:
    """The search with each marking an integer, one bit per place (narrow nets: an operation
    on a few machine words is cheaper than on a set)."""
    width = len(net.places)
    per = (HELD_PER_MARKING + 28 + 4 * -(-width // 30) + 2 * width + -(-width // 8)
           + (0 if arcs else 8))  # the int, the dense row and its packed bytes at the end
    per_arc = ARC_BYTES if arcs else 0
    pre = [sum(1 << p for p, _ in tr.inputs) for tr in net.transitions]
    post = [sum(1 << p for p, _ in tr.outputs) for tr in net.transitions]
    m0 = sum(1 << p for p, n in net.initial.items() if n)
    index = {m0: 0}
    order = [m0]
    src, dst, trs = array("i"), array("i"), array("i")
    parent, parent_t = array("q", [-1]), array("i", [-1])
    degree: list[int] = []
    fired = [0] * len(net.transitions)
    head = 0
    complete = True
    # locals, not attribute look-ups, in the loop that runs once per arc
    index_get, order_append = index.get, order.append
    src_append, dst_append, trs_append = src.append, dst.append, trs.append
    by_rank = rank.__getitem__
    moves = [(pre[t], ~pre[t], post[t]) for t in range(len(net.transitions))]
    looked_up = sum(1 << p for p, ts in enumerate(readers) if ts)  # places some t is under
    while head < len(order):
        m = order[head]
        if not arcs:
            degree.append(0)
        candidates: list[int] = []
        bits = m & looked_up
        while bits:  # each marked place: the transitions looked up by it
            low = bits & -bits
            candidates += readers[low.bit_length() - 1]
            bits ^= low
        if len(candidates) > 1:
            candidates.sort(key=by_rank)
        for t in candidates:
            needs, off, on = moves[t]
            if m & needs != needs:
                continue  # not enabled
            rest = m & off
            if rest & on:
                return None  # a second token in a place: not 1-safe
            n = rest | on
            j = index_get(n)
            if j is None:
                j = len(order)
                if j >= max_markings or j * per + len(src) * per_arc > max_bytes:
                    complete = False
                    break
                index[n] = j
                order_append(n)
                parent.append(head)
                parent_t.append(t)
            if arcs:
                src_append(head)
                dst_append(j)
                trs_append(t)
            else:
                degree[head] += 1
                fired[t] += 1
        if not complete:
            break
        head += 1
    return order, src, dst, trs, parent, parent_t, head, complete, degree, fired


def _search_sets(net: Net, readers: list[tuple[int, ...]], rank: list[int], max_markings: int,
                 arcs: bool, max_bytes: float = math.inf) -> Found | None:
    """The search with each marking the frozenset of its marked places (wide nets: the cost
    of an operation is the number of tokens, not of places)."""
    per = HELD_PER_MARKING + len(net.places) + (0 if arcs else 8)  # and the set: 24 B a token
    per_arc = ARC_BYTES if arcs else 0
    pre = [frozenset(p for p, _ in tr.inputs) for tr in net.transitions]
    post = [frozenset(p for p, _ in tr.outputs) for tr in net.transitions]
    held = float(sum(map(sys.getsizeof, pre)) + sum(map(sys.getsizeof, post))
                 + HELD_PER_MARKING * len(net.transitions))  # the net as the search holds it
    m0 = frozenset(p for p, n in net.initial.items() if n)
    index = {m0: 0}
    order = [m0]
    src, dst, trs = array("i"), array("i"), array("i")
    parent, parent_t = array("q", [-1]), array("i", [-1])
    degree: list[int] = []
    fired = [0] * len(net.transitions)
    head = 0
    complete = True
    while head < len(order):
        m = order[head]
        if not arcs:
            degree.append(0)
        candidates = [t for p in m for t in readers[p]]
        if len(candidates) > 1:
            candidates.sort(key=rank.__getitem__)
        for t in candidates:
            if not pre[t] <= m:
                continue
            rest = m - pre[t]
            if not rest.isdisjoint(post[t]):
                return None  # a second token in a place: not 1-safe
            n = rest | post[t]
            j = index.get(n)
            if j is None:
                held += per + sys.getsizeof(n) + 24 * len(n)
                if len(order) >= max_markings or held + len(src) * per_arc > max_bytes:
                    complete = False
                    break
                j = index[n] = len(order)
                order.append(n)
                parent.append(head)
                parent_t.append(t)
            if arcs:
                src.append(head)
                dst.append(j)
                trs.append(t)
            else:
                degree[head] += 1
                fired[t] += 1
        if not complete:
            break
        head += 1
    return order, src, dst, trs, parent, parent_t, head, complete, degree, fired
