"""The reachability graph as the properties search it: numpy arrays, no Python object per
marking or arc.

:class:`ReachabilityGraph` splits a :class:`~petri.verification.reachability.StateSpace` in
the two parts the verification model needs: the *main* model (the mission left to itself: no
external stop) and the *stop* region (reached by an external stop, ``Mission.abort``).
:class:`Adjacency` holds a set of arcs in compressed sparse rows (CSR) both ways and searches
them a breadth-first level at a time: :meth:`Adjacency.reach` (the markings reachable from a
set, or that reach it) and :meth:`Adjacency.path` (a shortest path). :func:`lasso` finds a
marking on a cycle and the shortest firing sequence to it, for the properties whose violation
is a loop (``terminates``, ``no-zeno``).

tests/petri/verification/test_graph.py checks these searches against networkx's
(``strongly_connected_components``, ``shortest_path_length``) on small nets.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import numpy.typing as npt

from petri.net import Net
from petri.semantics import Semantics
from petri.verification.reachability import StateSpace

Rows = npt.NDArray[np.int64]  # marking (or arc) indices
Mask = npt.NDArray[np.bool_]  # one entry per marking (or arc)
CSR = tuple[Rows, Rows, Rows]  # (starts per marking, arc targets, arc ids), see csr()


class ReachabilityGraph:
    """The reachability graph split the way the properties need it: the *main* model (the
    mission left to itself: no external stop) and the *stop* region (after Mission.abort)."""

    def __init__(self, ss: StateSpace, net: Net, rules: Semantics):
        self.ss, self.net, self.rules = ss, net, rules
        n = ss.n_markings
        self.n = n
        self.marked = Marked(ss.markings)
        latch = np.zeros(len(net.places), bool)
        latch[rules.latch_states] = True
        ends = list(rules.ends)
        self.ended = (self.marked[:, ends].any(axis=1) if ends else np.zeros(n, bool))
        # tokens outside the latch states (a marked place each, where one-safe holds)
        self.others = (ss.markings.sum(axis=1, dtype=np.int64)
                       - ss.markings[:, latch].sum(axis=1, dtype=np.int64))
        self.terminal = self.ended & (self.others == 1)
        self.expanded = n if ss.expanded < 0 else ss.expanded
        stop = np.zeros(len(net.transitions), bool)
        stop[rules.stops] = True
        self.stop_arc = stop[ss.transition] if len(ss.transition) else np.zeros(0, bool)
        maybe = np.array([rules.zero_time(t) for t in range(len(net.transitions))], bool)
        known = maybe & np.array([not isinstance(t.timer, str) for t in net.transitions],
                                 bool)
        self.zero_arc = known[ss.transition] if len(ss.transition) else np.zeros(0, bool)
        self.maybe_zero_arc = (maybe[ss.transition] if len(ss.transition)
                               else np.zeros(0, bool))
        self.all_arcs = Adjacency(n, ss.src, ss.dst)
        self.main_arcs = Adjacency(n, ss.src[~self.stop_arc], ss.dst[~self.stop_arc],
                                   np.flatnonzero(~self.stop_arc))
        self.main = self.main_arcs.reach(np.array([0]))
        seeds = unique(ss.dst[self.stop_arc & self.main[ss.src]])
        self.stopped = self.all_arcs.reach(seeds) if len(seeds) else np.zeros(n, bool)

    def deadlocks(self) -> Rows:
        """Markings without successors that are not final markings (among those expanded)."""
        out = np.bincount(self.ss.src, minlength=self.n)
        dead = np.flatnonzero((out == 0) & ~self.terminal)
        return dead[dead < self.expanded]


class Marked:
    """``markings > 0``, computed only for the rows and columns asked for (a full copy of a
    large state space would cost as much as the state space), and read from a copy of the
    columns :meth:`keep` gathered, when they hold every column asked for."""

    def __init__(self, markings: npt.NDArray[np.unsignedinteger[Any]]):
        self.markings = markings
        self.kept: Mask | None = None  # markings[:, columns] > 0 for the kept columns
        self.position = np.full(markings.shape[1], -1, np.int64)  # column -> kept column

    def __len__(self) -> int:
        return int(self.markings.shape[0])

    def keep(self, columns: list[int]) -> None:
        """Gather these columns once: the questions about them read that copy, a row of a
        few bytes, instead of a row of the whole net each (on a net of 8,000 places the
        behaviour properties asked 4 questions of 300-700 columns each, 140 ms in all)."""
        columns = sorted(set(columns))
        self.kept = np.asarray(self.markings[:, columns] > 0)
        self.position[:] = -1
        self.position[columns] = np.arange(len(columns))

    def __getitem__(self, key: Any) -> Mask:
        if self.kept is not None and isinstance(key, tuple) and len(key) == 2:
            rows, columns = key
            if not isinstance(columns, slice):
                where = self.position[np.asarray(columns, np.int64)]
                if where.size and (where >= 0).all():
                    return self.kept[rows, where]
        return np.asarray(self.markings[key] > 0)


class Adjacency:
    """Forward and backward adjacency (CSR) of a set of arcs, with vectorised searches.
    ``ids`` names each arc (default: its position in ``src``), as paths report them."""

    def __init__(self, n: int, src: npt.NDArray[np.int32], dst: npt.NDArray[np.int32],
                 ids: Rows | None = None):
        self.n = n
        self.ids = np.arange(len(src)) if ids is None else ids
        self.fwd = csr(n, src, dst)
        self.bwd = csr(n, dst, src)

    def reach(self, sources: npt.NDArray[np.integer[Any]], backward: bool = False,
              within: Mask | None = None) -> Mask:
        """The markings reachable from ``sources`` (or that reach them), inside ``within``."""
        starts, targets, _ = self.bwd if backward else self.fwd
        seen = np.zeros(self.n, bool)
        frontier = unique(np.asarray(sources, np.int64))
        seen[frontier] = True
        for _ in range(self.n + 1):  # each round adds at least one marking, or stops
            if len(frontier) == 0:
                break
            if len(frontier) <= NARROW:
                frontier = narrow_step(starts, targets, frontier, seen, within)
            else:
                nxt = targets[gather(starts, frontier)]
                keep = ~seen[nxt] if within is None else ~seen[nxt] & within[nxt]
                frontier = unique(nxt[keep])
            seen[frontier] = True
        return seen

    def path(self, source: int, goal: Mask, within: Mask | None = None) -> tuple[list[int], int]:
        """A shortest path (arc ids) from ``source`` to a marking in ``goal`` (at least one
        arc), and the marking it reaches; ([], -1) when there is none."""
        starts, targets, arcs = self.fwd
        parent = np.full(self.n, -1, np.int64)
        via = np.full(self.n, -1, np.int64)
        seen = np.zeros(self.n, bool)
        frontier = np.array([source], np.int64)
        for _ in range(self.n + 1):
            if len(frontier) == 0:
                return [], -1
            idx = gather(starts, frontier)
            nxt, arc = targets[idx], arcs[idx]
            src = np.repeat(frontier, starts[frontier + 1] - starts[frontier])
            keep = ~seen[nxt] if within is None else ~seen[nxt] & within[nxt]
            nxt, arc, src = nxt[keep], arc[keep], src[keep]
            nxt, first = np.unique(nxt, return_index=True)
            arc, src = arc[first], src[first]
            seen[nxt], parent[nxt], via[nxt] = True, src, arc
            hit = nxt[goal[nxt]]
            if len(hit):
                return self._walk_back(source, int(hit[0]), parent, via), int(hit[0])
            frontier = nxt
        return [], -1

    def _walk_back(self, source: int, end: int, parent: Rows, via: Rows) -> list[int]:
        """The arc ids from ``source`` to ``end`` along the BFS tree ``parent``/``via``."""
        at, out = end, []
        for _ in range(self.n + 1):
            out.append(int(via[at]))
            at = int(parent[at])
            if at == source:
                break
        return [int(self.ids[a]) for a in out[::-1]]


def csr(n: int, src: npt.NDArray[np.int32], dst: npt.NDArray[np.int32]) -> CSR:
    """The arcs ``src -> dst`` of a graph on ``n`` markings in compressed sparse rows: the
    arcs leaving marking m are ``targets[starts[m]:starts[m + 1]]``, with their ids
    (positions in ``src``) alongside."""
    order = np.argsort(src, kind="stable")
    starts = np.zeros(n + 1, np.int64)
    np.cumsum(np.bincount(src, minlength=n), out=starts[1:])
    return starts, dst[order].astype(np.int64), order.astype(np.int64)


# A breadth-first level of at most this many markings is expanded in Python: numpy's dozen
# calls a level cost more than the few arcs themselves. A mission in sequence is a graph
# thousands of levels deep and one or two markings wide (reach: 49 ms -> 12 ms on the
# 2,671 levels of a thousand-task sequence).
NARROW = 16


def narrow_step(starts: Rows, targets: Rows, frontier: Rows, seen: Mask,
                within: Mask | None) -> Rows:
    """The markings one arc from ``frontier`` (CSR ``starts``/``targets``), not ``seen`` and
    inside ``within``, sorted: one level of :meth:`Adjacency.reach`, one marking at a time."""
    found = set()
    for m in frontier.tolist():
        for x in targets[starts[m]:starts[m + 1]].tolist():
            if not seen[x] and (within is None or within[x]):
                found.add(x)
    return np.array(sorted(found), np.int64)


def unique(values: npt.NDArray[np.integer[Any]]) -> Rows:
    """The distinct values of a 1-D integer array, sorted: ``np.unique`` without numpy 2's
    check for a masked array, which loads numpy.ma (7 ms of every mclc) at its first call."""
    ordered = np.sort(np.asarray(values, np.int64))
    if len(ordered) < 2:
        return ordered
    return ordered[np.concatenate(([True], ordered[1:] != ordered[:-1]))]


def gather(starts: Rows, nodes: Rows) -> Rows:
    """Indices of every arc leaving ``nodes`` in a CSR layout, without a Python loop."""
    lo, hi = starts[nodes], starts[nodes + 1]
    lens = hi - lo
    total = int(lens.sum())
    if total == 0:
        return np.zeros(0, np.int64)
    offsets = np.repeat(lo - np.concatenate(([0], np.cumsum(lens)[:-1])), lens)
    return offsets + np.arange(total)


def on_cycles(n: int, bad: Mask, src: npt.NDArray[np.int32], dst: npt.NDArray[np.int32]
              ) -> Mask:
    """The markings of ``bad`` left after peeling, inside ``bad``, those with no
    predecessor and then those with no successor (Kahn's algorithm both ways): every marking
    on a cycle of arcs within ``bad`` is left (and those between two such cycles)."""
    inside = bad[src] & bad[dst]
    alive = bad.copy()
    for s, d in ((src[inside], dst[inside]), (dst[inside], src[inside])):
        degree = np.bincount(d[alive[s] & alive[d]], minlength=n)
        fwd = csr(n, s, d)
        frontier = np.flatnonzero(alive & (degree == 0))
        for _ in range(n + 1):
            if len(frontier) == 0:
                break
            alive[frontier] = False
            nxt = fwd[1][gather(fwd[0], frontier)]
            np.subtract.at(degree, nxt, 1)
            nxt = unique(nxt)
            frontier = nxt[alive[nxt] & (degree[nxt] == 0)]
    return alive


def lasso(ss: StateSpace, adj: Adjacency, bad: Mask, src: npt.NDArray[np.int32],
          dst: npt.NDArray[np.int32], reach: Adjacency
          ) -> tuple[int, list[int], list[int]] | None:
    """A marking of ``bad`` that lies on a cycle of ``adj``'s arcs (``src -> dst``, arcs of
    ``ss``) inside ``bad``: the marking, the shortest firing sequence to it over ``reach``'s
    arcs, and the shortest cycle through it (transitions); None when there is no such cycle
    (or none through the 64 nearest candidates)."""
    n = ss.n_markings
    candidates = np.flatnonzero(on_cycles(n, bad, src, dst))  # BFS order: nearest first
    goal = np.zeros(n, bool)
    for m in candidates[:64]:
        goal[:] = False
        goal[m] = True
        cycle, _ = adj.path(int(m), goal, within=bad)
        if cycle:
            prefix, _ = reach.path(0, goal) if m != 0 else ([], m)
            trans = ss.transition
            return int(m), [int(trans[a]) for a in prefix], [int(trans[a]) for a in cycle]
    return None
