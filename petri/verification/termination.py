"""The properties about ending: ``terminates``, ``can-end``, ``no-zeno``, ``instant-loop`` and
``stop-safe``.

``terminates``: every run ends — no run of the main model (no external stop) can go on for
ever. For a plain net it is the *graph rule* (:func:`terminates`): a reachable cycle of the
main model is a run that some answers of the environment keep going for ever. A mission
compiled from MCL decides it instead from its proved worst-case duration
(mcl/analysis/termination.py, passed to ``verify`` as its ``terminates``), since its timers
bound loops the untimed graph has; :func:`lasso_through` then shows the loop.
``can-end`` is the weaker property: from every reachable marking an end can still be reached.

``instant-loop`` (a warning) is the loop that goes round with no mission time passing when the
vehicle answers at once: a cycle of the main model whose every firing may come at zero delay
(immediate, an awaited event, a timer of 0 s or of a parameter without a value); only a timer
of a positive delay makes a lap take time. The player bounds such a loop (it stops a mission
past ``MAX_FIRINGS_PER_INSTANT`` firings at one instant), hence a warning, not an error.

A violation of ``terminates``, ``no-zeno`` and ``instant-loop`` is a loop: a *lasso*, the shortest firing
sequence to a marking on the loop, then the loop (:func:`petri.verification.graph.lasso`).
``stop-safe`` is decided on the stop region, reached by an external stop.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import numpy.typing as npt

from petri.net import Net
from petri.semantics import MAX_FIRINGS_PER_INSTANT
from petri.verification.graph import Adjacency, ReachabilityGraph, lasso
from petri.verification.reachability import shortest_path
from petri.verification.verdict import HOLDS, INSTANT_OK, NO_STOP, Result, nearest, undecided


Termination = Callable[[ReachabilityGraph, str, str], Result]
"""How a caller decides ``terminates`` on the explored graph (its ``how`` and ``cut``)."""


def terminates(g: ReachabilityGraph, how: str, cut: str) -> Result:
    """The graph rule: every run ends when the main model has no reachable cycle (a loop
    the environment's answers can keep going for ever: its lasso is the counterexample)."""
    name = "terminates"
    main = ~g.stop_arc
    loop = lasso(g.ss, g.main_arcs, g.main, g.ss.src[main], g.ss.dst[main], g.main_arcs)
    if loop is not None:
        at, prefix, cycle = loop
        return Result(name, False, "error", "some run can go on for ever: "
                      + why_endless(g.net, cycle, can_end=False), how + ", graph rule: a "
                      "reachable cycle is a run that can go on for ever", prefix, at,
                      cycle=cycle)
    if cut:
        return undecided(name, cut, how)
    return Result(name, True, "error", "every run ends: the main model has no reachable "
                  "cycle", how + ", graph rule: no reachable cycle, so no run goes on for ever")


def can_end(g: ReachabilityGraph, how: str, cut: str) -> Result:
    """Main model: from every reachable marking an end can still be reached (weaker than
    ``terminates``: a loop that can be left holds it)."""
    name = "can-end"
    if cut:
        return undecided(name, cut, how)
    reached = g.main_arcs.reach(np.flatnonzero(g.terminal & g.main), backward=True,
                                within=g.main)
    bad = g.main & ~reached
    if not bad.any():
        return Result(name, True, "error", HOLDS[name], how + ", backward search")
    main = ~g.stop_arc
    loop = lasso(g.ss, g.main_arcs, bad, g.ss.src[main], g.ss.dst[main], g.main_arcs)
    if loop is None:  # every marking that cannot end is stuck: no-deadlock says where
        first = int(np.flatnonzero(bad).min())
        return Result(name, False, "error", "the mission can get stuck before it ends",
                      how, shortest_path(g.ss, np.array([first])), first)
    at, prefix, cycle = loop
    return Result(name, False, "error", why_endless(g.net, cycle), how, prefix, at,
                  cycle=cycle)


def why_endless(net: Net, cycle: list[int], can_end: bool = True) -> str:
    """Why a loop of the main model goes round for ever, in the mission's words
    (``can_end``: the loop cannot be left at all, as ``can-end`` finds it)."""
    loops = [o for o in (net.transitions[t].origin for t in cycle)
             if o is not None and o.kind == "WHILE"]
    if loops:
        o = loops[0]
        cond = o.text.removeprefix("WHILE").strip().removeprefix("{").removesuffix("}")
        if not can_end:
            return f"the WHILE at line {o.line} (`{cond.strip()}`) can go round for ever"
        return (f"the WHILE at line {o.line} cannot end: its condition `{cond.strip()}` can "
                "never fail and its body never fails, so it goes round for ever")
    if not can_end:
        return "a loop of the net can go round for ever"
    return "the mission can go round for ever without ending (no external stop)"


def lasso_through(g: ReachabilityGraph, transitions: list[int]
                  ) -> tuple[int, list[int], list[int]] | None:
    """A loop of the main model through a firing of one of ``transitions``: the marking it
    starts from, the shortest firing sequence to it, and the shortest loop back (the firing
    first); None when no such firing lies on a cycle (or none of the 64 nearest)."""
    ss = g.ss
    wanted = np.zeros(len(g.net.transitions), bool)
    wanted[transitions] = True
    arcs = np.flatnonzero(wanted[ss.transition] & ~g.stop_arc & g.main[ss.src])
    arcs = arcs[np.argsort(ss.src[arcs], kind="stable")]  # BFS order: the nearest first
    goal = np.zeros(g.n, bool)
    for arc in arcs[:64]:
        at, after = int(ss.src[arc]), int(ss.dst[arc])
        goal[:] = False
        goal[at] = True
        back: list[int] = []
        if after != at:
            back, _ = g.main_arcs.path(after, goal, within=g.main)
            if not back:
                continue
        prefix, _ = g.main_arcs.path(0, goal) if at != 0 else ([], at)
        return (at, [int(ss.transition[a]) for a in prefix],
                [int(ss.transition[arc])] + [int(ss.transition[a]) for a in back])
    return None


def no_zeno(g: ReachabilityGraph, how: str, cut: str) -> Result:
    """A loop of zero-time firings. A timer whose parameter has no value yet may be 0 s: a
    loop that needs one is undecided (it depends on the value), not a violation."""
    name = "no-zeno"
    for arcs, certain in ((g.zero_arc, True), (g.maybe_zero_arc, False)):
        loop = zero_lasso(g, arcs) if arcs.any() else None
        if loop is None:
            continue
        at, prefix, cycle = loop
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
    return Result(name, True, "error", HOLDS[name], how)


def instant_loop(g: ReachabilityGraph, how: str, cut: str) -> Result:
    """A loop of the main model every lap of which can complete with no mission time passing
    when the vehicle answers at once (no timer of a positive delay on it)."""
    name = "instant-loop"
    net = g.net
    timed = np.array([isinstance(t.timer, (int, float)) and float(t.timer) > 0
                      for t in net.transitions], bool)
    instant = (~timed[g.ss.transition] & ~g.stop_arc & g.main[g.ss.src]
               if len(g.ss.transition) else np.zeros(0, bool))
    loop = zero_lasso(g, instant) if instant.any() else None
    if loop is not None:
        at, prefix, cycle = loop
        lines = [o.line for o in (net.transitions[t].origin for t in cycle)
                 if o is not None and o.kind == "WHILE"]
        events = list(dict.fromkeys(e for e in (net.transitions[t].event for t in cycle)
                                    if e is not None))
        return Result(name, False, "warning", instant_text(
            f"the WHILE at line {lines[0]}" if lines else "a loop", events), how, prefix, at,
            cycle=cycle)
    if cut:
        return undecided(name, cut, how, "warning")
    return Result(name, True, "warning", INSTANT_OK, how)


def instant_text(where: str, events: list[str], among: bool = False) -> str:
    """Why a loop can spin at one mission instant: ``where`` it is, the ``events`` that
    close a lap (none: immediate tasks and 0 s timers alone, which no-zeno reports; with
    ``among``, the events its tasks wait for, some of which close a lap)."""
    which = ("events among " if among else "") + ", ".join(events)
    closed = (f"a lap can be closed by {which} alone, which a vehicle may answer at once"
              if events else "a lap needs only instant tasks and 0 s timers")
    return (f"{where} can go round with no mission time passing: {closed} (the player "
            f"stops a mission past {MAX_FIRINGS_PER_INSTANT:,} firings at one instant); make "
            "each lap wait for a timer > 0 (e.g. Wait(1 s)) if it must not spin")


def zero_lasso(g: ReachabilityGraph, zero: npt.NDArray[np.bool_]
               ) -> tuple[int, list[int], list[int]] | None:
    """A loop of the arcs marked in ``zero`` (one entry per arc), as :func:`lasso`."""
    bad = np.zeros(g.n, bool)
    bad[g.ss.src[zero]] = True
    adj = Adjacency(g.n, g.ss.src[zero], g.ss.dst[zero], np.flatnonzero(zero))
    return lasso(g.ss, adj, bad, g.ss.src[zero], g.ss.dst[zero], g.all_arcs)


def stop_safe(g: ReachabilityGraph, how: str, cut: str) -> Result:
    """The external stop: from wherever it comes, the mission then ends with nothing on."""
    name = "stop-safe"
    if cut:
        return undecided(name, cut, how)
    if not g.stop_arc.any():
        return Result(name, True, "error", NO_STOP, how)
    can_end = g.all_arcs.reach(np.flatnonzero(g.terminal & g.stopped), backward=True,
                               within=g.stopped)
    bad = np.flatnonzero(g.stopped & ~can_end)
    if len(bad):
        return nearest(g.ss, name, bad, "", "after an external stop the mission can fail to "
                       "end", how + ", stop region")
    return Result(name, True, "error", HOLDS[name], how + ", stop region")

