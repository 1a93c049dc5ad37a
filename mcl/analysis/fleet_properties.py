"""The fleet properties, decided on the explored product net (mcl/analysis/fleet.py).

=========================  ==================================================================
property                   holds when
=========================  ==================================================================
fleet-one-safe             no reachable joint marking puts two tokens in one place
fleet-proper-completion    a vehicle that has ended holds nothing else (but its latches'
                           state places; messages left in channels do not count)
fleet-no-deadlock          no vehicle waits for ever: every joint marking without a
                           successor has every vehicle ended
fleet-can-end              from every reachable joint marking every vehicle can still end
                           (no cycle without an exit)
fleet-silence              from every reachable joint marking, with every message on a
                           LOSSY channel lost from then on, every vehicle can still end
                           properly with nothing on
fleet-nothing-on-at-end    no vehicle has a behaviour on once it has ended
fleet-terminates           every run of the fleet ends: each vehicle's proved worst case
                           (its places change by its own transitions only, so a fleet run
                           that went on for ever would be such a run of one vehicle)
=========================  ==================================================================

A violation seen in a cut exploration is real; what a cut exploration cannot establish is
*undecided*, never printed as holding. Counterexamples interleave the vehicles' lines
(:meth:`FleetNet.step_text`); a loop is a lasso (prefix, then the cycle).
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np
import numpy.typing as npt

from petri.verification.graph import Adjacency, lasso
from petri.verification.reachability import StateSpace, shortest_path
from petri.verification.verdict import Result, undecided

from mcl.analysis.fleet import FleetNet, Step

Mask = npt.NDArray[np.bool_]
Terminates = Callable[[str], tuple[bool, str]]  # vehicle -> (proved to end, why)


class Views:
    """Per-vehicle questions about every explored joint marking: has it ended, ended
    properly (nothing else held), has it a behaviour on."""

    def __init__(self, fnet: FleetNet, ss: StateSpace):
        self.fnet, self.ss = fnet, ss
        m = ss.markings
        n = ss.n_markings
        self.ended: dict[str, Mask] = {}
        self.proper: dict[str, Mask] = {}
        self.on: dict[str, Mask] = {}
        for v, s in fnet.slices.items():
            ends = [s.first + p for p in s.rules.ends]
            latch = {s.first + p for p in s.rules.latch_states}
            rest = [c for c in s.columns if c not in latch]
            holders = sorted({s.first + p for ps in s.rules.holders.values() for p in ps})
            self.ended[v] = np.asarray((m[:, ends] > 0).any(axis=1) if ends else np.zeros(n, bool))
            others = m[:, rest].sum(axis=1, dtype=np.int64)
            self.proper[v] = self.ended[v] & (others == 1)
            self.on[v] = np.asarray((m[:, holders] > 0).any(axis=1) if holders
                                   else np.zeros(n, bool))
        self.all_ended = np.logical_and.reduce(list(self.ended.values()))
        self.good = np.logical_and.reduce(
            [self.proper[v] & ~self.on[v] for v in fnet.slices])
        self.expanded = n if ss.expanded < 0 else ss.expanded
        self.adj = Adjacency(n, ss.src, ss.dst)

    def who_waits(self, row: int, among: set[str] | None = None) -> str:
        """The vehicles not ended at joint marking ``row`` (of ``among``, when given) and
        the tasks they run."""
        parts = []
        for v, s in self.fnet.slices.items():
            if not self.ended[v][row] and (among is None or v in among):
                running = s.rules.running_tasks(self.fnet.vehicle_marking(
                    self.ss.markings[row], v))
                parts.append(v + (f" (at {', '.join(running)})" if running else ""))
        return ", ".join(parts)

    def on_cycle(self, cycle: list[int]) -> set[str]:
        """The vehicles whose own transitions make up a loop."""
        return {v for t in cycle if (v := self.fnet.steps[t].vehicle) is not None}

    def left_on(self, row: int) -> str:
        parts = []
        for v, s in self.fnet.slices.items():
            on = s.rules.behaviours_on(self.fnet.vehicle_marking(self.ss.markings[row], v))
            if on and self.ended[v][row]:
                parts.append(f"{v}: {', '.join(on)}")
        return "; ".join(parts)


def lossy_delivery(step: Step) -> bool:
    """The steps silence takes away in the product: receptions of a LOSSY channel's
    messages."""
    return step.kind == "vehicle" and step.link is not None and step.link.lossy


LOSSY_SILENCE = "every later message on a lossy channel is lost"


def decide(fnet: FleetNet, ss: StateSpace, terminates: Terminates, how: str,
           quiet: Callable[[Step], bool] = lossy_delivery, hush: str = LOSSY_SILENCE
           ) -> list[Result]:
    """Every fleet property on the explored product (``how``: the method's words;
    ``quiet``: the steps that silence takes away, ``hush`` says what that means)."""
    views = Views(fnet, ss)
    cut = "" if ss.complete else (f"undecided: the exploration stopped ({ss.stop_reason}) "
                                  "before every joint marking was seen")
    out = [_safety(views, "fleet-one-safe", np.flatnonzero(ss.markings.max(axis=1) > 1),
                   "no joint marking puts two tokens in one place",
                   lambda r: "a place can hold two tokens", how, cut)]
    unclean = np.logical_or.reduce([views.ended[v] & ~views.proper[v] for v in fnet.slices])
    out.append(_safety(views, "fleet-proper-completion", np.flatnonzero(unclean),
                       "each vehicle ends with exactly one token in its ok or fail place",
                       lambda r: "a vehicle can end with tokens left behind", how, cut))
    degree = np.bincount(ss.src, minlength=ss.n_markings)
    dead = np.flatnonzero((degree == 0) & ~views.all_ended)
    dead = dead[dead < views.expanded]
    out.append(_safety(views, "fleet-no-deadlock", dead,
                       "no vehicle waits for ever: every joint marking without a successor "
                       "has every vehicle ended",
                       lambda r: f"a vehicle can wait for ever: {views.who_waits(r)}", how, cut))
    can_end = _reach_end(views, "fleet-can-end", views.all_ended, None, how, cut, hush)
    out.append(can_end)
    silent = np.ones(len(ss.src), bool)
    hushed = [t for t, s in enumerate(fnet.steps) if quiet(s)]
    if len(ss.src):
        silent[np.isin(ss.transition, hushed)] = False
    out.append(_reach_end(views, "fleet-silence", views.good, silent, how, cut, hush))
    on_end = np.logical_or.reduce([views.ended[v] & views.on[v] for v in fnet.slices])
    out.append(_safety(views, "fleet-nothing-on-at-end", np.flatnonzero(on_end),
                       "no vehicle has a behaviour on once it has ended",
                       lambda r: f"a vehicle can end with {views.left_on(r)} still on",
                       how, cut))
    out.append(_terminates(views, terminates, how, can_end))
    twice = two_waiting(fnet, ss)
    if twice:  # the player hands one delivery to both; the product to one: not modelled
        out = [undecided(r.name, f"undecided: {twice}", r.method) if r.holds else r
               for r in out]
    return out


def two_waiting(fnet: FleetNet, ss: StateSpace) -> str:
    """Why the product does not model some run: two Receives of one message can wait at
    once in one vehicle (the player hands one delivery to both, the product to one); ""
    when none can."""
    for ln in fnet.links:
        if len(ln.waiting) > 1 and (ss.markings[:, list(ln.waiting)] > 0).sum(axis=1).max() > 1:
            return (f"two Receives of {ln.event} can wait at once in {ln.receiver}: one "
                    "delivery ends both at run time, which the product does not model")
    return ""


def _safety(views: Views, name: str, bad: npt.NDArray[np.int64], good: str,
            bad_msg: Callable[[int], str], how: str, cut: str) -> Result:
    """Fails at the nearest ``bad`` joint marking (real even when cut); else holds, or is
    undecided when the exploration was cut."""
    if len(bad) == 0:
        return undecided(name, cut, how) if cut else Result(name, True, "error", good, how)
    target = int(bad.min())
    return Result(name, False, "error", bad_msg(target), how,
                  shortest_path(views.ss, np.array([target])), target)


def _reach_end(views: Views, name: str, goal: Mask, arcs: Mask | None, how: str,
               cut: str, hush: str) -> Result:
    """From every reachable joint marking ``goal`` can be reached over ``arcs`` (None: all).
    A violation: the shortest run to a joint marking from which it cannot, then (over
    ``arcs``) a loop it cannot leave or the marking it gets stuck in."""
    ss = views.ss
    silence = arcs is not None
    what = f"properly, with nothing on, when {hush}" if silence else ""
    if cut:
        return undecided(name, cut, how)
    keep = np.ones(len(ss.src), bool) if arcs is None else arcs
    ids = np.flatnonzero(keep)
    sub = Adjacency(ss.n_markings, ss.src[keep], ss.dst[keep], ids)
    reached = sub.reach(np.flatnonzero(goal), backward=True)
    bad = ~reached
    if not bad.any():
        return Result(name, True, "error", "from every reachable joint marking every vehicle "
                      f"can still end{' ' + what if what else ''}", how + ", backward search")
    loop = lasso(ss, sub, bad, ss.src[keep], ss.dst[keep], views.adj)
    first = int(np.flatnonzero(bad).min())
    prefix = shortest_path(ss, np.array([first]))
    if loop is not None and not silence:
        at, prefix, cycle = loop
        return Result(name, False, "error", f"the fleet can go round for ever: "
                      f"{views.who_waits(at, views.on_cycle(cycle))} goes round and cannot "
                      "end", how, prefix, at, cycle=cycle)
    # the run to the first such marking, then (silent) on to where it gets stuck or loops
    stuck = bad & (np.bincount(ss.src[keep], minlength=ss.n_markings) == 0)
    rest, end = sub.path(first, stuck, within=bad) if not stuck[first] else ([], first)
    if end < 0 and loop is not None:
        at, prefix, cycle = loop
        return Result(name, False, "error", f"when {hush}, "
                      f"{views.who_waits(at, views.on_cycle(cycle))} can go round for ever",
                      how, prefix, at,
                      cycle=cycle)
    end = first if end < 0 else end
    steps = prefix + [int(ss.transition[a]) for a in rest]
    why = (f"{views.who_waits(end)} cannot end" if not views.all_ended[end] else
           f"the fleet ends with {views.left_on(end) or 'tokens left behind'}")
    head = f"when {hush}, " if silence else ""
    return Result(name, False, "error", head + why, how, steps, end)


def _terminates(views: Views, terminates: Terminates, how: str, can_end: Result) -> Result:
    """Each vehicle's proved worst case bounds the fleet's runs (the module's doc); a
    vehicle not proved to end is shown by a loop from which no end can be reached
    (``can_end``'s lasso), a run that gets stuck, or a lasso through its transitions."""
    name = "fleet-terminates"
    fnet = views.fnet
    proofs = {v: terminates(v) for v in fnet.slices}
    unproved = [v for v, (ok, _) in proofs.items() if not ok]
    method = "each vehicle's proved worst-case duration (mcl/analysis/duration.py)"
    if not unproved:
        return Result(name, True, "error", "every run of the fleet ends: "
                      + "; ".join(why for _, why in proofs.values()), method)
    ss = views.ss
    if can_end.status == "fails" and can_end.cycle:  # no end reachable: it never ends
        return Result(name, False, "error", "some run of the fleet never ends: "
                      + can_end.message.removeprefix("the fleet can go round for ever: "),
                      can_end.method, can_end.counterexample, can_end.witness,
                      cycle=can_end.cycle)
    mine = np.zeros(len(fnet.steps), bool)
    for t, s in enumerate(fnet.steps):
        mine[t] = s.vehicle in unproved
    open_ = ~views.all_ended
    loop = lasso(ss, views.adj, open_, ss.src, ss.dst, views.adj) if len(ss.src) else None
    timed = np.array([s.vehicle is not None and fnet.slices[s.vehicle].net.transitions[
        s.original].timer is not None for s in fnet.steps], bool)
    if loop is not None and mine[loop[2]].any() and not timed[loop[2]].any():
        at, prefix, cycle = loop  # no timer on the loop: nothing bounds it
        return Result(name, False, "error", "some run of the fleet can go on for ever: "
                      + "; ".join(proofs[v][1] for v in unproved), how, prefix, at,
                      cycle=cycle)
    degree = np.bincount(ss.src, minlength=ss.n_markings)
    stuck = np.flatnonzero((degree == 0) & ~views.all_ended)
    stuck = stuck[stuck < views.expanded]
    if len(stuck):  # a run that stops before its end: it waits for ever
        first = int(stuck.min())
        return Result(name, False, "error", "some run of the fleet never ends: "
                      f"waiting for ever: {views.who_waits(first)}", how,
                      shortest_path(ss, np.array([first])), first)
    if ss.complete and loop is None:
        return Result(name, True, "error", "every run of the fleet ends: the product has no "
                      "reachable cycle before every vehicle has ended", how + ", graph rule")
    return undecided(name, "undecided: " + "; ".join(proofs[v][1] for v in unproved)
                     + " (the product is untimed: whether timers end its cycles is not "
                     "decided there)",
                     how)


def worst_case_text(seconds: float) -> str:
    return "unbounded" if not math.isfinite(seconds) else f"{seconds:g} s"
