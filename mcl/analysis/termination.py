"""``terminates`` for a mission: every run ends, whatever the vehicle answers.

The decision is the proved worst-case duration (:func:`mcl.analysis.duration.analyse`, from
the mission's timeouts and timers only): the mission terminates exactly when it is finite.
A finite worst case bounds every run; an infinite one comes from a WHILE that can go round
for ever (its condition and body can both end ok, and no race bounds it) or a task that waits
for an event with no timeout (the vehicle may never answer) — then some run never ends. The
same decision on every route; what differs is the explanation: the explicit route shows the
loop as a lasso of its reachability graph (:func:`petri.verification.termination.lasso_through`),
or the shortest firing sequence to the task waiting; the structural route names them from the
syntax tree. The weaker ``can-end`` (from every state the mission can still end) is decided
apart (petri/verification/termination.py, mcl/analysis/outcomes.py).

A timer whose value is a mission parameter without a value bounds nothing yet: a mission that
only such a timer could bound is ``undecided`` (give the parameter a value).
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass
from typing import TYPE_CHECKING

from petri.verification.verdict import Result, undecided

from mcl.analysis.duration import Durations, Path, Step, analyse, stop_handler
from mcl.checker import Checked
from mcl.quantities import seconds_text

if TYPE_CHECKING:  # the explicit route's graph (numpy), given only to show a violation
    from petri.verification.graph import ReachabilityGraph

NAME = "terminates"
STOP_NAME = "stop-ends"  # the stop handler ends by itself within a proved bound
METHOD = "proved worst-case duration (mcl/analysis/duration.py: timeouts and timers only)"
ANSWER = re.compile(r"ends (ok|fail) (?:at once )?on (\S+)")


@dataclass(frozen=True)
class Endless:
    """What lets some run go on for ever: a WHILE (``loop``) or a task call that waits with no
    timeout, where it is (line, col), and why, in the mission's words."""

    line: int
    col: int
    loop: bool
    why: str


def endless(checked: Checked, d: Durations) -> Endless | None:
    """Why the mission's worst case is unbounded (None: it is finite)."""
    if math.isfinite(d.worst):
        return None
    steps = [s for s in d.critical_path if not math.isfinite(s.seconds)]
    if not steps:  # the mission never ends: name a WHILE that never ends
        never = [b for b in d.blocks if b.construct == "WhileDo" and not b.ends]
        loops = {(s.line, s.col): s for s in d.loops}
        chosen = [loops[(b.line, b.col)] for b in never if (b.line, b.col) in loops]
        if not chosen and not d.loops:
            return None
        steps = [(chosen or d.loops)[-1]]
    s = steps[0]
    if s.text.startswith("WHILE "):
        return Endless(s.line, s.col, True, loop_text(s, d.laps.get((s.line, s.col), ())))
    return Endless(s.line, s.col, False, wait_text(checked, s))


def loop_text(s: Step, lap: Path) -> str:
    """The WHILE and the answers that keep it going round."""
    answers = []
    for step in lap:
        m = ANSWER.search(step.ending)
        if m and f"{step.text} ends {m[1]} on {m[2]}" not in answers:
            answers.append(f"{step.text} ends {m[1]} on {m[2]}")
    cond = s.text.removeprefix("WHILE ")
    text = f"the WHILE at line {s.line} (`{cond}`) "
    if answers:
        text += "goes round for as long as " + " and ".join(answers)
    else:
        text += "goes round for ever whatever the vehicle answers (timers alone end its rounds)"
    return text + ": bound it, e.g. PARALLEL { WHILE ... } OR { Timeout(...) }"


def wait_text(checked: Checked, s: Step) -> str:
    """The task that waits for an event with no timeout."""
    events = next((f.ok + f.fail for c in checked.mission.calls()
                   if (c.span.line, c.span.col) == (s.line, s.col)
                   for f in [checked.resolved(c).form]), ())
    what = " or ".join(events) if events else "an event"
    return (f"line {s.line}: {s.text} waits for {what} with no timeout, so it ends only if the "
            "vehicle answers: give it one (timeout = ...) or race it with a Timeout")


