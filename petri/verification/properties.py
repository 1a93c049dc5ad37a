"""Verify a net compiled from MCL: the properties of docs/LANGUAGE.md, each with a counterexample.

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
terminates               every run ends: for a plain net, the main model has no reachable
                         cycle (a violation is a lasso: prefix, then the loop); a mission
                         decides it from its proved worst case (the ``terminates`` hook)
can-end                  main model: from every reachable marking an end can still be reached
no-zeno                  no cycle of immediate transitions and 0 s timers (a lasso)
instant-loop             no cycle without a timer of a positive delay: none spins at one
                         instant when the vehicle answers at once (a warning)
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

This module explores and decides the safety properties; its parts: the graph searches
(:mod:`petri.verification.graph`), the properties about ending
(:mod:`petri.verification.termination`), the behaviours in markings and transitions
(:mod:`petri.verification.behaviour_checks`), the results (:mod:`petri.verification.verdict`).
"""

from __future__ import annotations

import math
import time

import numpy as np

from petri.net import Net
from petri.semantics import Semantics
from petri.verification.behaviour_checks import (actions_match, behaviours_on, dof_conflicts,
                                                 dof_groups, names_on, shared_owner,
                                                 some_group)
from petri.verification.graph import Mask, ReachabilityGraph, Rows
from petri.verification.reachability import StateSpace, explore, shortest_path
from petri.verification.termination import (Termination, can_end, instant_loop, no_zeno,
                                            stop_safe, terminates)
from petri.verification.timed import TimedSpace, explore_timed
from petri.verification.verdict import (HOLDS, Result, Verdict, dead_transitions,
                                        explicit_method, nearest, step, undecided)

__all__ = ["TIMED_MAX_CLASSES", "Result", "Verdict", "actions_match", "step", "undecided",
           "verify"]

# The timed re-check of an untimed violation (pure Python, about 0.1 ms a class) stops here,
# and is not tried after a cut exploration: then the untimed verdict stands.
TIMED_MAX_CLASSES = 50_000


def verify(net: Net, max_markings: int = 5_000_000, keep_graph: bool = False,
           termination: Termination = terminates, max_bytes: float = math.inf,
           space: StateSpace | None = None) -> Verdict:
    """Explore the net's reachability graph (with the external stop) and decide every
    property of docs/SEMANTICS.md on it; a property a cut exploration cannot decide is
    undecided. With ``keep_graph`` the verdict keeps the graph (``Verdict.space``); without,
    it is not kept (a run that verifies first does not hold it in memory while it runs).
    ``termination`` decides ``terminates`` on the graph (default: the graph rule; a mission
    passes its own, from its proved worst case). The search stops, cut, where the next
    arrays would take it past ``max_bytes`` (petri/verification/reachability.py). ``space``:
    that exploration, when the caller made it already (petri/verification/all_hold.py)."""
    start = time.perf_counter()
    ss = space if space is not None else explore(net, max_markings=max_markings,
                                                 max_bytes=max_bytes)
    check = _Exploration(net, ss, Semantics(net))
    g, how, cut = check.graph, check.how, check.cut
    verdict = Verdict(net, ss.n_markings, len(ss.src), 0.0, space=ss if keep_graph else None)
    results = verdict.results
    results.append(check.safety("one-safe", np.flatnonzero(ss.markings.max(axis=1) > 1),
                                HOLDS["one-safe"], "a place can hold two tokens"))
    results.append(check.safety("proper-completion", np.flatnonzero(g.ended & (g.others > 1)),
                                HOLDS["proper-completion"],
                                "the mission can end with tokens left behind"))
    results.append(check.safety("no-deadlock", g.deadlocks(), HOLDS["no-deadlock"],
                                "the mission can get stuck"))
    results.append(termination(g, how, cut))
    results.append(can_end(g, how, cut))
    results.append(no_zeno(g, how, cut))
    results.append(instant_loop(g, how, cut))
    results += _behaviour_properties(check)
    results.append(_disable_while_held(check))
    results.append(stop_safe(g, how, cut))
    results.append(actions_match(net))
    fired = np.zeros(len(net.transitions), bool)
    fired[ss.transition] = True
    never = np.flatnonzero(~fired)
    verdict.dead_transitions = never.tolist()
    if cut:
        results.append(undecided("no-dead-transitions", cut, how, "warning"))
    else:
        results.append(dead_transitions(net, never.tolist(), how))
    for r in results:
        if r.witness is not None:
            verdict.witnesses[r.witness] = net.describe_marking(ss.markings[r.witness])
    verdict.seconds = time.perf_counter() - start
    return verdict


