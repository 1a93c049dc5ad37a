"""Verify a net compiled from MCL: the properties of MCL.md §4, each with a counterexample.

One exploration of the reachability graph (the external stop ``Mission.abort`` included) is
split in two: the *main* model, where any awaited event or timer may happen at any moment and
nothing stops the mission from outside, and the *stop region*, reached by an external stop.
Properties (see docs/LANGUAGE.md):

=======================  =====================================================================
property                 holds when
=======================  =====================================================================
one-safe                 no reachable marking puts two tokens in one place
proper-completion        when the mission's ok or fail place is marked, nothing else is
                         (but the latched behaviours' state places)
no-deadlock              every marking without successors is a final marking
terminates               main model: from every reachable marking an end can be reached
                         (a violation is a lasso: prefix, then a loop that cannot end)
no-zeno                  no cycle of immediate transitions and 0 s timers (a lasso)
behaviours-off-at-end    at every final marking no behaviour is still on
behaviour-single-owner   no behaviour driving a degree of freedom is held by two places at once
                         (watchers are shared: on while any holder is marked)
dof-exclusive            no two behaviours driving the same degree of freedom are on together
no-disable-while-held    no firing disables a dof behaviour that another place still holds
stop-safe                stop region: from every marking an end can be reached
actions-match-behaviours each firing that turns a behaviour on (off) sends enable (disable)
no-dead-transitions      every transition can fire (a warning only)
=======================  =====================================================================

A violation found is real even when the exploration was cut; a property that a cut
exploration cannot establish is *undecided*, never printed as holding. A failed property comes
with the shortest firing sequence from the initial marking that shows it, in the mission's own
words (source line, task, event, actions).
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import numpy.typing as npt

from petri.net import Net
from petri.verification.reachability import StateSpace, explore, shortest_path
from petri.semantics import Semantics
from petri.verification.timed import TimedSpace, explore_timed

# The timed re-check of an untimed violation (pure Python, about 0.1 ms a class) stops here,
# and is not tried after a cut exploration: then the untimed verdict stands.
TIMED_MAX_CLASSES = 50_000


@dataclass
class Result:
    """One property's verdict. ``holds`` True: the method established it; False with
    ``undecided`` False: it established a violation; ``undecided`` True: the method could not
    establish either (``message`` says why) — never printed as holding or failing."""

    name: str
    holds: bool
    severity: str  # "error" | "warning"
    message: str
    method: str
    counterexample: list[int] | None = None  # transition indices from the initial marking
    witness: int | None = None  # the marking index the counterexample leads to
    undecided: bool = False
    cycle: list[int] | None = None  # a lasso's loop (after ``counterexample``, its prefix)

    @property
    def status(self) -> str:
        return "undecided" if self.undecided else ("holds" if self.holds else "fails")


def undecided(name: str, why: str, method: str, severity: str = "error") -> Result:
    """A property the method could not establish, and why."""
    return Result(name, False, severity, why, method, undecided=True)


@dataclass
class Verdict:
    net: Net
    markings: int
    arcs: int
    seconds: float
    results: list[Result] = field(default_factory=list)
    dead_transitions: list[int] = field(default_factory=list)

    @property
    def ok(self) -> bool:
        """Every error-level property was established to hold."""
        return all(r.holds or r.severity != "error" for r in self.results)

    @property
    def failed(self) -> bool:
        """Some error-level property was established to fail."""
        return any(r.status == "fails" and r.severity == "error" for r in self.results)

    @property
    def undecided(self) -> bool:
        """Nothing failed, but some error-level property could not be established."""
        return not self.failed and any(r.undecided and r.severity == "error"
                                       for r in self.results)

    witnesses: dict[int, str] = field(default_factory=dict)

    def witness_text(self, index: int) -> str:
        return self.witnesses.get(index, "")

    def to_json(self) -> dict[str, Any]:
        return {
            "verified": self.ok,
            "reachable_markings": self.markings,
            "reachability_arcs": self.arcs,
            "dead_transitions": [self.net.transitions[t].name for t in self.dead_transitions],
            "seconds": round(self.seconds, 4),
            "undecided": self.undecided,
            "properties": [{
                "property": r.name, "holds": r.holds, "status": r.status,
                "severity": r.severity, "message": r.message, "method": r.method,
                "counterexample": None if r.counterexample is None else
                [step(self.net, t) for t in r.counterexample],
                "cycle": None if r.cycle is None else [step(self.net, t) for t in r.cycle],
                "marking": None if r.witness is None else self.witness_text(r.witness),
            } for r in self.results],
        }


def step(net: Net, t: int) -> dict[str, Any]:
    """One firing of a counterexample, in the mission's terms."""
    tr = net.transitions[t]
    o = tr.origin
    return {"transition": tr.name, "label": tr.label, "event": tr.event, "timer": tr.timer,
            "actions": [str(a) for a in tr.actions],
            "file": o.file if o else None, "line": o.line if o else None,
            "col": o.col if o else None, "construct": o.text if o else None}


