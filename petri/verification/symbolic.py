"""Symbolic reachability of 1-safe place/transition nets with binary decision diagrams.

For state spaces too large to enumerate (Philosophers-PT-000020 has 3.5e9 markings) the set of
reachable markings is one BDD over one Boolean variable per place ("marked"). It uses the ``dd``
package: ``dd.cudd`` (CUDD, compiled) when its wheel has it, else the pure-Python ``dd.autoref``.

Firing a transition t with input places I and output places O, on a set S of 1-safe markings::

    image(S, t) = (S restricted to I = 1 and O \\ I = 0) and (I \\ O = 0) and (O = 1)

The restriction is a BDD cofactor, so no relation BDD and no primed variables are needed. The
fixpoint is computed by chaining: within a round each transition's image is added to the set
straight away, so later transitions in the round already fire from the new markings.

A 1-safe net never fires t when an output place outside I is marked (the place would then hold
two tokens). The restriction above drops those markings, so the fixpoint is exact only if no
reachable marking enables such a firing; this is checked at the end, and when it fails the net
is not 1-safe and :class:`NotOneSafe` is raised (use the explicit search for such nets).

Counts (markings, arcs) are exact Python integers: CUDD's own count is a double, exact below
2**53; larger counts are made by walking the BDD (:class:`ExactCounter`).
"""

from __future__ import annotations

import time
from collections import deque
from dataclasses import dataclass, field
from typing import Any

from petri.net import Net

Bdd = Any  # dd.cudd.BDD or dd.autoref.BDD
Node = Any  # a BDD node (dd Function)


class SymbolicLimit(Exception):
    """The symbolic search ran out of its time budget."""


class NotOneSafe(Exception):
    """The net is not 1-safe: the symbolic route does not apply."""

    def __init__(self, message: str, transition: int | None = None) -> None:
        super().__init__(message)
        self.transition = transition


@dataclass
class SymbolicResult:
    markings: int
    arcs: int
    max_tokens: int
    deadlock_reachable: bool
    dead_transitions: list[int]  # transition indices
    one_safe: bool
    rounds: int  # chaining rounds to the fixpoint
    bdd_nodes: int  # nodes of the reachable-set BDD
    backend: str  # "cudd" or "autoref"
    order: list[int] = field(default_factory=list)  # place indices, top variable first
    seconds: float = 0.0


def available() -> bool:
    """Is the ``dd`` package installed?"""
    try:
        import dd  # noqa: F401
    except ImportError:
        return False
    return True


def new_bdd() -> tuple[Bdd, str]:
    try:
        from dd import cudd
        return cudd.BDD(), "cudd"
    except ImportError:  # the dd wheel without CUDD: pure Python, slower
        from dd import autoref
        return autoref.BDD(), "autoref"


def is_candidate(net: Net) -> bool:
    """Could the net be 1-safe? (Initial marking and output arc weights at most 1.)"""
    return (all(n <= 1 for n in net.initial.values())
            and all(w == 1 for t in net.transitions for _, w in t.outputs))


def variable_order(net: Net, rounds: int = 30) -> list[int]:
    """A place order that keeps each transition's places close together.

    Start from a breadth-first (Cuthill-McKee-like) order of the graph in which two places are
    neighbours when a transition touches both, then improve it with the FORCE heuristic: move
    each place to the mean centre of the transitions it touches, re-sort, and keep the order with
    the smallest total span (sum over transitions of last minus first position).
    """
    n_places = len(net.places)
    groups = [sorted({p for p, _ in t.inputs} | {p for p, _ in t.outputs})
              for t in net.transitions]
    groups = [g for g in groups if g]
    order = _bfs_order(n_places, groups)
    best, best_span = order, _span(order, groups)
    for _ in range(rounds):
        position = {p: i for i, p in enumerate(order)}
        centre = [sum(position[p] for p in g) / len(g) for g in groups]
        pull: list[list[float]] = [[] for _ in range(n_places)]
        for g, c in zip(groups, centre):
            for p in g:
                pull[p].append(c)
        target = [sum(c) / len(c) if c else position[p] for p, c in enumerate(pull)]
        order = sorted(range(n_places), key=lambda p: (target[p], position[p]))
        span = _span(order, groups)
        if span < best_span:
            best, best_span = order, span
    return best