class _Exploration:
    """One exploration and what its properties share: the graph, how it was made (``how``,
    each result's method), why a cut one decides nothing that holds (``cut``, "" when
    complete), and the timed model, explored at the first need."""

    def __init__(self, net: Net, ss: StateSpace, rules: Semantics):
        self.net, self.ss, self.rules = net, ss, rules
        self.graph = ReachabilityGraph(ss, net, rules)
        reason = ss.stop_reason or "a limit was reached"
        self.how = (explicit_method(ss.n_markings, len(ss.src))
                    + ("" if ss.complete else f", CUT: {reason}"))
        self.cut = "" if ss.complete else (f"undecided: the exploration stopped ({reason}) "
                                           "before every marking was seen")
        self.timed: list[TimedSpace] = []

    def safety(self, name: str, bad: Rows, good: str, bad_msg: str,
               every: Rows | None = None) -> Result:
        """A property that fails at the ``bad`` markings. A violation seen in part of the
        graph is real; its absence proves nothing then. With ``every`` (every marking where
        the property fails, not only the nearest ones), timers may decide it instead."""
        if len(bad) == 0 and self.cut:
            return undecided(name, self.cut, self.how)
        if len(bad) and every is not None and not self.cut and (
                r := self.by_timers(name, every, good, bad_msg)):
            return r  # timers against timers decide it (docs/SEMANTICS.md §5)
        return nearest(self.ss, name, bad, good, bad_msg, self.how)

    def by_timers(self, name: str, rows: Rows, good: str, bad_msg: str | list[str],
                  via: list[int] | None = None) -> Result | None:
        """Re-check an untimed violation on the timed model (docs/SEMANTICS.md §5), given
        every bad marking (``rows``; with ``via``, every bad firing into them): it holds by
        the timers' values if none is reachable there, fails with a counterexample that some
        timing allows if one is (``bad_msg``, or ``bad_msg[k]`` for row k); None (keep the
        untimed verdict) if the timed exploration was cut, or not tried: it is tried only
        where timers can race (two timed transitions or more), since events may come at any
        moment."""
        net, ss = self.net, self.ss
        if sum(t.timer is not None for t in net.transitions) < 2:
            return None
        if not self.timed:
            limit = min(TIMED_MAX_CLASSES, 8 * ss.n_markings + 1_000)
            self.timed.append(explore_timed(net, stop=True, max_classes=limit))
        space = self.timed[0]
        method = f"{self.how}, re-checked on the timed model ({space.classes} state classes)"
        found = space.witness(ss.markings[rows], via)
        if found is not None:
            k, path = found
            message = bad_msg if isinstance(bad_msg, str) else bad_msg[k]
            return Result(name, False, "error", message, method, path, int(rows[k]))
        if not space.complete:
            return None
        return Result(name, True, "error", f"{good} (by the timers' values: the untimed "
                      "graph has it, no timing of the events allows it)", method)