def verify(net: Net, max_markings: int = 5_000_000) -> Verdict:
    """Explore the net's reachability graph (with the external stop) and decide every
    property of SEMANTICS on it; a property a cut exploration cannot decide is undecided."""
    start = time.perf_counter()
    rules = Semantics(net)
    ss = explore(net, max_markings=max_markings)
    how = (f"explicit reachability graph ({len(ss.markings)} markings, {len(ss.src)} arcs)"
           + ("" if ss.complete else f", CUT: {ss.stop_reason or 'a limit was reached'}"))
    verdict = Verdict(net, len(ss.markings), len(ss.src), 0.0)
    g = _Graph(ss, net, rules)
    results = verdict.results
    reason = ss.stop_reason or "a limit was reached"
    cut = "" if ss.complete else (f"undecided: the exploration stopped ({reason}) before "
                                  "every marking was seen")

    timed: list[TimedSpace] = []  # the timed model, explored at the first need

    def safety(name: str, bad: npt.NDArray[np.int64], good: str, bad_msg: str,
               every: npt.NDArray[np.int64] | None = None) -> None:
        # a violation seen in part of the graph is real; its absence proves nothing then
        if len(bad) == 0 and cut:
            results.append(undecided(name, cut, how))
        elif len(bad) and every is not None and not cut and (
                r := _by_timers(net, ss, timed, name, every, good, bad_msg, how)):
            results.append(r)  # timers against timers decide it (SEMANTICS §5)
        else:
            results.append(_result(ss, name, bad, good, bad_msg, how, net))

    safety("one-safe", np.flatnonzero(ss.markings.max(axis=1) > 1),
           "every place holds at most one token", "a place can hold two tokens")
    safety("proper-completion", np.flatnonzero(g.ended & (g.others > 1)),
           "the mission ends with exactly one token, in its ok or fail place",
           "the mission can end with tokens left behind")
    safety("no-deadlock", g.deadlocks(), "no reachable marking is stuck before the mission ends",
           "the mission can get stuck")
    results.append(_terminates(g, how, cut))
    results.append(_no_zeno(g, how, cut))
    on = _behaviours_on(net, g.marked)
    left_on = np.flatnonzero(g.terminal & on.any(axis=1)) if on.size else np.array([], int)
    names = sorted({b for i in left_on for b in _names(net, on[i])})
    safety("behaviours-off-at-end", left_on, "no behaviour is left on when the mission ends",
           f"the mission can end with {', '.join(names)} still on")
    shared, who = _shared_owner(net, g.marked)
    safety("behaviour-single-owner", shared,
           "no behaviour driving a degree of freedom is held on by two tasks at once "
           "(watchers are shared: on until the last holder lets go)",
           f"{who} can be held on by two tasks at once: the first to end switches it off "
           "under the other",
           _some_group(g.marked, [ps for b, ps in rules.holders.items() if net.dofs.get(b)]))
    conflict, what = _dof_conflicts(net, on)
    safety("dof-exclusive", conflict,
           "no two behaviours driving the same degree of freedom are on together",
           f"two behaviours can drive {what} at once",
           _some_group(on, _dof_groups(net)))
    results.append(_disable_while_held(g, how, cut, timed))
    results.append(_stop_safe(g, how, cut))
    results.append(_actions_match(net))
    fired = np.zeros(len(net.transitions), bool)
    fired[np.unique(ss.transition)] = True
    never = np.flatnonzero(~fired)
    verdict.dead_transitions = never.tolist()
    if cut:
        results.append(undecided("no-dead-transitions", cut, how, "warning"))
    else:
        results.append(_dead(net, never, how))
    _describe_witnesses(verdict, ss)
    verdict.seconds = time.perf_counter() - start
    return verdict


