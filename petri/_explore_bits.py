"""Reachability of small safe nets with markings packed into Python integers (one bit per
place): the engine for mission nets, which are 1-safe and small, where starting a compiler
(numba) would cost more than the search itself.

A transition is enabled when its input bits are all set; firing clears them and sets its
output bits. Only the transitions that read a marked place are examined. If a firing would put
a second token in a place, or a weight is not 1, the net is not for this engine: ``None`` is
returned and the caller uses the general one.
"""

from __future__ import annotations

from array import array

import numpy as np

from .net import Net


def explore_bits(net: Net, max_markings: int) -> tuple[object, ...] | None:
    """(markings (n, places) uint8, src, dst, transition, parent, parent_transition, complete)
    or None when the net is not 1-safe with unit weights."""
    if any(w != 1 for tr in net.transitions for _, w in tr.inputs + tr.outputs) or \
            any(n > 1 for n in net.initial.values()):
        return None
    pre = [sum(1 << p for p, _ in tr.inputs) for tr in net.transitions]
    post = [sum(1 << p for p, _ in tr.outputs) for tr in net.transitions]
    readers: list[list[int]] = [[] for _ in net.places]
    for i, tr in enumerate(net.transitions):
        if tr.inputs:
            readers[min(p for p, _ in tr.inputs)].append(i)  # examined via its first input
    m0 = sum(1 << p for p, n in net.initial.items() if n)
    index = {m0: 0}
    order = [m0]
    src, dst, trs = array("i"), array("i"), array("i")
    parent, parent_t = array("q", [-1]), array("i", [-1])
    head = 0
    complete = True
    while head < len(order):
        m = order[head]
        bits = m
        while bits:  # each marked place: the transitions whose first input it is
            low = bits & -bits
            p = low.bit_length() - 1
            bits ^= low
            for t in readers[p]:
                if m & pre[t] != pre[t]:
                    continue
                rest = m & ~pre[t]
                if rest & post[t]:
                    return None  # a second token in a place: not 1-safe
                n = rest | post[t]
                j = index.get(n)
                if j is None:
                    if len(order) >= max_markings:
                        complete = False
                        break
                    j = index[n] = len(order)
                    order.append(n)
                    parent.append(head)
                    parent_t.append(t)
                src.append(head)
                dst.append(j)
                trs.append(t)
            if not complete:
                break
        if not complete:
            break
        head += 1
    width = len(net.places)
    nbytes = (width + 7) // 8
    packed = np.frombuffer(b"".join(m.to_bytes(nbytes, "little") for m in order),
                           dtype=np.uint8).reshape(len(order), nbytes)
    markings = np.unpackbits(packed, axis=1, bitorder="little")[:, :width]
    return (markings, np.frombuffer(src, np.int32), np.frombuffer(dst, np.int32),
            np.frombuffer(trs, np.int32), np.frombuffer(parent, np.int64),
            np.frombuffer(parent_t, np.int32), complete)
