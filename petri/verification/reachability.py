"""Explicit reachability graphs of bounded place/transition nets.

Markings are discovered breadth first and numbered in that order (row 0 is the initial
marking), so a marking's parent, kept for each row, lies on a shortest firing sequence to it.

The hot loop never builds a Python object per marking. A marking is a fixed-width row of token
counts (``uint8`` when at most 255 tokens may lie in a place, wider otherwise) padded to whole
64-bit words; a row is stored, hashed and compared as those words. Seen markings live in an
open-addressing hash table (linear probing) of row numbers; arcs of the reachability graph are
three integer arrays. The successor loop is compiled with numba when it is installed
(:mod:`petri.verification.explore_numba`); otherwise a level-by-level numpy search
(:mod:`petri.verification.explore_numpy`) computes the same numbering, more slowly. A search
without its arcs (``arcs=False``, ``mclc NET.pnml``'s), or any when numba is missing, whose
markings fit one 64-bit word is done in numpy on packed words instead
(:mod:`petri.verification.explore_packed`: faster than numba's, and without numba's memory),
the same numbering again.

A limit (markings, or tokens in one place) stops the search with ``complete=False``. When it
stops, the firing sequence to the last marking is checked for the Karp-Miller witness of
unboundedness: an earlier marking that the later one strictly covers.
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
import numpy.typing as npt

from petri.net import END_FAIL, END_OK, Net, triggers

if TYPE_CHECKING:
    import networkx as nx

IntArray = npt.NDArray[np.integer]

# Safe nets are first tried with the engine that keeps a marking as its set of marked places
# (petri/verification/explore_bits.py). Its cost per marking is its number of tokens, while the dense
# engines pay the net's width: on nets with at most SMALL_SAFE_PLACES places it is given up
# (for numba's or numpy's engine) after SMALL_SAFE_MARKINGS markings, on wider ones never.
SMALL_SAFE_PLACES = 4096
SMALL_SAFE_MARKINGS = 100_000

# Why the search stopped (the kernels return these codes).
COMPLETE, MARKING_LIMIT, TOKEN_LIMIT, MEMORY_LIMIT = 0, 1, 2, 4


@dataclass
class StateSpace:
    """The reachability graph: markings in BFS order and one arc per firing."""

    markings: npt.NDArray[np.unsignedinteger]  # (n, places); row 0 = initial marking
    src: npt.NDArray[np.int32]  # one entry per reachability-graph arc
    dst: npt.NDArray[np.int32]
    transition: npt.NDArray[np.int32]
    complete: bool  # False if a limit stopped exploration
    unbounded_place: int | None = None  # a place proven unbounded (Karp-Miller witness)
    parent: npt.NDArray[np.int64] | None = None  # BFS tree: parent marking (-1 for row 0)
    parent_transition: npt.NDArray[np.int32] | None = None  # transition fired from parent
    stop_reason: str = ""  # "" when complete, else what limit stopped the search
    engine: str = ""  # "bits", "packed", "numba" or "numpy"
    expanded: int = -1  # markings 0..expanded-1 have all their arcs (-1: all of them)
    # When explored with arcs=False, src/dst/transition are empty and these count the arcs:
    degree: npt.NDArray[np.int32] | None = None  # successors of each marking
    fired: npt.NDArray[np.int64] | None = None  # firings of each transition

    @property
    def n_markings(self) -> int:
        return int(self.markings.shape[0])

    @property
    def n_arcs(self) -> int:
        if self.degree is not None:
            return int(self.degree.sum())
        return int(self.src.shape[0])

    def to_networkx(self, net: Net) -> nx.MultiDiGraph:
        """This graph as networkx's: see :func:`as_digraph`."""
        return as_digraph(net, self)