class _Graph:
    """The reachability graph split the way the properties need it: the *main* model (the
    mission left to itself: no external stop) and the *stop* region (after Mission.abort)."""

    def __init__(self, ss: StateSpace, net: Net, rules: Semantics):
        self.ss, self.net, self.rules = ss, net, rules
        n = ss.n_markings
        self.n = n
        self.marked = _Marked(ss.markings)
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
        self.all_arcs = _Adjacency(n, ss.src, ss.dst)
        self.main_arcs = _Adjacency(n, ss.src[~self.stop_arc], ss.dst[~self.stop_arc],
                                    np.flatnonzero(~self.stop_arc))
        self.main = self.main_arcs.reach(np.array([0]))
        seeds = np.unique(ss.dst[self.stop_arc & self.main[ss.src]])
        self.stopped = self.all_arcs.reach(seeds) if len(seeds) else np.zeros(n, bool)

    def deadlocks(self) -> npt.NDArray[np.int64]:
        out = np.bincount(self.ss.src, minlength=self.n)
        dead = np.flatnonzero((out == 0) & ~self.terminal)
        return dead[dead < self.expanded]


class _Marked:
    """``markings > 0``, computed only for the rows and columns asked for (a full copy of a
    large state space would cost as much as the state space)."""

    def __init__(self, markings: npt.NDArray[np.unsignedinteger[Any]]):
        self.markings = markings

    def __len__(self) -> int:
        return int(self.markings.shape[0])

    def __getitem__(self, key: Any) -> npt.NDArray[np.bool_]:
        return np.asarray(self.markings[key] > 0)


class _Adjacency:
    """Forward and backward adjacency (CSR) of a set of arcs, with vectorised searches."""

    def __init__(self, n: int, src: npt.NDArray[np.int32], dst: npt.NDArray[np.int32],
                 ids: npt.NDArray[np.int64] | None = None):
        self.n = n
        self.ids = np.arange(len(src)) if ids is None else ids
        self.fwd = _csr(n, src, dst)
        self.bwd = _csr(n, dst, src)

    def reach(self, sources: npt.NDArray[np.integer[Any]], backward: bool = False,
              within: npt.NDArray[np.bool_] | None = None) -> npt.NDArray[np.bool_]:
        """The markings reachable from ``sources`` (or that reach them), inside ``within``."""
        starts, targets, _ = self.bwd if backward else self.fwd
        seen = np.zeros(self.n, bool)
        frontier = np.unique(np.asarray(sources, np.int64))
        seen[frontier] = True
        for _ in range(self.n + 1):  # each round adds at least one marking, or stops
            if len(frontier) == 0:
                break
            nxt = targets[_gather(starts, frontier)]
            keep = ~seen[nxt] if within is None else ~seen[nxt] & within[nxt]
            frontier = np.unique(nxt[keep])
            seen[frontier] = True
        return seen

    def path(self, source: int, goal: npt.NDArray[np.bool_],
             within: npt.NDArray[np.bool_] | None = None) -> tuple[list[int], int]:
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
            idx = _gather(starts, frontier)
            nxt, arc = targets[idx], arcs[idx]
            src = np.repeat(frontier, starts[frontier + 1] - starts[frontier])
            keep = ~seen[nxt] if within is None else ~seen[nxt] & within[nxt]
            nxt, arc, src = nxt[keep], arc[keep], src[keep]
            nxt, first = np.unique(nxt, return_index=True)
            arc, src = arc[first], src[first]
            seen[nxt], parent[nxt], via[nxt] = True, src, arc
            hit = nxt[goal[nxt]]
            if len(hit):
                at = end = int(hit[0])
                out = []
                for _ in range(self.n + 1):
                    out.append(int(via[at]))
                    at = int(parent[at])
                    if at == source and out:
                        break
                return [int(self.ids[a]) for a in out[::-1]], end
            frontier = nxt
        return [], -1


