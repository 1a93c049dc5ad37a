"""Choosing how to verify a compiled mission: explicit, structural, or auto.

* ``explicit`` (petri/verification/properties.py): every reachable marking, exact, with
  counterexamples; stops at a limit of markings (derived from the memory budget too) and then
  says undecided for what the part it saw cannot decide.
* ``structural`` (mcl/analysis/structural.py): templates verified with generic children,
  outcomes and behaviours decided on the syntax tree; never enumerates the mission's state
  space.
* ``auto``: estimates the explicit route's memory (estimated markings × bytes per marking,
  plus the net itself) against the budget; under it, runs the explicit route with a marking
  limit that keeps it under the budget, and if that exploration is cut, completes the verdict
  with the structural route (a violation the explicit route saw stays: it is real); over it,
  runs the structural route. It never exhausts memory and never fails for want of it: should
  the estimate fall short and the explicit route meet a MemoryError, auto takes the structural
  route and explicit says undecided. ``mclc --max-memory`` sets the budget (default 1 GiB).

Each property's ``method`` says which route established it.
"""

from __future__ import annotations

import time
from typing import TYPE_CHECKING

from petri.net import Net
from petri.verification.actions import actions_match
from petri.verification.all_hold import all_hold, explored, state_space
from petri.verification.verdict import Result, Verdict, undecided

from mcl.analysis import size, termination

if TYPE_CHECKING:
    from petri.verification.graph import ReachabilityGraph

    from mcl.api import Compiled

METHODS = ("auto", "explicit", "structural")
MAX_MARKINGS = 5_000_000
MAX_BYTES = 1 << 30  # the memory the explicit route may use: 1 GiB
# The explicit route holds each marking as a row of one byte per place (padded to 8 bytes),
# and its analyses make a few copies of that matrix (booleans, behaviours on); the arcs of
# the graph (three 32-bit integers each, a few arcs per marking) come on top.
COPIES = 4
ARC_BYTES = 12 * 4  # bytes of arcs per marking (about four arcs per marking)


