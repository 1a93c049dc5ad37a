"""The quick verdict: the explicit route's verdict of a small 1-safe net whose every property
holds, decided in Python's own containers, without numpy.

What a user pays who edits a mission and checks it (``mclc``): the explicit route
(petri/verification/properties.py) keeps its graph in numpy arrays, and importing numpy costs
more CPU than exploring and deciding a mission of a few thousand markings (the dam mission:
3,155 markings, 12,091 arcs). So a 1-safe net of at most :data:`MAX_PLACES` places is first
searched by :func:`petri.verification.explore_bits.search` (markings as integers, a bit per
place: :func:`explored`), and on a graph of at most :data:`MAX_MARKINGS` markings each property
is decided as the explicit route decides it when it holds (:func:`all_hold`):

* one-safe: the search gives up on a second token in a place;
* proper-completion, no-deadlock, behaviours-off-at-end, behaviour-single-owner,
  dof-exclusive, no-disable-while-held: no marking (or firing) is bad;
* can-end and stop-safe: a backward search from the final markings reaches every marking of
  the main model (of the stop region);
* no-zeno and instant-loop: the arcs that may take no time (of the main model, for
  instant-loop) make no cycle (Kahn's algorithm);
* terminates: the caller decides it (a mission: from its proved worst case) and passes it;
* actions-match-behaviours and no-dead-transitions: as the explicit route, from the net and
  the transitions that fire.

Every property that holds is said in the explicit route's words (petri/verification/verdict.py
``HOLDS``), with its method. Where one does not hold (a violation needs its counterexample,
the shortest firing sequence or a lasso, and maybe the timed model), where the exploration is
cut, or where the net is not for it (wider, not 1-safe, larger), the caller takes the explicit
route, on the same graph when it was searched (:func:`state_space`: not searched twice), which
decides the same properties on it: the verdicts are the same
(tests/petri/verification/test_all_hold.py compares them).
"""

from __future__ import annotations

import math
import time
from array import array
from bisect import bisect_left
from collections.abc import Iterable, Sequence
from itertools import compress
from typing import TYPE_CHECKING

from petri.net import Net
from petri.semantics import Semantics
from petri.verification.actions import actions_match
from petri.verification.explore_bits import WIDE, Found, arrays, search
from petri.verification.verdict import (HOLDS, NO_STOP, Result, Verdict, dead_transitions,
                                        explicit_method)

if TYPE_CHECKING:
    from petri.verification.reachability import StateSpace

MAX_PLACES = WIDE  # wider nets keep markings as sets (explore_bits): the numpy route
# The search stops here, as explore() stops its search of a small safe net
# (petri/verification/reachability.py, SMALL_SAFE_MARKINGS), so that a complete one is the
# graph explore() gives, which the numpy route then takes instead of searching again.
SEARCH_MARKINGS = 100_000
# Above this many markings the numpy route's vectorised searches pay for numpy's import
# (about 60 ms of CPU): the properties cost about 4 us a marking here (the dam: 3,155
# markings, 12,091 arcs, 14 ms; every_construct.mcl, 26,426 markings: 130 ms against 65 ms).
MAX_MARKINGS = 20_000


def explored(net: Net, max_markings: int, max_bytes: float = math.inf) -> Found | None:
    """The complete breadth-first search of a 1-safe net of at most :data:`MAX_PLACES` places
    (as :func:`petri.verification.reachability.explore` makes it, with its limits), or None:
    a net not for it, or a search cut."""
    if len(net.places) > MAX_PLACES:
        return None
    found = search(net, min(max_markings, SEARCH_MARKINGS), arcs=True, max_bytes=max_bytes)
    return found if found is not None and found[7] else None


def all_hold(net: Net, found: Found, terminates: Result) -> Verdict | None:
    """The explicit route's verdict of ``net`` (``verify(net, termination=...)`` of
    petri/verification/properties.py) on the graph :func:`explored` found, when every
    property it decides on the graph holds, ``terminates`` being the caller's (it must hold);
    None when one does not, or when the graph has more than :data:`MAX_MARKINGS` markings."""
    start = time.perf_counter()
    order, src, dst, trs = found[0], found[1], found[2], found[3]
    if not terminates.holds or len(order) > MAX_MARKINGS:
        return None
    graph = Graph(net, order, src, dst, trs)
    how = explicit_method(len(order), len(src))
    results = graph.safety(how)
    if results is None:
        return None
    results.insert(3, terminates)
    fired = set(trs)
    never = [t for t in range(len(net.transitions)) if t not in fired]
    results += [actions_match(net), dead_transitions(net, never, how)]
    verdict = Verdict(net, len(order), len(src), 0.0, results)
    verdict.dead_transitions = never
    verdict.seconds = time.perf_counter() - start
    return verdict