def _csr(n: int, src: npt.NDArray[np.int32], dst: npt.NDArray[np.int32]
         ) -> tuple[npt.NDArray[np.int64], npt.NDArray[np.int64], npt.NDArray[np.int64]]:
    order = np.argsort(src, kind="stable")
    starts = np.zeros(n + 1, np.int64)
    np.cumsum(np.bincount(src, minlength=n), out=starts[1:])
    return starts, dst[order].astype(np.int64), order.astype(np.int64)


def _gather(starts: npt.NDArray[np.int64], nodes: npt.NDArray[np.int64]
            ) -> npt.NDArray[np.int64]:
    """Indices of every arc leaving ``nodes`` in a CSR layout, without a Python loop."""
    lo, hi = starts[nodes], starts[nodes + 1]
    lens = hi - lo
    total = int(lens.sum())
    if total == 0:
        return np.zeros(0, np.int64)
    offsets = np.repeat(lo - np.concatenate(([0], np.cumsum(lens)[:-1])), lens)
    return offsets + np.arange(total)


def _lasso(g: _Graph, adj: _Adjacency, bad: npt.NDArray[np.bool_], src: npt.NDArray[np.int32],
           dst: npt.NDArray[np.int32], reach: _Adjacency
           ) -> tuple[int, list[int], list[int]] | None:
    """A marking of ``bad`` that lies on a cycle of ``adj``'s arcs inside ``bad``: the
    shortest firing sequence to it over ``reach``'s arcs, and the cycle (transitions)."""
    # markings of bad on a cycle within bad: peel those with no predecessor, then those
    # with no successor, left inside bad (Kahn's algorithm both ways)
    inside = bad[src] & bad[dst]
    alive = bad.copy()
    for s, d in ((src[inside], dst[inside]), (dst[inside], src[inside])):
        degree = np.bincount(d[alive[s] & alive[d]], minlength=g.n)
        fwd = _csr(g.n, s, d)
        frontier = np.flatnonzero(alive & (degree == 0))
        for _ in range(g.n + 1):
            if len(frontier) == 0:
                break
            alive[frontier] = False
            nxt = fwd[1][_gather(fwd[0], frontier)]
            np.subtract.at(degree, nxt, 1)
            nxt = np.unique(nxt)
            frontier = nxt[alive[nxt] & (degree[nxt] == 0)]
    candidates = np.flatnonzero(alive)  # BFS order: the first are the nearest
    if len(candidates) == 0:
        return None
    goal = np.zeros(g.n, bool)
    for m in candidates[:64]:
        goal[:] = False
        goal[m] = True
        cycle, _ = adj.path(int(m), goal, within=bad)
        if cycle:
            prefix, _ = reach.path(0, goal) if m != 0 else ([], m)
            trans = g.ss.transition
            return int(m), [int(trans[a]) for a in prefix], [int(trans[a]) for a in cycle]
    return None


