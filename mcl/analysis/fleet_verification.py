"""Proving a fleet: the explicit product, the compositional route, or auto.

* ``explicit``: the product net (mcl/analysis/fleet.py) explored breadth first within the
  memory budget; every fleet property (mcl/analysis/fleet_properties.py) decided on it, with
  counterexamples that interleave the vehicles' lines. A cut exploration keeps the violations
  it saw and decides nothing that holds.
* ``compositional``: each vehicle alone against its channels' contract (a message may arrive
  at any moment, or never): the product is never built. A property every vehicle alone
  establishes holds for the fleet (docs/METHODS.md says why); anything else is *undecided*
  with the reason — a violation of one vehicle alone may need messages its sender never sends.
* ``auto``: proves each vehicle alone first (cheap), which bounds the product's joint
  markings (each vehicle's markings alone multiplied, twice per link); within the budget,
  explicit, and should that exploration be cut the compositional results fill in what it
  left undecided; over it, the compositional verdict stands.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

from petri.verification.reachability import StateSpace, explore, markings_within
from petri.verification.verdict import Result, undecided

from mcl.analysis.duration import analyse
from mcl.analysis.fleet import FleetNet, Step, alone, product
from mcl.analysis.fleet_properties import decide
from mcl.analysis.termination import endless

if TYPE_CHECKING:
    from mcl.fleet import CompiledFleet

METHODS = ("auto", "explicit", "compositional")
MAX_MARKINGS = 5_000_000
MAX_BYTES = 1 << 30
PROPERTIES = ("fleet-one-safe", "fleet-proper-completion", "fleet-no-deadlock",
              "fleet-can-end", "fleet-silence", "fleet-nothing-on-at-end", "fleet-terminates")


@dataclass
class FleetVerdict:
    """Every fleet property's result, the route that decided it, and what was explored
    (``space``: the product's graph, when explored and asked for)."""

    fleet: FleetNet
    markings: int
    arcs: int
    seconds: float
    results: list[Result] = field(default_factory=list)
    note: str = ""
    space: StateSpace | None = field(default=None, repr=False)
    alone_markings: dict[str, int] = field(default_factory=dict)  # compositional: per vehicle

    @property
    def ok(self) -> bool:
        return all(r.holds for r in self.results)

    @property
    def failed(self) -> bool:
        return any(r.status == "fails" for r in self.results)

    @property
    def undecided(self) -> bool:
        return not self.failed and any(r.undecided for r in self.results)

    def lines(self, steps: list[int]) -> list[str]:
        """A counterexample's firings, one line each, in the vehicles' words."""
        return [self.fleet.step_text(t) for t in steps]

    def to_json(self) -> dict[str, Any]:
        return {
            "fleet": self.fleet.name, "verified": self.ok, "undecided": self.undecided,
            "reachable_markings": self.markings, "reachability_arcs": self.arcs,
            "seconds": round(self.seconds, 4), "note": self.note,
            "properties": [{
                "property": r.name, "holds": r.holds, "status": r.status,
                "severity": r.severity, "message": r.message, "method": r.method,
                "counterexample": None if r.counterexample is None else
                [self.step(t) for t in r.counterexample],
                "cycle": None if r.cycle is None else [self.step(t) for t in r.cycle],
            } for r in self.results]}

    def step(self, t: int) -> dict[str, Any]:
        """One firing of a counterexample: whose (a vehicle, or None for a channel), where,
        and the line it prints as."""
        s: Step = self.fleet.steps[t]
        base: dict[str, Any] = {"vehicle": s.vehicle, "text": self.fleet.step_text(t),
                                "kind": s.kind, "file": None, "line": None, "col": None}
        if s.link is not None and s.kind != "vehicle":
            base["construct"] = f"channel {s.link.channel}"
            base["label"] = base["text"].split(": ", 1)[-1]
            base["channel"] = s.link.channel
            base["message"] = s.link.message
            base["receiver"] = s.link.receiver
            return base
        assert s.vehicle is not None
        tr = self.fleet.slices[s.vehicle].net.transitions[s.original]
        if tr.origin is not None:
            base.update(file=tr.origin.file, line=tr.origin.line, col=tr.origin.col,
                        construct=tr.origin.text)
        base.update(transition=tr.name, label=tr.label, event=tr.event, timer=tr.timer)
        return base


def terminates_of(fleet: CompiledFleet) -> dict[str, tuple[bool, str]]:
    """Each vehicle's proved worst case (its receptions as events that may never come)."""
    out = {}
    for v, compiled in fleet.vehicles.items():
        d = analyse(compiled.checked)
        if math.isfinite(d.worst):
            out[v] = (True, f"{v} ends within {d.worst:g} s")
        else:
            why = endless(compiled.checked, d)
            out[v] = (False, f"{v} is not proved to end ({why.why if why else 'unbounded'})")
    return out


def verify_fleet(fleet: CompiledFleet, method: str = "auto", max_markings: int = MAX_MARKINGS,
                 max_bytes: int = MAX_BYTES, keep_graph: bool = False) -> FleetVerdict:
    """Prove the fleet properties by ``method`` ("auto", "explicit" or "compositional")."""
    if method not in METHODS:
        raise ValueError(f"unknown method {method!r}: one of {', '.join(METHODS)}")
    start = time.perf_counter()
    proofs = terminates_of(fleet)
    if method == "compositional":
        verdict = compositional(fleet, proofs, max_markings, max_bytes)
    else:
        fnet = product(fleet)
        limit = min(max_markings, markings_within(fnet.net, max_bytes))
        alone_ = (compositional(fleet, proofs, max_markings, max_bytes)
                  if method == "auto" else None)
        bound = product_bound(alone_) if alone_ is not None else 0.0
        if alone_ is not None and (limit < 1 or bound > limit):
            verdict = alone_
            verdict.note = (f"auto: up to {bound:.3g} joint markings (each vehicle's alone, "
                            f"multiplied), over the explicit route's budget "
                            f"of {limit:,} ({max_bytes / 2**20:,.0f} MiB): compositional")
        else:
            verdict = explicit(fnet, proofs, max(1, limit), max_bytes)
            cut = verdict.space is not None and not verdict.space.complete
            if not keep_graph:
                verdict.space = None
            if alone_ is not None and cut:
                verdict = _merge(verdict, alone_)
    verdict.seconds = time.perf_counter() - start
    return verdict


def product_bound(alone_: FleetVerdict) -> float:
    """An upper bound of the product's joint markings: each vehicle's markings alone (with
    the messages on their way to it) multiplied."""
    total = 1.0
    for n in alone_.alone_markings.values():
        total *= n
    return min(total, 1e300)


def explicit(fnet: FleetNet, proofs: dict[str, tuple[bool, str]], limit: int,
             max_bytes: float) -> FleetVerdict:
    """The product explored and every fleet property decided on it (the graph is kept in
    ``space``)."""
    ss = explore(fnet.net, max_markings=limit, max_bytes=max_bytes)
    how = (f"explicit product of the fleet ({ss.n_markings:,} joint markings, "
           f"{ss.n_arcs:,} arcs)" + ("" if ss.complete else f", CUT: {ss.stop_reason}"))
    results = decide(fnet, ss, lambda v: proofs[v], how)
    return FleetVerdict(fnet, ss.n_markings, ss.n_arcs, 0.0, results, space=ss)


def compositional(fleet: CompiledFleet, proofs: dict[str, tuple[bool, str]], max_markings: int,
                  max_bytes: float) -> FleetVerdict:
    """Each vehicle alone against its channels' contract (the module's doc)."""
    per: dict[str, dict[str, Result]] = {}
    counts: dict[str, int] = {}
    markings = arcs = 0
    for v in fleet.vehicles:
        fnet = alone(fleet, v)
        limit = max(1, min(max_markings, markings_within(fnet.net, max_bytes)))
        ss = explore(fnet.net, max_markings=limit, max_bytes=max_bytes)
        markings, arcs = markings + ss.n_markings, arcs + ss.n_arcs
        counts[v] = ss.n_markings if ss.complete else 2**62
        how = f"{v} alone ({ss.n_markings:,} markings)"
        per[v] = {r.name: r for r in decide(fnet, ss, lambda u: proofs[u], how,
                                            quiet=lambda s: s.kind == "arrive",
                                            hush="no message arrives")}
    method = ("compositional: each vehicle alone against its channels' contract (a message "
              f"may arrive at any moment, or never; {markings:,} markings in all)")
    results = []
    for name in PROPERTIES:
        if name == "fleet-terminates":
            results.append(_terminates(proofs, method))
            continue
        # can-end and no-deadlock follow from each vehicle ending without any message
        source = "fleet-silence" if name in ("fleet-can-end", "fleet-no-deadlock") else name
        bad = {v: r[source] for v, r in per.items() if not r[source].holds}
        if name == "fleet-no-deadlock":
            bad |= {v: per[v][name] for v in per if not per[v][name].holds}
        if not bad:
            results.append(Result(name, True, "error", _holds(name), method))
            continue
        why = "; ".join(f"{v} alone: {r.message}" for v, r in bad.items())
        results.append(undecided(name, f"undecided: {why} (alone, a vehicle may get or miss "
                                 "any message; the product decides whether the fleet lets "
                                 "this happen: --method explicit)", method))
    return FleetVerdict(product(fleet), markings, arcs, 0.0, results,
                        alone_markings=counts)


def _terminates(proofs: dict[str, tuple[bool, str]], method: str) -> Result:
    name = "fleet-terminates"
    if all(ok for ok, _ in proofs.values()):
        return Result(name, True, "error", "every run of the fleet ends: "
                      + "; ".join(why for _, why in proofs.values()),
                      "each vehicle's proved worst-case duration")
    return undecided(name, "undecided: " + "; ".join(why for ok, why in proofs.values()
                                                     if not ok), method)


def _holds(name: str) -> str:
    return {
        "fleet-one-safe": "no joint marking puts two tokens in one place",
        "fleet-proper-completion": "each vehicle ends with exactly one token in its ok or "
                                   "fail place",
        "fleet-no-deadlock": "no vehicle waits for ever: each can end without any message",
        "fleet-can-end": "every vehicle can still end from every joint marking, without any "
                         "message",
        "fleet-silence": "every vehicle still ends properly with nothing on when every "
                         "message is lost from any point on",
        "fleet-nothing-on-at-end": "no vehicle has a behaviour on once it has ended",
    }[name]


def _merge(explicit_: FleetVerdict, other: FleetVerdict) -> FleetVerdict:
    """A cut product's violations stand; what it left undecided, the compositional route's."""
    mine = {r.name: r for r in other.results}
    results = [r if not r.undecided else mine.get(r.name, r) for r in explicit_.results]
    return FleetVerdict(explicit_.fleet, explicit_.markings, explicit_.arcs, 0.0, results,
                        note="auto: the product's exploration was cut; the compositional "
                        "route decided what it left undecided")
