"""Verify a net compiled from MCL: the properties of MCL.md §4, each with a counterexample.

The environment is free: any awaited event or timer may happen at any moment and the mission
may be aborted at any moment (the ``Mission.abort`` transition), so every interleaving is
explored. Properties:

=======================  =====================================================================
property                 holds when
=======================  =====================================================================
one-safe                 no reachable marking puts two tokens in one place
no-deadlock              every marking without successors is a final marking
final-reachable          from every reachable marking a final marking can be reached
proper-completion        when the mission's ok or fail place is marked, nothing else is
                         (but the latched behaviours' state places)
behaviours-off-at-end    at every final marking no behaviour is still on
dof-exclusive            no two behaviours driving the same degree of freedom are on together
behaviour-single-owner   no behaviour is held on by two tasks (or latches) at once
actions-match-behaviours each firing that turns a behaviour on (off) sends enable (disable)
no-dead-transitions      every transition can fire (a warning only)
=======================  =====================================================================

A failed property comes with the shortest firing sequence from the initial marking that shows
it, in the mission's own words (source line, task, event, actions).
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import Any

import networkx as nx
import numpy as np
import numpy.typing as npt

from .net import Net
from .reachability import StateSpace, explore, shortest_path

NETWORKX_MAX_ARCS = 500_000  # above this, backward reachability runs on integer arrays


@dataclass
class Result:
    name: str
    holds: bool
    severity: str  # "error" | "warning"
    message: str
    method: str
    counterexample: list[int] | None = None  # transition indices from the initial marking
    witness: int | None = None  # the marking index the counterexample leads to


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
        return all(r.holds or r.severity != "error" for r in self.results)

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
            "properties": [{
                "property": r.name, "holds": r.holds, "severity": r.severity,
                "message": r.message, "method": r.method,
                "counterexample": None if r.counterexample is None else
                [step(self.net, t) for t in r.counterexample],
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
    start = time.perf_counter()
    ss = explore(net, max_markings=max_markings)
    how = (f"explicit reachability graph ({len(ss.markings)} markings, {len(ss.src)} arcs)"
           + ("" if ss.complete else ", INCOMPLETE: limit reached"))
    verdict = Verdict(net, len(ss.markings), len(ss.src), 0.0)
    marked = ss.markings > 0
    latch_places = np.array([p.origin is None or p.origin.kind == "latch"
                             for p in net.places]) & np.array(
        [p.name.endswith(".off") or ".on@" in p.name for p in net.places])
    end_places = [net.place(n) for n in ("MISSION.ok", "MISSION.fail")
                  if n in net._index]
    ended = marked[:, end_places].any(axis=1) if end_places else np.zeros(len(marked), bool)
    others = (marked & ~latch_places).sum(axis=1)
    terminal = ended & (others == 1)  # the mission's end place and latch states only

    results = verdict.results
    # one-safe
    over = np.flatnonzero(ss.markings.max(axis=1) > 1)
    results.append(_result(ss, "one-safe", over, "every place holds at most one token",
                           "a place can hold two tokens", how, net))
    # proper completion: an end place marked together with other tokens
    improper = np.flatnonzero(ended & (others > 1))
    results.append(_result(ss, "proper-completion", improper,
                           "the mission ends with exactly one token, in MISSION.ok or "
                           "MISSION.fail", "the mission can end with tokens left behind", how,
                           net))
    # deadlocks
    out_degree = np.bincount(ss.src, minlength=len(ss.markings))
    dead = np.flatnonzero((out_degree == 0) & ~terminal)
    results.append(_result(ss, "no-deadlock", dead,
                           "no reachable marking is stuck before the mission ends",
                           "the mission can get stuck", how, net))
    # a final marking stays reachable
    can_end = _backward(ss, np.flatnonzero(terminal))
    stuck = np.flatnonzero(~can_end)
    results.append(_result(ss, "final-reachable", stuck,
                           "from every reachable marking the mission can still end",
                           "the mission can reach a state from which it never ends",
                           how + (", backward search with networkx"
                                  if len(ss.src) <= NETWORKX_MAX_ARCS
                                  else ", backward search on integer arrays"), net))
    # behaviours still on at the end
    on = _behaviours_on(net, marked)
    left_on = np.flatnonzero(terminal & on.any(axis=1)) if on.size else np.array([], int)
    names = sorted({b for i in left_on for b in _names(net, on[i])})
    results.append(_result(ss, "behaviours-off-at-end", left_on,
                           "no behaviour is left on when the mission ends",
                           f"the mission can end with {', '.join(names)} still on", how, net))
    # one owner per behaviour: two blocks holding one behaviour on means the first to stop it
    # switches it off under the other (the net would still count it on)
    shared, who = _shared_owner(net, marked)
    results.append(_result(ss, "behaviour-single-owner", shared,
                           "no behaviour is held on by two tasks at once",
                           f"{who} can be held on by two tasks at once: the first to end "
                           "switches it off under the other", how, net))
    # degrees of freedom
    conflict, what = _dof_conflicts(net, on)
    results.append(_result(ss, "dof-exclusive", conflict,
                           "no two behaviours driving the same degree of freedom are on "
                           "together", f"two behaviours can drive {what} at once", how, net))
    # every behaviour switched on or off by a firing is switched by its actions
    results.append(_actions_match(net))
    # dead transitions (a warning)
    fired = np.zeros(len(net.transitions), bool)
    fired[np.unique(ss.transition)] = True
    never = np.flatnonzero(~fired)
    verdict.dead_transitions = never.tolist()
    origins = [(net.transitions[t].origin, net.transitions[t].name) for t in never]
    tasks_never = sorted({(o.line, o.text) for o, name in origins
                          if o is not None and o.kind == "task" and name.endswith(".start")})
    if len(never) == 0:
        msg = "every transition can fire"
    else:
        msg = (f"{len(never)} of {len(net.transitions)} transitions never fire "
               "(template paths this mission cannot take)")
        if tasks_never:
            msg += "; tasks that can never start: " + ", ".join(
                f"{text} (line {line})" for line, text in tasks_never)
    results.append(Result("no-dead-transitions", len(never) == 0, "warning", msg, how))
    if not ss.complete:
        results.append(Result("complete", False, "error",
                              f"exploration stopped at {len(ss.markings)} markings: nothing "
                              "is proved", how))
    _describe_witnesses(verdict, ss)
    verdict.seconds = time.perf_counter() - start
    return verdict


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


def _backward(ss: StateSpace, targets: npt.NDArray[np.int64]) -> npt.NDArray[np.bool_]:
    """Which markings can reach one of ``targets``."""
    n = len(ss.markings)
    reach = np.zeros(n, bool)
    if len(targets) == 0:
        return reach
    if len(ss.src) <= NETWORKX_MAX_ARCS:
        g = nx.DiGraph()
        g.add_nodes_from(range(n))
        g.add_edges_from(zip(ss.dst.tolist(), ss.src.tolist()))  # reversed graph
        g.add_edges_from((-1, t) for t in targets.tolist())  # one virtual source
        reach[list(nx.descendants(g, -1))] = True
        return reach
    order = np.argsort(ss.dst, kind="stable")
    starts = np.searchsorted(ss.dst[order], np.arange(n + 1))
    preds = ss.src[order]
    frontier = targets
    reach[frontier] = True
    for _ in range(n):  # bounded: each round adds at least one marking or stops
        if len(frontier) == 0:
            break
        nxt = np.concatenate([preds[starts[m]:starts[m + 1]] for m in frontier])
        nxt = np.unique(nxt[~reach[nxt]]) if len(nxt) else nxt
        reach[nxt] = True
        frontier = nxt
    return reach


def _behaviours_on(net: Net, marked: npt.NDArray[np.bool_]) -> npt.NDArray[np.bool_]:
    behaviours = sorted({b for p in net.places for b in p.behaviours})
    if not behaviours:
        return np.zeros((len(marked), 0), bool)
    index = {b: i for i, b in enumerate(behaviours)}
    place_beh = np.zeros((len(net.places), len(behaviours)), np.int32)
    for p, place in enumerate(net.places):
        for b in place.behaviours:
            place_beh[p, index[b]] = 1
    return (marked.astype(np.int32) @ place_beh) > 0


def _names(net: Net, row: npt.NDArray[np.bool_]) -> list[str]:
    behaviours = sorted({b for p in net.places for b in p.behaviours})
    return [b for b, on in zip(behaviours, row) if on]


def _shared_owner(net: Net, marked: npt.NDArray[np.bool_]
                  ) -> tuple[npt.NDArray[np.int64], str]:
    first: npt.NDArray[np.int64] = np.array([], np.int64)
    who = ""
    for b in sorted({b for p in net.places for b in p.behaviours}):
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


def format_text(report: dict[str, Any]) -> str:
    """The verification part of ``mclc``'s text output."""
    lines = []
    head = "verified" if report["verified"] else "NOT verified"
    if report["reachable_markings"]:
        lines.append(f"  {head}: {report['reachable_markings']} reachable markings, "
                     f"{report['reachability_arcs']} arcs, {report['seconds']:.3f} s")
    else:
        lines.append(f"  {head} by construction and static analysis (the state space is "
                     f"not enumerated), {report['seconds']:.3f} s")
    for r in report["properties"]:
        mark = "ok  " if r["holds"] else ("FAIL" if r["severity"] == "error" else "warn")
        lines.append(f"  [{mark}] {r['property']}: {r['message']}")
        if r["counterexample"] is not None:
            lines.append("         shortest firing sequence from the start:")
            for i, s in enumerate(r["counterexample"], 1):
                where = f"{s['file']}:{s['line']}:{s['col']}" if s["file"] else ""
                extra = f" on {s['event']}" if s["event"] else ""
                extra += f" after {s['timer']} s" if s["timer"] is not None else ""
                acts = f"  [{'; '.join(s['actions'])}]" if s["actions"] else ""
                lines.append(f"         {i:3}. {where}  {s['construct']}: {s['label']}"
                             f"{extra}{acts}")
            if r.get("marking"):
                lines.append(f"         reaching the marking {r['marking']}")
    methods = sorted({r["method"] for r in report["properties"]})
    for m in methods:
        names = [r["property"] for r in report["properties"] if r["method"] == m]
        lines.append(f"  method for {', '.join(names)}: {m}" if len(methods) > 1
                     else f"  method: {m}")
    return "\n".join(lines)