def _terminates(g: _Graph, how: str, cut: str) -> Result:
    name = "terminates"
    if cut:
        return undecided(name, cut, how)
    can_end = g.main_arcs.reach(np.flatnonzero(g.terminal & g.main), backward=True,
                                within=g.main)
    bad = g.main & ~can_end
    if not bad.any():
        return Result(name, True, "error", "from every reachable marking the mission ends "
                      "by itself (no external stop needed)", how + ", backward search")
    main = ~g.stop_arc
    lasso = _lasso(g, g.main_arcs, bad, g.ss.src[main], g.ss.dst[main], g.main_arcs)
    if lasso is None:  # every marking that cannot end is stuck: no-deadlock says where
        first = int(np.flatnonzero(bad).min())
        return Result(name, False, "error", "the mission can get stuck before it ends",
                      how, shortest_path(g.ss, np.array([first])), first)
    at, prefix, cycle = lasso
    return Result(name, False, "error", _why_endless(g.net, cycle), how, prefix, at,
                  cycle=cycle)


def _why_endless(net: Net, cycle: list[int]) -> str:
    loops = [o for o in (net.transitions[t].origin for t in cycle)
             if o is not None and o.kind == "WHILE"]
    if loops:
        o = loops[0]
        cond = o.text.removeprefix("WHILE").strip().removeprefix("{").removesuffix("}")
        return (f"the WHILE at line {o.line} cannot end: its condition `{cond.strip()}` can "
                "never fail and its body never fails, so it goes round for ever")
    return "the mission can go round for ever without ending (no external stop)"


def _no_zeno(g: _Graph, how: str, cut: str) -> Result:
    """A loop of zero-time firings. A timer whose parameter has no value yet may be 0 s: a
    loop that needs one is undecided (it depends on the value), not a violation."""
    name = "no-zeno"
    for arcs, certain in ((g.zero_arc, True), (g.maybe_zero_arc, False)):
        lasso = _zero_lasso(g, arcs) if arcs.any() else None
        if lasso is None:
            continue
        at, prefix, cycle = lasso
        lines = [o.line for o in (g.net.transitions[t].origin for t in cycle)
                 if o is not None and o.kind == "WHILE"]
        where = f"the WHILE at line {lines[0]}" if lines else "a loop"
        if not certain:
            params = sorted({str(g.net.transitions[t].timer) for t in cycle
                             if isinstance(g.net.transitions[t].timer, str)})
            return undecided(name, f"{where} goes round without time passing if the timer "
                             f"parameter {', '.join(params)} is 0 s: give it a value", how)
        return Result(name, False, "error", f"{where} can go round without time passing "
                      "(instant tasks and 0 s timers only): the player would spin; make each "
                      "round wait for an event or a timer > 0", how, prefix, at, cycle=cycle)
    if cut:
        return undecided(name, cut, how)
    return Result(name, True, "error", "no loop can go round without time passing", how)


def _zero_lasso(g: _Graph, zero: npt.NDArray[np.bool_]
                ) -> tuple[int, list[int], list[int]] | None:
    bad = np.zeros(g.n, bool)
    bad[g.ss.src[zero]] = True
    adj = _Adjacency(g.n, g.ss.src[zero], g.ss.dst[zero], np.flatnonzero(zero))
    return _lasso(g, adj, bad, g.ss.src[zero], g.ss.dst[zero], g.all_arcs)