def bytes_per_marking(net: Net) -> int:
    """One byte per place, rounded up to whole 8-byte words."""
    return -(-len(net.places) // 8) * 8


def explicit_cost(net: Net, markings: float) -> float:
    """Bytes the explicit route needs for ``markings`` markings of ``net``."""
    per = bytes_per_marking(net) * COPIES + ARC_BYTES
    return markings * per + net_bytes(net)


def net_bytes(net: Net) -> float:
    """Bytes of the net itself as the explicit route holds it: its arcs, places and
    transitions, a few words each."""
    return 64.0 * (net.arc_count() + len(net.places) + len(net.transitions))


def marking_limit(net: Net, max_markings: int, max_bytes: int) -> int:
    """The most markings the explicit route may enumerate within ``max_bytes``."""
    per = bytes_per_marking(net) * COPIES + ARC_BYTES
    room = (max_bytes - net_bytes(net)) // per
    return int(max(0, min(max_markings, room, 2**31 - 1)))


def verify_mission(compiled: Compiled, method: str = "auto", max_markings: int = MAX_MARKINGS,
                   max_bytes: int = MAX_BYTES, keep_graph: bool = False) -> Verdict:
    """Verify a compiled mission by ``method`` ("auto", "explicit" or "structural");
    ``keep_graph``: the verdict keeps the explicit route's graph (``Verdict.space``). A
    mission with a stop handler also gets ``stop-ends`` (mcl/analysis/termination.py), the
    same on every route."""
    verdict = _verify(compiled, method, max_markings, max_bytes, keep_graph)
    stop = termination.stop_result(compiled.checked)
    if stop is not None:  # beside stop-safe
        at = next((i + 1 for i, r in enumerate(verdict.results) if r.name == "stop-safe"),
                  len(verdict.results))
        verdict.results.insert(at, stop)
    return verdict


def _verify(compiled: Compiled, method: str, max_markings: int, max_bytes: int,
            keep_graph: bool) -> Verdict:
    if method not in METHODS:
        raise ValueError(f"unknown method {method!r}: one of {', '.join(METHODS)}")
    net = compiled.net
    checked = compiled.checked
    limit = marking_limit(net, max_markings, max_bytes)
    explicit = method == "explicit" and limit >= 1
    if method == "auto":
        estimate = size.mission_estimate(checked)
        explicit = not (limit < 1 or explicit_cost(net, estimate) > max_bytes
                        or estimate > limit)
    start = time.perf_counter()
    try:
        found = explored(net, limit, max_bytes) if explicit else None  # small and safe
    except MemoryError:  # the explicit route below meets it again and says so
        found = None
    if found is not None and not keep_graph:  # every property holds: decided without numpy
        quick = all_hold(net, found, termination.result(checked))
        if quick is not None:
            quick.seconds = time.perf_counter() - start
            return quick
    # Lazy for start-up speed: the explicit route's graph is numpy's, and the structural
    # route loads it too, which the quick verdict above needs neither of.
    from mcl.analysis import structural
    from petri.verification.properties import verify

    def terminates(g: ReachabilityGraph, how: str, cut: str) -> Result:
        return termination.result(checked, how, g)  # the worst case decides, cut or not

    def explicit_route() -> Verdict:
        space = state_space(net, found) if found is not None else None  # not searched again
        verdict = verify(net, max_markings=limit, keep_graph=keep_graph,
                         termination=terminates, max_bytes=max_bytes, space=space)
        verdict.seconds = time.perf_counter() - start
        return verdict

    if method == "structural":
        return structural.analyse(checked, net)
    if method == "explicit":
        if limit < 1:
            return _too_big(net, max_bytes)
        try:
            return explicit_route()
        except MemoryError:  # the estimate fell short: say so, never crash
            return _too_big(net, max_bytes, "ran out of memory")
    budget = f"{max_bytes / 2**20:,.0f} MiB"
    if not explicit:
        why = (f"auto: about {estimate:,.0f} markings estimated, over the explicit route's "
               f"budget of {limit:,} markings ({budget})")
        return structural.analyse(checked, net, note=why)
    try:
        done = explicit_route()
    except MemoryError:  # the estimate fell short: the structural route instead
        return structural.analyse(checked, net, note=f"auto: the explicit route ran out of "
                                  f"memory ({budget}): structural instead")
    if not any(r.undecided for r in done.results if r.severity == "error"):
        return done
    cut = done.markings >= limit or any("CUT: " in r.method for r in done.results)
    why = (f"auto: the explicit route stopped at {done.markings:,} markings "
           f"(limit {limit:,}, {budget})" if cut else "auto: undecided by the explicit route")
    return merge(done, structural.analyse(checked, net, note=why), cut)


def merge(explicit: Verdict, structural: Verdict, cut: bool = True) -> Verdict:
    """One verdict from the explicit route and the structural route: per property, what the
    explicit route established — a violation it saw is real even in a cut exploration, but a
    cut exploration proves nothing holds — else the structural route's result."""
    seen = {r.name: r for r in explicit.results}
    out = Verdict(explicit.net, explicit.markings, explicit.arcs,
                  explicit.seconds + structural.seconds)
    out.witnesses = explicit.witnesses
    out.dead_transitions = explicit.dead_transitions
    names = [r.name for r in structural.results]
    names += [n for n in seen if n not in names]
    mine = {r.name: r for r in structural.results}
    for name in names:
        first = seen.get(name)
        other = mine.get(name)
        if first is not None and (first.status == "fails" or other is None
                                  or (first.status == "holds" and not cut)):
            out.results.append(first)
        elif other is not None:
            out.results.append(other)
    return out


def _too_big(net: Net, max_bytes: int, what: str = "leaves no room for markings") -> Verdict:
    why = (f"undecided: the net ({len(net.places):,} places, {len(net.transitions):,} "
           f"transitions) {what} in {max_bytes / 2**20:,.0f} MiB")
    verdict = Verdict(net, 0, 0, 0.0)
    for name in ("one-safe", "proper-completion", "no-deadlock", "terminates", "can-end",
                 "no-zeno",
                 "behaviours-off-at-end", "behaviour-single-owner", "dof-exclusive",
                 "no-disable-while-held", "stop-safe"):
        verdict.results.append(undecided(name, why, "explicit (not run)"))
    verdict.results.append(undecided("instant-loop", why, "explicit (not run)", "warning"))
    verdict.results.append(actions_match(net))
    verdict.results.append(Result("no-dead-transitions", False, "warning", why,
                                  "explicit (not run)", undecided=True))
    return verdict