def state_space(net: Net, found: Found) -> StateSpace:
    """The graph :func:`explored` found, as explore() gives it (numpy arrays)."""
    from petri.verification.reachability import StateSpace  # lazy for start-up speed:
    # numpy, which the quick verdict never needs

    markings, src, dst, tr, parent, parent_t = arrays(net, found)[:6]
    return StateSpace(markings, src, dst, tr, True, None, parent, parent_t,  # type: ignore[arg-type]
                      engine="bits")


def mask(places: Iterable[int]) -> int:
    """The places as a marking's bits."""
    bits = 0
    for p in places:
        bits |= 1 << p
    return bits


class Graph:
    """The reachability graph as :func:`search` gives it (markings as integers, arcs as three
    arrays in the order of their source markings), and the parts the properties read: the
    *main* model (no external stop) and the *stop* region, as
    :class:`petri.verification.graph.ReachabilityGraph` splits them."""

    def __init__(self, net: Net, order: list[int], src: array[int], dst: array[int],
                 trs: array[int]):
        self.net, self.order, self.src, self.dst, self.trs = net, order, src, dst, trs
        self.rules = rules = Semantics(net)
        n = len(order)
        ends, latches = mask(rules.ends), mask(rules.latch_states)
        self.ended = [m & ends != 0 for m in order]
        # tokens outside the latch states (1-safe: a bit each)
        self.others = [(m & ~latches).bit_count() for m in order]
        self.terminal = [e and k == 1 for e, k in zip(self.ended, self.others)]
        stops = set(rules.stops)
        self.stop_arc = [t in stops for t in trs]
        # the arcs leaving m: starts[m] to starts[m + 1] (the arcs are in their sources' order)
        self.starts = [bisect_left(src, m) for m in range(n + 1)]
        self.main = self.forward([0], [not s for s in self.stop_arc])
        seeds = [d for d, s, stop in zip(dst, src, self.stop_arc) if stop and self.main[s]]
        self.stopped = self.forward(seeds, None) if seeds else bytearray(n)
        self.before: list[list[int]] = []  # the arcs entering each marking (backward())

    def forward(self, sources: Sequence[int], arcs: list[bool] | None) -> bytearray:
        """The markings reachable from ``sources`` by the arcs ``arcs`` marks (all: None)."""
        seen = bytearray(len(self.order))
        for m in sources:
            seen[m] = 1
        todo = list(sources)
        starts, dst = self.starts, self.dst
        while todo:
            m = todo.pop()
            for a in range(starts[m], starts[m + 1]):
                d = dst[a]
                if not seen[d] and (arcs is None or arcs[a]):
                    seen[d] = 1
                    todo.append(d)
        return seen

    def backward(self, goal: list[bool], within: bytearray, arcs: list[bool] | None
                 ) -> bool:
        """Whether every marking of ``within`` reaches one of ``goal`` (inside ``within``)
        by the arcs ``arcs`` marks (all: None)."""
        if not self.before:  # the arcs entering each marking, once
            self.before = [[] for _ in self.order]
            for a, d in enumerate(self.dst):
                self.before[d].append(a)
        before, src = self.before, self.src
        seen = bytearray(len(self.order))
        todo = [m for m, g in enumerate(goal) if g and within[m]]
        for m in todo:
            seen[m] = 1
        count = len(todo)
        while todo:
            for a in before[todo.pop()]:
                s = src[a]
                if not seen[s] and within[s] and (arcs is None or arcs[a]):
                    seen[s] = 1
                    count += 1
                    todo.append(s)
        return count == sum(within)

    def acyclic(self, arcs: list[bool]) -> bool:
        """Whether the arcs ``arcs`` marks make no cycle. Markings are numbered breadth
        first, so a cycle has an arc to a marking numbered no higher than its source (a
        *back* arc), and lies among the markings reachable from the targets of back arcs;
        Kahn's algorithm decides among those alone (every marking is peeled once no marked
        arc enters it): a few hundred of the dam's 3,155 markings."""
        back = [d for s, d in compress(zip(self.src, self.dst), arcs) if d <= s]
        if not back:
            return True
        within = self.forward(back, arcs)  # closed: a marked arc from it stays in it
        among = list(compress(range(len(self.order)), within))
        starts, dst = self.starts, self.dst
        entering = dict.fromkeys(among, 0)
        for m in among:
            for a in range(starts[m], starts[m + 1]):
                if arcs[a]:
                    entering[dst[a]] += 1
        left = sum(entering.values())
        todo = [m for m in among if entering[m] == 0]
        while todo:
            m = todo.pop()
            for a in range(starts[m], starts[m + 1]):
                if arcs[a]:
                    d = dst[a]
                    left -= 1
                    entering[d] -= 1
                    if entering[d] == 0:
                        todo.append(d)
        return left == 0

    def safety(self, how: str) -> list[Result] | None:
        """Every property the graph decides but ``terminates``, as the explicit route says it
        when it holds, in its order; None when one does not hold."""
        net, rules, order = self.net, self.rules, self.order
        if any(e and k > 1 for e, k in zip(self.ended, self.others)):
            return None  # proper-completion
        if any(self.starts[m] == self.starts[m + 1] and not self.terminal[m]
               for m in range(len(order))):
            return None  # no-deadlock
        if not self.backward(self.terminal, self.main, [not s for s in self.stop_arc]):
            return None  # can-end
        zero = [rules.zero_time(t) for t in range(len(net.transitions))]
        if not self.acyclic([zero[t] for t in self.trs]):
            return None  # no-zeno (a timer parameter without a value counts as 0 s)
        timed = [isinstance(t.timer, (int, float)) and float(t.timer) > 0
                 for t in net.transitions]
        if not self.acyclic([not timed[t] and not stop and bool(self.main[s])
                             for t, stop, s in zip(self.trs, self.stop_arc, self.src)]):
            return None  # instant-loop
        if not self.behaviours_hold():
            return None
        stop_safe = Result("stop-safe", True, "error", NO_STOP, how)
        if any(self.stop_arc):
            if not self.backward(self.terminal, self.stopped, None):
                return None
            stop_safe = Result("stop-safe", True, "error", HOLDS["stop-safe"],
                               how + ", stop region")

        def holds(name: str, method: str = how, severity: str = "error") -> Result:
            return Result(name, True, severity, HOLDS[name], method)

        return [holds("one-safe"), holds("proper-completion"), holds("no-deadlock"),
                holds("can-end", how + ", backward search"), holds("no-zeno"),
                holds("instant-loop", severity="warning"), holds("behaviours-off-at-end"),
                holds("behaviour-single-owner"), holds("dof-exclusive"),
                holds("no-disable-while-held"), stop_safe]

    def behaviours_hold(self) -> bool:
        """behaviours-off-at-end, behaviour-single-owner, dof-exclusive and
        no-disable-while-held hold."""
        net, holders, order = self.net, self.rules.holders, self.order
        on = {b: mask(places) for b, places in holders.items()}
        anything = mask(p for places in holders.values() for p in places)
        if any(t and m & anything for t, m in zip(self.terminal, order)):
            return False  # behaviours-off-at-end
        held = {m & anything for m in order}  # the behaviours' places marked: a few sets
        shared = [on[b] for b, places in holders.items()
                  if net.dofs.get(b) and len(places) > 1]
        dofs = sorted({d for b in holders for d in net.dofs.get(b, ())})
        groups = [[on[b] for b in sorted(holders) if d in net.dofs.get(b, ())] for d in dofs]
        for bits in shared:  # two of its places marked at once
            if any(x & (x - 1) for x in {m & bits for m in held}):
                return False  # behaviour-single-owner
        for group in (g for g in groups if len(g) > 1):  # two of its behaviours on at once
            union = 0
            for bits in group:
                union |= bits
            if any(sum(x & bits != 0 for bits in group) > 1 for x in {m & union for m in held}):
                return False  # dof-exclusive
        disables = [0] * len(net.transitions)  # the holders of what each one disables
        for t, tr in enumerate(net.transitions):
            for a in tr.actions:
                if a.kind == "disable" and net.dofs.get(a.behaviour) and holders.get(
                        a.behaviour):
                    disables[t] |= on[a.behaviour]
        return not any(order[d] & disables[t] for t, d in zip(self.trs, self.dst)
                       if disables[t])  # no-disable-while-held