def _behaviour_properties(check: _Exploration) -> list[Result]:
    """behaviours-off-at-end, behaviour-single-owner and dof-exclusive."""
    net, g = check.net, check.graph
    g.marked.keep([p for places in check.rules.holders.values() for p in places])
    on = behaviours_on(net, g.marked)
    left_on = np.flatnonzero(g.terminal & on.any(axis=1)) if on.size else np.array([], int)
    names = sorted({b for i in left_on for b in names_on(net, on[i])})
    shared, who = shared_owner(net, g.marked)
    conflict, what = dof_conflicts(net, on)
    holders = [ps for b, ps in check.rules.holders.items() if net.dofs.get(b)]
    return [
        check.safety("behaviours-off-at-end", left_on, HOLDS["behaviours-off-at-end"],
                     f"the mission can end with {', '.join(names)} still on"),
        check.safety("behaviour-single-owner", shared, HOLDS["behaviour-single-owner"],
                     f"{who} can be held on by two tasks at once: the first to end switches it "
                     "off under the other", some_group(g.marked, holders)),
        check.safety("dof-exclusive", conflict, HOLDS["dof-exclusive"],
                     f"two behaviours can drive {what} at once", some_group(on, dof_groups(net))),
    ]


def _disable_while_held(check: _Exploration) -> Result:
    """A firing that disables a behaviour driving a degree of freedom while another place
    still holds it: the line says "off", but a running task still drives it."""
    name = "no-disable-while-held"
    net, ss, g = check.net, check.ss, check.graph
    good = HOLDS[name]
    order = np.argsort(ss.transition, kind="stable")  # the arcs of each transition
    starts = np.searchsorted(ss.transition[order], np.arange(len(net.transitions) + 1))
    disables = [(t, a.behaviour) for t, tr in enumerate(net.transitions) for a in tr.actions
                if a.kind == "disable" and net.dofs.get(a.behaviour)
                and g.rules.holders.get(a.behaviour)]
    held = _held_after(check, disables, order, starts)
    bad: list[tuple[int, int, str]] = []  # every bad firing: its arc, transition, message
    for (t, behaviour), (arcs, after) in zip(disables, held):
        tr = net.transitions[t]
        where = f"{tr.origin.where()} {tr.origin.text}: " if tr.origin else ""
        why = (f"{where}disables {behaviour} while another task still holds it on (it "
               "stays on until that task ends)")
        bad += [(int(arc), t, why) for arc in arcs[after]]
    if not bad:
        return (undecided(name, check.cut, check.how) if check.cut
                else Result(name, True, "error", good, check.how))
    rows = np.array([int(ss.dst[arc]) for arc, _, _ in bad])
    if not check.cut and (r := check.by_timers(name, rows, good, [w for _, _, w in bad],
                                               [t for _, t, _ in bad])):
        return r
    arc, t, why = min(bad, key=lambda item: (int(ss.src[item[0]]), item[1]))  # the nearest
    src = int(ss.src[arc])
    path = (shortest_path(ss, np.array([src])) if src else []) + [t]
    return Result(name, False, "error", why, check.how, path, int(ss.dst[arc]))


def _held_after(check: _Exploration, disables: list[tuple[int, str]], order: Rows,
                starts: Rows) -> list[tuple[Rows, Mask]]:
    """For each (transition, behaviour) of ``disables``: the arcs that fire the transition
    and whether a place still holds the behaviour after each. One question of the markings
    per behaviour, not per transition (2,664 questions on a thousand-task mission)."""
    ss, g = check.ss, check.graph
    arcs = [order[starts[t]:starts[t + 1]] for t, _ in disables]
    out: list[tuple[Rows, Mask]] = [(a, np.zeros(0, bool)) for a in arcs]
    for behaviour in sorted({b for _, b in disables}):
        jobs = [i for i, (_, b) in enumerate(disables) if b == behaviour]
        rows = ss.dst[np.concatenate([arcs[i] for i in jobs])]
        holders = np.array(g.rules.holders[behaviour])
        held: Mask = (np.asarray(g.marked[np.ix_(rows, holders)].any(axis=1)) if len(rows)
                      else np.zeros(0, bool))
        bounds = np.cumsum([0] + [len(arcs[i]) for i in jobs])
        for i, lo, hi in zip(jobs, bounds[:-1], bounds[1:]):
            out[i] = (arcs[i], held[lo:hi])
    return out