def _disable_while_held(g: _Graph, how: str, cut: str, timed: list[TimedSpace]) -> Result:
    """A firing that disables a behaviour driving a degree of freedom while another place
    still holds it: the line says "off", but a running task still drives it."""
    name = "no-disable-while-held"
    net, ss = g.net, g.ss
    good = "no task switches off a behaviour another task holds"
    order = np.argsort(ss.transition, kind="stable")  # the arcs of each transition
    starts = np.searchsorted(ss.transition[order], np.arange(len(net.transitions) + 1))
    bad: list[tuple[int, int, str]] = []  # every bad firing: its arc, transition, message
    for t, tr in enumerate(net.transitions):
        for a in tr.actions:
            holders = g.rules.holders.get(a.behaviour, [])
            if a.kind != "disable" or not net.dofs.get(a.behaviour) or not holders:
                continue
            arcs = order[starts[t]:starts[t + 1]]
            held = ss.markings[np.ix_(ss.dst[arcs], np.array(holders))].any(axis=1)
            where = f"{tr.origin.where()} {tr.origin.text}: " if tr.origin else ""
            why = (f"{where}disables {a.behaviour} while another task still holds it on (it "
                   "stays on until that task ends)")
            bad += [(int(arc), t, why) for arc in arcs[held]]
    if not bad:
        return undecided(name, cut, how) if cut else Result(name, True, "error", good, how)
    rows = np.array([int(ss.dst[arc]) for arc, _, _ in bad])
    if not cut and (r := _by_timers(net, ss, timed, name, rows, good, [w for _, _, w in bad],
                                    how, [t for _, t, _ in bad])):
        return r
    arc, t, why = min(bad, key=lambda item: (int(ss.src[item[0]]), item[1]))  # the nearest
    src = int(ss.src[arc])
    path = (shortest_path(ss, np.array([src])) if src else []) + [t]
    return Result(name, False, "error", why, how, path, int(ss.dst[arc]))


def _stop_safe(g: _Graph, how: str, cut: str) -> Result:
    """The external stop: from wherever it comes, the mission then ends with nothing on."""
    name = "stop-safe"
    if cut:
        return undecided(name, cut, how)
    if not g.stop_arc.any():
        return Result(name, True, "error", "the mission has no external stop to check", how)
    can_end = g.all_arcs.reach(np.flatnonzero(g.terminal & g.stopped), backward=True,
                               within=g.stopped)
    bad = np.flatnonzero(g.stopped & ~can_end)
    if len(bad):
        return _result(g.ss, name, bad, "", "after an external stop the mission can fail to "
                       "end", how + ", stop region", g.net)
    return Result(name, True, "error", "an external stop (operator, uncaught Link.lost, a "
                  "limit) from any reachable marking ends the mission with every behaviour "
                  "off", how + ", stop region")


def _by_timers(net: Net, ss: StateSpace, timed: list[TimedSpace], name: str,
               rows: npt.NDArray[np.int64], good: str, bad_msg: str | list[str], how: str,
               via: list[int] | None = None) -> Result | None:
    """Re-check an untimed violation on the timed model (SEMANTICS §5), given every bad
    marking (``rows`` of ``ss``; with ``via``, every bad firing into them): it holds by the
    timers' values if none is reachable there, fails with a counterexample that some timing
    allows if one is (``bad_msg``, or ``bad_msg[k]`` for row k); None (keep the untimed
    verdict) if the timed exploration was cut, or not tried: it is tried only where timers
    can race (two timed transitions or more), since events may come at any moment."""
    if sum(t.timer is not None for t in net.transitions) < 2:
        return None
    if not timed:
        limit = min(TIMED_MAX_CLASSES, 8 * ss.n_markings + 1_000)
        timed.append(explore_timed(net, stop=True, max_classes=limit))
    space = timed[0]
    method = f"{how}, re-checked on the timed model ({space.classes} state classes)"
    found = space.witness(ss.markings[rows], via)
    if found is not None:
        k, path = found
        message = bad_msg if isinstance(bad_msg, str) else bad_msg[k]
        return Result(name, False, "error", message, method, path, int(rows[k]))
    if not space.complete:
        return None
    return Result(name, True, "error", f"{good} (by the timers' values: the untimed graph "
                  "has it, no timing of the events allows it)", method)


def _some_group(marked: _Marked | npt.NDArray[np.bool_], groups: list[list[int]]
                ) -> npt.NDArray[np.int64]:
    """Rows in which two columns of some group are true."""
    bad = np.zeros(len(marked), bool)
    for cols in groups:
        bad |= marked[:, cols].sum(axis=1) > 1
    return np.flatnonzero(bad)


