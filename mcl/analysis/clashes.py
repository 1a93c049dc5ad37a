"""Behaviours that clash, decided on the syntax tree (the structural route's part 3,
mcl/analysis/structural.py).

Which latched behaviours may be on at each point (mcl/analysis/latches.py's data flow, whose
states are "off" or "on from call site S", here taking only the exits and branches that
mcl/analysis/outcomes.py allows), which tasks may run at the same time (their closest common
block is a PARALLEL, or a TRY with one in the TRY block and one in the CATCH block), and so:
whether two behaviours driving the same degree of freedom may be on together (task and task,
task and latch, latch and latch, two behaviours one task enables), whether a behaviour that
drives a degree of freedom may be held by two holders at once or switched off under a holder,
and whether a latched behaviour may be left on at the end. Behaviours that drive no degree of
freedom (watchers) may be shared.

This over-approximates: a violation it reports may be a false alarm (the data flow does not
relate the states of two latches, and merges the rounds of a loop), but it misses none.
"""

from __future__ import annotations

from collections.abc import Iterable

from petri.verification.properties import Result

from mcl import ast
from mcl.analysis.latches import OFF, Flow, State
from mcl.analysis.outcomes import Outcomes
from mcl.checker import Checked

METHOD = ("static analysis of the syntax tree (latched-behaviour data flow and "
          "may-happen-in-parallel; over-approximate: a violation may be a false alarm, none "
          "is missed)")


class ClashFlow(Flow):
    """mcl/analysis/latches.py's data flow, pruned by the blocks' outcomes and finer after a
    race, checking at each latching call whether another latched behaviour sharing a degree
    of freedom may be on: two latches are first on together just after one of them is
    switched on (:attr:`clash`, the first such call, or "")."""

    def __init__(self, checked: Checked, outcomes: Outcomes):
        super().__init__(checked)
        self.clash = ""
        self.drives = checked.library.dofs()
        self.outcomes = outcomes

    def can_end(self, block: ast.Block) -> frozenset[str]:
        """The endings the outcome analysis allows: WHILE and IF take only those exits and
        branches, and a block that can never end has no end states (so a latch switched on
        in a loop that never ends is not "left on at the end")."""
        return self.outcomes.start(block)

    def switched_on(self, call: ast.Call, behaviour: str, after: State) -> None:
        if self.clash:
            return
        mine = set(self.drives.get(behaviour, ()))
        for other, site in sorted(after):
            if other != behaviour and site != OFF and (common := mine & set(
                    self.drives.get(other, ()))):
                self.clash = (f"{call.span}: {call.name} switches {behaviour} on while "
                              f"{other}, switched on at line {site.split(':')[0]}, may be on: "
                              f"both drive {', '.join(sorted(common))}")
                return

    def race_won(self, blocks: list[ast.Block], ends: list[State], winner: int) -> State:
        """The states after ``blocks[winner]`` ended first in a race: the others were
        stopped, their latches cleaned up, or some of them had ended too (a late abort). A
        block's end states include everything the others may create meanwhile, so a state
        after blocks i and j both ended lies in both their end sets."""
        sites = [self.sites(b) for b in blocks]
        others = [k for k in range(len(blocks)) if k != winner]
        out = set(self.cleanup(ends[winner], set().union(*(sites[k] for k in others))))
        for j in others:
            rest = set().union(*(sites[k] for k in others if k != j))
            out |= self.cleanup(ends[winner] & ends[j], rest)
        return frozenset(out)



def results(checked: Checked, out: Outcomes, body: ast.Block, reach: set[int], method: str
            ) -> list[Result]:
    """The properties ``behaviours-off-at-end``, ``dof-exclusive``, ``behaviour-single-owner``
    and ``no-disable-while-held`` of the mission ``body``; ``reach``: the blocks that can
    start (:meth:`Outcomes.reachable`)."""
    found: list[Result] = []
    reached = [c for c in ast.calls(body) if id(c) in reach]
    flow = ClashFlow(checked, out)
    end, _during = flow.flow(body, flow.initial(body))
    left_on = sorted({(b, s) for b, s in end if s != OFF})
    if left_on:
        where = ", ".join(f"{b} (switched on at line {s.split(':')[0]})" for b, s in left_on)
        found.append(Result("behaviours-off-at-end", False, "error",
                            f"the mission may end with {where} still on", method))
    else:
        found.append(Result("behaviours-off-at-end", True, "error",
                            "no behaviour is left on when the mission ends", method))
    together = [(a, b, k) for a, b, k in may_run_together(body)
                if id(a) in reach and id(b) in reach]
    conflict = dof_conflict(checked, flow, reached, together)
    found.append(Result("dof-exclusive", not conflict, "error",
                        conflict or "no two behaviours driving the same degree of freedom "
                        "are on together", method))
    shared = shared_owner(checked, flow, reached, together)
    found.append(Result("behaviour-single-owner", not shared, "error",
                        shared or "no behaviour that drives a degree of freedom is held on "
                        "by two tasks at once", method))
    under = disable_while_held(checked, flow, reached, together)
    found.append(Result("no-disable-while-held", not under, "error",
                        under or "no firing switches off a behaviour another task or latch "
                        "still holds", method))
    return found


def _running(checked: Checked, call: ast.Call) -> tuple[str, ...]:
    form = checked.resolved(call).form
    return () if form.immediate else form.behaviours_on_while_running()


def _on_latches(flow: ClashFlow, call: ast.Call) -> list[tuple[str, str]]:
    return sorted((b, s) for b, s in flow.at_call.get(id(call), frozenset()) if s != OFF)


