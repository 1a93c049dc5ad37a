"""``actions-match-behaviours``: the static check that each firing sends the actions that
switch the behaviours it turns on or off. It reads the net alone (no reachability graph, no
numpy), so every route runs it: the explicit one (petri/verification/properties.py and the
quick verdict of petri/verification/all_hold.py) and the structural one.
"""

from __future__ import annotations

from petri.net import Net
from petri.verification.verdict import Result


def actions_match(net: Net) -> Result:
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