def result(checked: Checked, how: str = "", g: ReachabilityGraph | None = None,
           durations: Durations | None = None) -> Result:
    """``terminates`` of the checked mission; with ``g`` (the explicit route's graph, ``how``
    it was made) a violation comes with its lasso or firing sequence."""
    d = durations if durations is not None else analyse(checked)
    method = METHOD
    shown = f"{METHOD}; the counterexample from the {how}"
    why = endless(checked, d)
    if why is None and math.isfinite(d.worst):
        return Result(NAME, True, "error", "every run ends, whatever the vehicle answers: "
                      f"its timeouts bound it to {seconds_text(d.worst)} (the proved worst "
                      "case)", method)
    if why is None:
        return Result(NAME, False, "error", "some run can go on for ever (the proved worst "
                      "case is unbounded)", method)
    if not why.loop and any((u.line, u.col) == (why.line, why.col) for u in d.unset_timers):
        return undecided(NAME, f"line {why.line}: only a timer whose value is a mission "
                         "parameter without a value bounds it: give it a value", method)
    message = "some run never ends: " + why.why
    if g is None:
        return Result(NAME, False, "error", message, method)
    if why.loop:
        from petri.verification.termination import lasso_through  # lazy for start-up
        # speed: numpy, which only a violation on the explicit route's graph needs

        found = lasso_through(g, transitions(g, f"WHILE@{why.line}:{why.col}.body_ok"))
        if found is not None:
            at, prefix, cycle = found
            return Result(NAME, False, "error", message, shown, prefix, at, cycle=cycle)
        return Result(NAME, False, "error", message, method)
    return waiting(g, message, shown, transitions(g, f"@{why.line}:{why.col}.start"))


def transitions(g: ReachabilityGraph, suffix: str) -> list[int]:
    """The transitions of the net whose name ends with ``suffix``."""
    return [t for t, tr in enumerate(g.net.transitions) if tr.name.endswith(suffix)]


def waiting(g: ReachabilityGraph, message: str, method: str, start: list[int]) -> Result:
    """The shortest firing sequence that starts the task that may wait for ever."""
    import numpy as np  # lazy for start-up speed: only a violation on the explicit route's
    # graph needs it

    ss = g.ss
    fires = np.isin(ss.transition, start) & ~g.stop_arc & g.main[ss.src]
    goal = np.zeros(g.n, bool)
    goal[ss.dst[fires]] = True
    if not goal.any():
        return Result(NAME, False, "error", message, method)
    path, at = g.main_arcs.path(0, goal)
    return Result(NAME, False, "error", message, method,
                  [int(ss.transition[a]) for a in path], at)


def stop_result(checked: Checked) -> Result | None:
    """``stop-ends``: the mission's stop handler (``ON STOP``) ends by itself within its proved
    worst case, the bound ``mcl run`` gives it after a stop (None: the mission has none)."""
    d = stop_handler(checked)
    if d is None:
        return None
    where = f"the stop handler (ON STOP, line {checked.mission.stop_span.line})"
    if math.isfinite(d.worst):
        return Result(STOP_NAME, True, "error", f"{where} ends by itself within "
                      f"{seconds_text(d.worst)} (its proved worst case), with nothing on", METHOD)
    why = endless(checked, d)
    if why is not None and not why.loop and any((u.line, u.col) == (why.line, why.col)
                                                for u in d.unset_timers):
        return undecided(STOP_NAME, f"line {why.line}: only a timer whose value is a mission "
                         "parameter without a value bounds it: give it a value", METHOD)
    text = why.why if why is not None else "its proved worst case is unbounded"
    return Result(STOP_NAME, False, "error", f"{where} may never end: {text}", METHOD)