def _bfs_order(n_places: int, groups: list[list[int]]) -> list[int]:
    neighbours: list[set[int]] = [set() for _ in range(n_places)]
    for g in groups:
        for p in g:
            neighbours[p].update(g)
    seen = [False] * n_places
    order: list[int] = []
    by_degree = sorted(range(n_places), key=lambda p: len(neighbours[p]))
    for start in by_degree:  # one BFS per connected component
        if seen[start]:
            continue
        seen[start] = True
        queue = deque([start])
        while queue:  # each place enters the queue once
            p = queue.popleft()
            order.append(p)
            for q in sorted(neighbours[p], key=lambda q: len(neighbours[q])):
                if not seen[q]:
                    seen[q] = True
                    queue.append(q)
    return order


def _span(order: list[int], groups: list[list[int]]) -> int:
    position = {p: i for i, p in enumerate(order)}
    return sum(max(position[p] for p in g) - min(position[p] for p in g) for g in groups)


class ExactCounter:
    """Exact model counts of BDDs of one manager over its ``n_vars`` variables.

    Walks each DAG once, memoising the count of every regular node over the variables from
    its level down; the memo is shared between calls, so counting many sets that share most
    of their nodes (the reachable set and its restrictions to each transition's guard) costs
    little more than counting one. CUDD uses complemented edges: a negated node has the
    models its regular node lacks. The counted roots are kept alive, so that no memoised node
    is freed and its address reused while the counter exists.
    """

    def __init__(self, bdd: Bdd, n_vars: int) -> None:
        self.bdd = bdd
        self.n_vars = n_vars
        self.memo: dict[int, int] = {}
        self.roots: list[Node] = []

    def _level(self, v: Node) -> int:
        return self.n_vars if v == self.bdd.true or v == self.bdd.false else int(v.level)

    def _signed(self, v: Node) -> int:
        """Models of ``v`` over the variables from its level down."""
        if v == self.bdd.true:
            return 1
        if v == self.bdd.false:
            return 0
        if v.negated:
            return (1 << (self.n_vars - self._level(v))) - self.memo[int(~v)]
        return self.memo[int(v)]

    def count(self, u: Node) -> int:
        self.roots.append(u)
        bdd, memo = self.bdd, self.memo
        if u != bdd.true and u != bdd.false:
            stack: list[tuple[Node, bool]] = [(~u if u.negated else u, False)]
            while stack:  # post-order over regular nodes: each pushed at most twice
                v, ready = stack.pop()
                if int(v) in memo:
                    continue
                low, high = v.low, v.high
                if ready:
                    here = self._level(v)
                    memo[int(v)] = sum(self._signed(c) << (self._level(c) - here - 1)
                                       for c in (low, high))
                    continue
                stack.append((v, True))
                for child in (low, high):
                    if child != bdd.true and child != bdd.false:
                        regular = ~child if child.negated else child
                        if int(regular) not in memo:
                            stack.append((regular, False))
        return self._signed(u) << self._level(u)


def _counter(bdd: Bdd, backend: str, n_vars: int) -> Any:
    """A ``count(u)`` giving exact model counts over the ``n_vars`` variables.

    dd.autoref counts with Python integers. CUDD counts with doubles, and its count is exact
    whenever it is below 2**53: ``ddCountMintermAux`` memoises on the edge (complement bit
    included) and never computes |not f| as 2**n - |f|, so every intermediate value is
    |g| * 2**k for a cofactor g of the counted function (|g| <= |f|) and a power of two 2**k,
    exact in a double. Larger counts are walked again in Python (:class:`ExactCounter`).
    """
    if backend != "cudd":
        return lambda u: int(bdd.count(u, nvars=n_vars))
    exact = ExactCounter(bdd, n_vars)

    def count(u: Node) -> int:
        fast = bdd.count(u, nvars=n_vars)
        return int(fast) if fast < 2.0**53 else exact.count(u)

    return count