@dataclass(frozen=True)
class _Compiled:
    """The net in the flat arrays the kernels read: CSR lists per transition, built from the
    sparse arcs (no place x transition matrix), and the transitions indexed by input place."""

    in_ptr: npt.NDArray[np.int64]  # inputs of t: in_place/in_w[in_ptr[t]:in_ptr[t+1]]
    in_place: npt.NDArray[np.int64]
    in_w: npt.NDArray[np.int64]
    eff_ptr: npt.NDArray[np.int64]  # non-zero effect post - pre of t, same layout
    eff_place: npt.NDArray[np.int64]
    eff_delta: npt.NDArray[np.int64]
    # The transitions examined when place p is marked, rd_t[rd_ptr[p]:rd_ptr[p+1]]: those
    # looked up by p (petri.net.triggers; one list per row cell, padding included).
    rd_ptr: npt.NDArray[np.int64]
    rd_t: npt.NDArray[np.int64]
    sources: npt.NDArray[np.int64]  # transitions without inputs (always examined)
    row: npt.NDArray[np.unsignedinteger]  # the initial marking, padded to whole words


def compile_net(net: Net, max_tokens: int) -> _Compiled:
    in_ptr, in_place, in_w = [0], [], []
    eff_ptr, eff_place, eff_delta = [0], [], []
    first = triggers(net)
    for t, tr in enumerate(net.transitions):
        for p, w in tr.inputs:
            in_place.append(p)
            in_w.append(w)
        in_ptr.append(len(in_place))
        for p, d in sorted(net.effect(t).items()):
            eff_place.append(p)
            eff_delta.append(d)
        eff_ptr.append(len(eff_place))
    dtype = row_dtype(max_tokens)
    width = max(1, len(net.places))
    per_word = 8 // np.dtype(dtype).itemsize
    padded = -(-width // per_word) * per_word
    row = np.zeros(padded, dtype=dtype)
    for p, n in net.initial.items():
        if n > max_tokens:
            raise ValueError(f"the initial marking has more than max_tokens={max_tokens} "
                             "tokens in one place")
        row[p] = n
    trigger = np.asarray(first, dtype=np.int64)
    has = np.flatnonzero(trigger >= 0)
    order = has[np.argsort(trigger[has], kind="stable")]  # by trigger place, then t
    rd_ptr = np.zeros(padded + 1, dtype=np.int64)
    np.cumsum(np.bincount(trigger[has], minlength=padded), out=rd_ptr[1:])

    def ints(values: list[int]) -> npt.NDArray[np.int64]:
        return np.asarray(values, dtype=np.int64)

    return _Compiled(ints(in_ptr), ints(in_place), ints(in_w), ints(eff_ptr), ints(eff_place),
                     ints(eff_delta), rd_ptr, order.astype(np.int64),
                     np.flatnonzero(trigger < 0).astype(np.int64), row)


def row_dtype(max_tokens: int) -> type[np.unsignedinteger]:
    for dtype in (np.uint8, np.uint16, np.uint32):
        if max_tokens <= np.iinfo(dtype).max:
            return dtype
    raise ValueError(f"max_tokens={max_tokens} exceeds 2**32 - 1")


def _kernel(engine: str) -> tuple[str, object]:
    """The successor loop: numba's when available (or asked for), numpy's otherwise."""
    if engine not in ("auto", "numba", "numpy"):
        raise ValueError(f"unknown engine {engine!r}")
    if engine != "numpy":
        try:
            from petri.verification import explore_numba as _explore_numba
            return "numba", _explore_numba.explore_rows
        except ImportError:  # numba is optional
            if engine == "numba":
                raise
    from petri.verification import explore_numpy as _explore_numpy
    return "numpy", _explore_numpy.explore_rows


def default_engine() -> str:
    """The engine ``explore`` uses by default: "numba" when installed, else "numpy"."""
    return _kernel("auto")[0]


def explore(net: Net, max_markings: int = 20_000_000, max_tokens: int = 255,
            engine: str = "auto", arcs: bool = True, max_bytes: float = math.inf
            ) -> StateSpace:
    """Breadth-first reachability graph of ``net`` from its initial marking.

    Stops (``complete=False``) after ``max_markings`` markings, when a firing would put
    more than ``max_tokens`` tokens in a place, or when the next arrays the numba or numpy
    engine would allocate (estimated before they are) would take what it holds past
    ``max_bytes`` ("the memory budget of N MiB"). ``engine`` is "auto", "bits", "packed",
    "numba" or "numpy" ("packed" raises ValueError for a net whose markings outgrow one
    64-bit word). ``arcs=False`` keeps only the number of successors of each marking and of
    firings of each transition (``degree``, ``fired``), not the arcs: enough for deadlocks,
    dead transitions and bounds, in a third of the memory. "auto" takes the bits engine for
    1-safe nets (given up past SMALL_SAFE_MARKINGS on narrow ones), then the packed one where
    markings fit a word, for a search without arcs (or any, when numba is missing), else
    numba's (numpy's when numba is missing).
    """
    if not 1 <= max_markings < 2**31:
        raise ValueError("max_markings must lie in [1, 2**31)")
    if engine in ("bits", "auto"):
        from petri.verification.explore_bits import explore_bits

        small = engine == "auto" and len(net.places) <= SMALL_SAFE_PLACES
        cap = min(max_markings, SMALL_SAFE_MARKINGS) if small else max_markings
        result = explore_bits(net, cap, arcs=arcs, max_bytes=max_bytes)
        if result is not None and (result[-1] or engine == "bits" or not small):
            markings, src, dst, tr, parent, parent_t, expanded = result[:7]
            complete = result[-1]
            ss = StateSpace(markings, src, dst, tr, bool(complete), None, parent,  # type: ignore[arg-type]
                            parent_t, engine="bits")  # type: ignore[arg-type]
            if not arcs:
                ss.degree, ss.fired = result[7], result[8]  # type: ignore[assignment]
            if not complete:  # before the cap, what stopped it was the memory budget
                ss.stop_reason = (f"the memory budget of {max_bytes / 2**20:,.0f} MiB"
                                  if ss.n_markings < cap else
                                  f"more than {max_markings} markings")
                ss.expanded = int(expanded)  # type: ignore[call-overload]
            return ss
    compiled = compile_net(net, max_tokens)
    found = None
    if engine == "packed" or (engine == "auto" and (not arcs or default_engine() == "numpy")):
        # lazily, as the other engines: its threads and ctypes cost start-up time
        from petri.verification.explore_packed import explore_rows as packed_rows

        found, name = packed_rows(compiled, max_markings, max_tokens, arcs, max_bytes), "packed"
        if found is None and engine == "packed":
            raise ValueError(f"the markings of {net.name} do not fit one 64-bit word")
    if found is None:
        name, kernel = _kernel(engine)
        found = kernel(compiled, max_markings, max_tokens, arcs, max_bytes)  # type: ignore[operator]
    cells, parent, parent_t, src, dst, tr, status, stop_at, stop_t, degree, fired = found
    markings = cells[:, : len(net.places)]
    ss = StateSpace(markings, src, dst, tr, status == COMPLETE, None, parent, parent_t,
                    engine=name, degree=degree, fired=fired)
    if status == TOKEN_LIMIT:
        ss.stop_reason = f"more than {max_tokens} tokens in a place"
        ss.unbounded_place = _unbounded_witness(net, ss, int(stop_at), int(stop_t))
    elif status == MEMORY_LIMIT:
        ss.stop_reason = f"the memory budget of {max_bytes / 2**20:,.0f} MiB"
    elif status == MARKING_LIMIT:
        ss.stop_reason = f"more than {max_markings} markings"
        ss.unbounded_place = _unbounded_witness(net, ss, ss.n_markings - 1, -1)
    if status != COMPLETE:
        ss.expanded = int(stop_at)
    return ss


# What the explicit search holds per marking at its peak, whichever engine: the row (token
# counts padded to 64-bit words) about six times over (the rows, their hash table or sorted
# keys, and the copy made when an array doubles or levels are joined), its parent (12 bytes),
# and its arcs (about four per marking, three 32-bit integers each, doubled while growing) or,
# without arcs, its number of successors.
ROW_COPIES = 6
ARC_BYTES = 4 * 12 * 2


def bytes_per_marking(net: Net, max_tokens: int = 255, arcs: bool = True) -> int:
    """An upper estimate of the bytes :func:`explore` holds per marking of ``net``."""
    itemsize = np.dtype(row_dtype(max_tokens)).itemsize
    row = -(-max(1, len(net.places)) * itemsize // 8) * 8
    return ROW_COPIES * row + 12 + (ARC_BYTES if arcs else 4)


def markings_within(net: Net, max_bytes: float, max_tokens: int = 255,
                    arcs: bool = True) -> int:
    """The most markings :func:`explore` may keep within ``max_bytes`` (0: none fit once
    the net itself, a few words per arc, place and transition, is held)."""
    net_bytes = 64.0 * (net.arc_count() + len(net.places) + len(net.transitions))
    room = (max_bytes - net_bytes) // bytes_per_marking(net, max_tokens, arcs)
    return int(max(0, min(room, 2**31 - 1)))


def _unbounded_witness(net: Net, ss: StateSpace, at: int, transition: int) -> int | None:
    """A place that the Karp-Miller criterion proves unbounded, if the path shows one.

    The marking reached by firing ``transition`` (or none: -1) from marking ``at`` is compared
    with every marking on its BFS path: if it strictly covers one of them, the firing sequence
    between the two can be repeated forever and each place it increases is unbounded.
    """
    if at < 0:
        return None
    last = ss.markings[at].astype(np.int64)
    if transition >= 0:
        for p, d in net.effect(transition).items():
            last[p] += d
    path = ss.markings[_path_markings(ss, at)].astype(np.int64)
    covered = np.all(path <= last, axis=1) & np.any(path < last, axis=1)
    if not covered.any():
        return None
    earlier = path[int(np.argmax(covered))]
    return int(np.argmax(last > earlier))


def _path_markings(ss: StateSpace, index: int) -> list[int]:
    """Rows on the BFS-tree path from row 0 to ``index`` (inclusive)."""
    assert ss.parent is not None
    rows = [index]
    for _ in range(ss.n_markings):  # a tree path visits each row at most once
        if rows[-1] == 0:
            break
        rows.append(int(ss.parent[rows[-1]]))
    return rows[::-1]


# -- questions about a state space ----------------------------------------------------------

def out_degree(ss: StateSpace) -> npt.NDArray[np.int64]:
    if ss.degree is not None:
        return ss.degree.astype(np.int64)
    return np.bincount(ss.src, minlength=ss.n_markings)


def deadlocks(ss: StateSpace) -> npt.NDArray[np.int64]:
    """Indices of markings with no successor (BFS order, so the first is a nearest one).

    On an incomplete state space, markings whose successors were not all computed are not
    reported.
    """
    dead = np.flatnonzero(out_degree(ss) == 0)
    if ss.expanded >= 0:
        dead = dead[dead < ss.expanded]
    return dead


def dead_transitions(net: Net, ss: StateSpace) -> list[int]:
    """Transitions that fire from no reachable marking (meaningful when ``ss.complete``)."""
    fired = (ss.fired if ss.fired is not None
             else np.bincount(ss.transition, minlength=len(net.transitions)))
    return [int(t) for t in np.flatnonzero(fired == 0)]


def max_tokens(ss: StateSpace) -> int:
    """The largest number of tokens in one place over all reachable markings."""
    return int(ss.markings.max()) if ss.markings.size else 0


def place_bounds(ss: StateSpace) -> npt.NDArray[np.int64]:
    if not ss.markings.size:
        return np.zeros(ss.markings.shape[1], dtype=np.int64)
    bounds: npt.NDArray[np.int64] = ss.markings.max(axis=0).astype(np.int64)
    return bounds


def is_one_safe(ss: StateSpace) -> bool:
    return max_tokens(ss) <= 1


def shortest_path(ss: StateSpace, target_indices: IntArray | list[int]) -> list[int]:
    """Transitions of a shortest firing sequence from the initial marking to any target.

    Markings are numbered in BFS order, so the smallest target index is a nearest one and the
    BFS-tree path to it is a shortest one.
    """
    targets = np.asarray(target_indices, dtype=np.int64)
    if targets.size == 0:
        raise ValueError("no target marking")
    if ss.parent is None or ss.parent_transition is None:
        return _bfs_path(ss, targets)
    rows = _path_markings(ss, int(targets.min()))
    return [int(ss.parent_transition[r]) for r in rows[1:]]


def _bfs_path(ss: StateSpace, targets: npt.NDArray[np.int64]) -> list[int]:
    """Shortest path by a fresh BFS over the arcs (for state spaces built without parents)."""
    order = np.argsort(ss.src, kind="stable")
    starts = np.searchsorted(ss.src[order], np.arange(ss.n_markings + 1))
    parent = np.full(ss.n_markings, -1, dtype=np.int64)
    via = np.full(ss.n_markings, -1, dtype=np.int64)
    wanted = {int(t) for t in targets}
    seen = np.zeros(ss.n_markings, dtype=bool)
    seen[0] = True
    queue = deque([0])
    found = 0 if 0 in wanted else -1
    while queue and found < 0:  # each marking enters the queue at most once
        m = queue.popleft()
        for a in order[starts[m]:starts[m + 1]]:
            d = int(ss.dst[a])
            if not seen[d]:
                seen[d], parent[d], via[d] = True, m, int(ss.transition[a])
                queue.append(d)
                if d in wanted:
                    found = d
                    break
    if found < 0:
        raise ValueError("no target marking is reachable")
    path: list[int] = []
    for _ in range(ss.n_markings):
        if found == 0:
            break
        path.append(int(via[found]))
        found = int(parent[found])
    return path[::-1]


def as_digraph(net: Net, ss: StateSpace) -> nx.MultiDiGraph:
    """The reachability graph as a networkx ``MultiDiGraph`` (a ``DiGraph`` whose two
    markings may be joined by several firings), for networkx's algorithms and writers.

    Node i is marking row i (0 the initial marking) with the attributes ``marking`` (the
    marked places: ``{a, b×2}``), ``initial`` (bool) and ``end`` ("ok" or "fail" when the
    net's ok or fail place is marked, else ""). Each firing is an edge keyed by its
    transition index, with ``transition`` (that index), ``name``, ``label`` and, for a net
    compiled from MCL, ``line`` (the source line). The graph's own attributes: ``net``,
    ``complete`` and, when a limit cut the exploration, ``stop_reason`` (then the markings
    past the last one expanded have no edges out). A state space explored without its arcs
    (``explore(..., arcs=False)``) has none to give: ValueError.
    """
    import networkx as nx  # lazily: importing networkx costs start-up time most runs never use

    if ss.degree is not None and ss.n_arcs:
        raise ValueError("the state space was explored without its arcs (arcs=False)")
    graph = nx.MultiDiGraph(net=net.name, complete=ss.complete)
    if ss.stop_reason:
        graph.graph["stop_reason"] = ss.stop_reason
    ends = {p: "ok" for p in net.places_with(END_OK)} | {
        p: "fail" for p in net.places_with(END_FAIL)}
    for i, row in enumerate(ss.markings):
        end = next((status for p, status in ends.items() if row[p]), "")
        graph.add_node(i, marking=net.describe_marking(row), initial=i == 0, end=end)
    firing: list[dict[str, object]] = []  # the attributes of each transition's edges
    for t, tr in enumerate(net.transitions):
        firing.append({"transition": t, "name": tr.name, "label": tr.label})
        if tr.origin is not None:
            firing[t]["line"] = tr.origin.line
    graph.add_edges_from((s, d, t, firing[t]) for s, d, t in
                         zip(ss.src.tolist(), ss.dst.tolist(), ss.transition.tolist()))
    return graph