def _dof_groups(net: Net) -> list[list[int]]:
    """For each degree of freedom, the columns of ``_behaviours_on`` that drive it."""
    behaviours = sorted({b for p in net.places for b in p.behaviours})
    dofs = sorted({d for b in behaviours for d in net.dofs.get(b, ())})
    return [[i for i, b in enumerate(behaviours) if d in net.dofs.get(b, ())] for d in dofs]


def _dead(net: Net, never: npt.NDArray[np.int64], how: str) -> Result:
    origins = [(net.transitions[t].origin, net.transitions[t].name) for t in never]
    tasks_never = sorted({(o.line, o.text) for o, name in origins
                          if o is not None and o.kind == "task" and name.endswith(".start")})
    if len(never) == 0:
        return Result("no-dead-transitions", True, "warning", "every transition can fire", how)
    msg = (f"{len(never)} of {len(net.transitions)} transitions never fire "
           "(template paths this mission cannot take)")
    if tasks_never:
        msg += "; tasks that can never start: " + ", ".join(
            f"{text} (line {line})" for line, text in tasks_never)
    return Result("no-dead-transitions", False, "warning", msg, how)


def _actions_match(net: Net) -> Result:
    """A static check of each transition: a behaviour that a firing turns on (its output
    places record it, its input places did not) must be enabled by the firing's actions, and
    one it turns off must be disabled by them. This catches a forgotten stop action."""
    for tr in net.transitions:
        before = {b for p, _ in tr.inputs for b in net.places[p].behaviours}
        after = {b for p, _ in tr.outputs for b in net.places[p].behaviours}
        enabled = {a.behaviour for a in tr.actions if a.kind == "enable"}
        disabled = {a.behaviour for a in tr.actions if a.kind == "disable"}
        problem = ""
        if missing := sorted((after - before) - enabled):
            problem = f"switches {', '.join(missing)} on without an enable action"
        elif missing := sorted((before - after) - disabled):
            problem = f"switches {', '.join(missing)} off without a disable action"
        elif stray := sorted(enabled - after):
            problem = (f"enables {', '.join(stray)} but no place records it on: it stays on "
                       "unseen (declare the task's behaviour as latched, or disable it in stop)")
        if problem:
            where = f"{tr.origin.where()} {tr.origin.text}: " if tr.origin else ""
            return Result("actions-match-behaviours", False, "error",
                          f"{where}transition {tr.name} {problem}",
                          "static check of every transition")
    return Result("actions-match-behaviours", True, "error",
                  "every firing that turns a behaviour on or off sends the action that does it",
                  "static check of every transition")


def _result(ss: StateSpace, name: str, bad: npt.NDArray[np.int64], good: str, bad_msg: str,
            method: str, net: Net) -> Result:
    if len(bad) == 0:
        return Result(name, True, "error", good, method)
    target = int(bad.min())  # markings are numbered in BFS order: the first is the nearest
    path = shortest_path(ss, np.array([target]))
    return Result(name, False, "error", bad_msg, method, path, target)


def _describe_witnesses(verdict: Verdict, ss: StateSpace) -> None:
    for r in verdict.results:
        if r.witness is not None:
            verdict.witnesses[r.witness] = verdict.net.describe_marking(ss.markings[r.witness])


def _behaviours_on(net: Net, marked: _Marked) -> npt.NDArray[np.bool_]:
    """Which behaviours are on in each marking (a column per behaviour, sorted by name)."""
    behaviours = sorted({b for p in net.places for b in p.behaviours})
    on = np.zeros((len(marked), len(behaviours)), bool)
    for i, b in enumerate(behaviours):
        cols = [p for p, place in enumerate(net.places) if b in place.behaviours]
        on[:, i] = marked[:, cols].any(axis=1)
    return on