def explore(net: Net, max_rounds: int = 100_000, time_limit: float | None = None,
            max_bytes: float | None = None) -> SymbolicResult:
    """Reachable markings of a 1-safe net as a BDD; raise :class:`NotOneSafe` otherwise.

    Raises :class:`SymbolicLimit` when ``time_limit`` seconds pass before the fixpoint (it is
    checked between two transition images, so one image may overrun it), or when CUDD would
    take more than ``max_bytes`` (its ``max_memory``: it refuses the node it cannot make, and
    dd says so with a ValueError about a NULL node).
    """
    try:
        return _explore(net, max_rounds, time_limit, max_bytes)
    except ValueError as exc:
        if max_bytes is None or "NULL" not in str(exc):
            raise
        raise SymbolicLimit(f"the BDDs outgrew the memory budget of "
                            f"{max_bytes / 2**20:,.0f} MiB") from None


def _explore(net: Net, max_rounds: int, time_limit: float | None,
             max_bytes: float | None) -> SymbolicResult:
    start = time.perf_counter()
    deadline = None if time_limit is None else start + time_limit
    if not is_candidate(net):
        raise NotOneSafe("the initial marking or an output arc puts 2+ tokens in a place")
    bdd, backend = new_bdd()
    order = variable_order(net)
    names = [f"p{p}" for p in range(len(net.places))]
    bdd.declare(*(names[p] for p in order))
    if backend == "cudd":
        bdd.configure(reordering=False)  # the static order is good; sifting costs time
        if max_bytes is not None:
            bdd.configure(max_memory=int(max_bytes))
    initial = bdd.cube({names[p]: net.initial.get(p, 0) > 0 for p in range(len(net.places))})
    fire = [_Firing(bdd, names, t) for t in net.transitions]

    reached, rounds = initial, 0
    for rounds in range(1, max_rounds + 1):  # chaining: usually a few dozen rounds
        before = reached
        for f in fire:
            if f.possible:
                reached = reached | f.image(bdd, reached)
            if deadline is not None and time.perf_counter() > deadline:
                raise SymbolicLimit(f"no fixpoint within {time_limit} s ({rounds} rounds, "
                                    f"{len(reached)} BDD nodes)")
        if reached == before:
            break
    else:
        raise RuntimeError(f"no fixpoint after {max_rounds} rounds")

    for t, f in enumerate(fire):
        if f.possible and (reached & f.unsafe) != bdd.false:
            raise NotOneSafe(f"firing {net.transitions[t].name!r} can put a second token in "
                             "a place", t)
    enabled = [reached & f.enabled if f.possible else bdd.false for f in fire]
    count = _counter(bdd, backend, len(names))
    dead = reached  # reachable markings that enable no transition
    for f in fire:  # (the union of all guards can be a big BDD: restrict step by step)
        if f.possible:
            dead = dead & ~f.enabled
    empty = bdd.cube({v: False for v in names})
    return SymbolicResult(
        markings=count(reached),
        arcs=sum(count(e) for e in enabled),
        max_tokens=1 if (reached & ~empty) != bdd.false else 0,
        deadlock_reachable=dead != bdd.false,
        dead_transitions=[t for t, e in enumerate(enabled) if e == bdd.false],
        one_safe=True,
        rounds=rounds,
        bdd_nodes=len(reached),
        backend=backend,
        order=order,
        seconds=time.perf_counter() - start,
    )


class _Firing:
    """One transition's guard and effect as BDD cubes and cofactor assignments."""

    def __init__(self, bdd: Bdd, names: list[str], transition: Any) -> None:
        ins = {p for p, _ in transition.inputs}
        outs = {p for p, _ in transition.outputs}
        # An input arc of weight 2+ needs 2 tokens: never enabled in a 1-safe net.
        self.possible = all(w == 1 for _, w in transition.inputs)
        self.enabled = bdd.cube({names[p]: True for p in ins})
        self.guard = {names[p]: True for p in ins} | {names[p]: False for p in outs - ins}
        self.effect = bdd.cube({names[p]: False for p in ins - outs}
                               | {names[p]: True for p in outs})
        marked_output = bdd.false
        for p in outs - ins:
            marked_output = marked_output | bdd.var(names[p])
        self.unsafe = self.enabled & marked_output
        self.changes = bool(ins ^ outs)

    def image(self, bdd: Bdd, states: Node) -> Node:
        if not self.guard:  # no input, no output place: the marking stays as it is
            return states
        return bdd.let(self.guard, states) & self.effect