def dof_conflict(checked: Checked, flow: ClashFlow, calls: list[ast.Call],
                  together: list[tuple[ast.Call, ast.Call, str]]) -> str:
    dofs = checked.library.dofs()

    def clash(a: str, b: str) -> set[str]:
        return set(dofs.get(a, ())) & set(dofs.get(b, ())) if a != b else set()

    for call in calls:
        running = _running(checked, call)
        # two behaviours one task switches on
        for i, ba in enumerate(running):
            for bb in running[i + 1:]:
                if common := clash(ba, bb):
                    return (f"{call.span}: {call.name} switches on {ba} and {bb}, which both "
                            f"drive {', '.join(sorted(common))}")
        # a task against latched behaviours that may be on while it runs
        for beh in running:
            for latched, site in _on_latches(flow, call):
                if common := clash(beh, latched):
                    return (f"{call.span}: {call.name} may drive {', '.join(sorted(common))} "
                            f"({beh}) while {latched}, switched on at line "
                            f"{site.split(':')[0]}, is on")
    # two latched behaviours
    if flow.clash:
        return flow.clash
    # two tasks that may run at the same time
    for a, b, construct in together:
        for ba in _running(checked, a):
            for bb in _running(checked, b):
                if common := clash(ba, bb):
                    return (f"{a.span}: {a.name} ({ba}) and line {b.span.line} {b.name} ({bb}) "
                            f"may drive {', '.join(sorted(common))} at once (both run inside the "
                            f"{construct} at line {construct_line(checked, a, b)})")
    return ""


def _drives(checked: Checked, behaviour: str) -> bool:
    return bool(checked.library.dofs().get(behaviour, ()))


def shared_owner(checked: Checked, flow: ClashFlow, calls: list[ast.Call],
                  together: list[tuple[ast.Call, ast.Call, str]]) -> str:
    """A behaviour that drives a degree of freedom two tasks may hold on at once (or a task
    while it is latched on). Watchers (no degree of freedom) may be shared."""
    for call in calls:
        for beh in _running(checked, call):
            for latched, site in _on_latches(flow, call):
                if latched == beh and _drives(checked, beh):
                    return (f"{call.span}: {call.name} may hold {beh} on while it is latched "
                            f"on from line {site.split(':')[0]}")
    for a, b, construct in together:
        common = {x for x in set(_running(checked, a)) & set(_running(checked, b))
                  if _drives(checked, x)}
        if common:
            return (f"{a.span}: {a.name} and line {b.span.line} {b.name} may hold "
                    f"{', '.join(sorted(common))} on at once (inside the {construct} at line "
                    f"{construct_line(checked, a, b)}): the first to end switches it off")
    return ""


def _disables(checked: Checked, call: ast.Call) -> set[str]:
    """Behaviours driving a degree of freedom that a call's firings switch off (its start
    actions, and its stop actions when it waits)."""
    form = checked.resolved(call).form
    actions: Iterable[object] = form.start if form.immediate else (*form.start, *form.stop)
    return {a.behaviour for a in actions  # type: ignore[attr-defined]
            if a.kind == "disable" and _drives(checked, a.behaviour)}  # type: ignore[attr-defined]


def disable_while_held(checked: Checked, flow: ClashFlow, calls: list[ast.Call],
                        together: list[tuple[ast.Call, ast.Call, str]]) -> str:
    """A firing that switches off a behaviour driving a degree of freedom while another task,
    or its latch, still holds it. A task that runs can always end (its event may come), so a
    task holding b while b's latch is on, or while another task holding b runs, is one; so is
    a call that switches b off (an unlatch, a stop) while a task holding b may run."""
    for call in calls:
        form = checked.resolved(call).form
        unlatch = form.unlatch
        for beh in sorted(_disables(checked, call)):
            if beh == unlatch:
                continue  # the unlatch takes the latch's own "on" place
            for latched, site in _on_latches(flow, call):
                if latched == beh:
                    return (f"{call.span}: {call.name} may switch {beh} off while it is "
                            f"latched on from line {site.split(':')[0]}")
    for a, b, construct in together:
        for x, y in ((a, b), (b, a)):
            held = set(_running(checked, y)) & _disables(checked, x)
            if held:
                return (f"{x.span}: {x.name} may switch {', '.join(sorted(held))} off while "
                        f"line {y.span.line} {y.name} holds it (both run inside the "
                        f"{construct} at line {construct_line(checked, x, y)})")
    return ""


def construct_line(checked: Checked, a: ast.Call, b: ast.Call) -> int:
    for block in (b for part in checked.mission.parts() for b in ast.walk(part)):
        kids = ast.children(block)
        inside = [any(x is a for x in ast.calls(k)) or any(x is b for x in ast.calls(k))
                  for k in kids]
        if sum(inside) == 2:
            return block.span.line
    return checked.mission.span.line


def may_run_together(body: ast.Block) -> list[tuple[ast.Call, ast.Call, str]]:
    """Pairs of calls whose closest common block runs them concurrently."""
    pairs = []
    for block in ast.walk(body):
        groups: list[list[ast.Call]] = []
        name = ""
        match block:
            case ast.ParallelAnd(branches=bs) | ast.ParallelOr(branches=bs):
                groups = [ast.calls(b) for b in bs]
                name = "PARALLEL"
            case ast.TryCatchDo(try_=t, catch=c):
                groups = [ast.calls(t), ast.calls(c)]
                name = "TRY"
        for i in range(len(groups)):
            for j in range(i + 1, len(groups)):
                pairs += [(a, b, name) for a in groups[i] for b in groups[j]]
    return pairs
