"""What verifying a net yields: a :class:`Result` per property, gathered in a :class:`Verdict`.

Every route (the explicit one of :mod:`petri.verification.properties`, the structural one of
:mod:`mcl.analysis.structural`) reports this way. A result holds, fails with a counterexample
(transition indices from the initial marking, and for a lasso the loop after them), or is
*undecided* with the reason; :meth:`Verdict.to_json` is the report every command prints from.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

from petri.net import Net

if TYPE_CHECKING:  # numpy is loaded only where a graph is (a small mission's quick verdict
    # needs none: petri/verification/all_hold.py)
    import numpy as np
    import numpy.typing as npt

    from petri.verification.reachability import StateSpace


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


# What each property of the explicit route says when it holds (the quick verdict of
# petri/verification/all_hold.py says it in the same words).
INSTANT_OK = ("every loop waits for a timer > 0 on each lap: none can go round at one "
              "instant, however fast the vehicle answers")
HOLDS = {
    "one-safe": "every place holds at most one token",
    "proper-completion": "the mission ends with exactly one token, in its ok or fail place",
    "no-deadlock": "no reachable marking is stuck before the mission ends",
    "can-end": "from every reachable marking the mission can still end by itself (no external "
               "stop needed)",
    "no-zeno": "no loop can go round without time passing",
    "instant-loop": INSTANT_OK,
    "behaviours-off-at-end": "no behaviour is left on when the mission ends",
    "behaviour-single-owner": "no behaviour driving a degree of freedom is held on by two tasks "
                              "at once (watchers are shared: on until the last holder lets go)",
    "dof-exclusive": "no two behaviours driving the same degree of freedom are on together",
    "no-disable-while-held": "no task switches off a behaviour another task holds",
    "stop-safe": "an external stop (operator, uncaught Link.lost, a limit) from any reachable "
                 "marking ends the mission with every behaviour off",
}
NO_STOP = "the mission has no external stop to check"  # stop-safe, in a net without one


def explicit_method(markings: int, arcs: int) -> str:
    """How the explicit route established what a complete exploration decides."""
    return f"explicit reachability graph ({markings} markings, {arcs} arcs)"


def undecided(name: str, why: str, method: str, severity: str = "error") -> Result:
    """A property the method could not establish, and why."""
    return Result(name, False, severity, why, method, undecided=True)


def nearest(ss: StateSpace, name: str, bad: npt.NDArray[np.int64], good: str, bad_msg: str,
            method: str) -> Result:
    """The property holds if no marking of ``ss`` is ``bad``; else it fails, with the
    shortest firing sequence to the nearest bad marking."""
    if len(bad) == 0:
        return Result(name, True, "error", good, method)
    from petri.verification.reachability import shortest_path  # lazy for start-up speed:
    # numpy, which a verdict without a counterexample never needs

    target = int(bad.min())  # markings are numbered in BFS order: the first is the nearest
    path = shortest_path(ss, [target])
    return Result(name, False, "error", bad_msg, method, path, target)


def dead_transitions(net: Net, never: list[int], how: str) -> Result:
    """no-dead-transitions (a warning): the transitions no reachable marking fires."""
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


@dataclass
class Verdict:
    """Every property's result for one net, with the size of what was explored.

    ``space`` is the explicit reachability graph the verdict was decided on, when asked for
    (``verify(net, keep_graph=True)``; None when the route enumerated none, like the
    structural route): ``space.to_networkx(net)`` turns it into a networkx graph,
    :mod:`petri.formats.graphml` writes it."""

    net: Net
    markings: int
    arcs: int
    seconds: float
    results: list[Result] = field(default_factory=list)
    dead_transitions: list[int] = field(default_factory=list)
    witnesses: dict[int, str] = field(default_factory=dict)  # marking index -> its places
    space: StateSpace | None = field(default=None, repr=False, compare=False)

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