def _names(net: Net, row: npt.NDArray[np.bool_]) -> list[str]:
    behaviours = sorted({b for p in net.places for b in p.behaviours})
    return [b for b, on in zip(behaviours, row) if on]


def _shared_owner(net: Net, marked: _Marked
                  ) -> tuple[npt.NDArray[np.int64], str]:
    first: npt.NDArray[np.int64] = np.array([], np.int64)
    who = ""
    for b in sorted({b for p in net.places for b in p.behaviours}):
        if not net.dofs.get(b):  # a watcher: several holders share it (on until the last)
            continue
        cols = [p for p, place in enumerate(net.places) if b in place.behaviours]
        if len(cols) < 2:
            continue
        bad = np.flatnonzero(marked[:, cols].sum(axis=1) > 1)
        if len(bad) and (len(first) == 0 or bad.min() < first.min()):
            first, who = bad, b
    return first, who


def _dof_conflicts(net: Net, on: npt.NDArray[np.bool_]) -> tuple[npt.NDArray[np.int64], str]:
    behaviours = sorted({b for p in net.places for b in p.behaviours})
    dofs = sorted({d for b in behaviours for d in net.dofs.get(b, ())})
    first: npt.NDArray[np.int64] = np.array([], np.int64)
    what = ""
    for d in dofs:
        cols = [i for i, b in enumerate(behaviours) if d in net.dofs.get(b, ())]
        if len(cols) < 2:
            continue
        bad = np.flatnonzero(on[:, cols].sum(axis=1) > 1)
        if len(bad) and (len(first) == 0 or bad.min() < first.min()):
            first = bad
            row = on[bad.min()]
            what = f"{d} ({' and '.join(behaviours[c] for c in cols if row[c])})"
    return first, what


def _steps(steps: list[dict[str, Any]], first: int) -> list[str]:
    lines = []
    for i, s in enumerate(steps, first):
        where = f"{s['file']}:{s['line']}:{s['col']}" if s["file"] else ""
        extra = f" on {s['event']}" if s["event"] else ""
        extra += f" after {s['timer']} s" if s["timer"] is not None else ""
        acts = f"  [{'; '.join(s['actions'])}]" if s["actions"] else ""
        lines.append(f"         {i:3}. {where}  {s['construct']}: {s['label']}{extra}{acts}")
    return lines


def format_text(report: dict[str, Any]) -> str:
    """The verification part of ``mclc``'s text output."""
    lines = []
    head = ("verified" if report["verified"] else
            "UNDECIDED" if report.get("undecided") else "NOT verified")
    if report["reachable_markings"]:
        lines.append(f"  {head}: {report['reachable_markings']} reachable markings, "
                     f"{report['reachability_arcs']} arcs, {report['seconds']:.3f} s")
    else:
        lines.append(f"  {head} by construction and static analysis (the state space is "
                     f"not enumerated), {report['seconds']:.3f} s")
    for r in report["properties"]:
        status = r.get("status", "holds" if r["holds"] else "fails")
        mark = ("ok  " if status == "holds" else "????" if status == "undecided"
                else "FAIL" if r["severity"] == "error" else "warn")
        lines.append(f"  [{mark}] {r['property']}: {r['message']}")
        if r["counterexample"] is not None:
            lines.append("         shortest firing sequence from the start:"
                         if not r.get("cycle") else
                         "         shortest firing sequence to the loop:")
            lines += _steps(r["counterexample"], 1)
            if r.get("cycle"):
                lines.append("         then round and round for ever:")
                lines += _steps(r["cycle"], len(r["counterexample"]) + 1)
            if r.get("marking"):
                lines.append(f"         reaching the marking {r['marking']}")
    methods = sorted({r["method"] for r in report["properties"]})
    for m in methods:
        names = [r["property"] for r in report["properties"] if r["method"] == m]
        lines.append(f"  method for {', '.join(names)}: {m}" if len(methods) > 1
                     else f"  method: {m}")
    return "\n".join(lines)
