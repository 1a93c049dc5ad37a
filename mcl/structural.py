"""Verification of missions too large to enumerate: by construction, and by static analysis.

MCL nets are block-structured: every block is an instance of a template with the
begin/abort -> ok/fail/aborted interface (MCL.md §5). If each template used is sound with
*generic* children — blocks that may end ok, end fail, or be aborted at any moment — then a
mission built from them is sound by construction. So this module

1. verifies, by explicit reachability, each template the mission uses with generic children
   (the mission's own PARALLEL arity up to :data:`MAX_ARITY`; wider ones share the template's
   symmetric structure), one variant with a latched behaviour inside; this establishes
   one-safe, no-deadlock, final-reachable and proper-completion for the whole mission;
2. decides the mission-specific properties on the syntax tree: which latched behaviours may be
   on at each point (a data-flow analysis whose states are "off" or "on from call site S"),
   which tasks may run at the same time (their closest common block is a PARALLEL, or a TRY
   with one in the TRY block and one in the CATCH block), and so whether two behaviours
   driving the same degree of freedom may be on together and whether a behaviour may be left
   on at the end. The analysis over-approximates: a violation it reports may be a false
   alarm, but it misses none.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from functools import cache

from petri.verify import Result, Verdict, verify

from . import ast
from .checker import Checked

MAX_ARITY = 4
OFF = "off"

State = frozenset[tuple[str, str]]  # (behaviour, "off" | call site "line:col")


# -- how big would the state space be? --------------------------------------------------------
def estimate_markings(block: ast.Block) -> float:
    """A rough product-form estimate of the reachable markings of a block's subnet."""
    if isinstance(block, ast.Call):
        return 4.0
    kids = ast.children(block)
    if isinstance(block, (ast.ParallelAnd, ast.ParallelOr)):
        product = 1.0
        for k in kids:
            product *= estimate_markings(k) + 2
        return product * 2
    if isinstance(block, ast.TryCatchDo):
        t, c, d = (estimate_markings(k) for k in kids)
        return (t + 2) * (c + 2) * 2 + d
    return sum(estimate_markings(k) for k in kids) + len(kids)


def mission_estimate(checked: Checked) -> float:
    """Markings, roughly, with the latched behaviours and the mission's own abort."""
    return estimate_markings(checked.mission.body) * 3


# -- 1. templates verified with generic children --------------------------------------------
def _template_keys(body: ast.Block) -> list[tuple[str, int]]:
    keys: set[tuple[str, int]] = set()
    for b in ast.walk(body):
        match b:
            case ast.Sequence(items=items):
                keys.add(("SEQ", min(len(items), 3)))
            case ast.TryCatchDo():
                keys.add(("TRY", 3))
            case ast.ParallelAnd(branches=bs):
                keys.add(("AND", min(len(bs), MAX_ARITY)))
            case ast.ParallelOr(branches=bs):
                keys.add(("OR", min(len(bs), MAX_ARITY)))
            case ast.IfThenElse(else_=e):
                keys.add(("IF", 3 if e is not None else 2))
            case ast.WhileDo():
                keys.add(("WHILE", 2))
    keys.add(("TASK", 1))
    return sorted(keys)


def _generic_mission(kind: str, arity: int, variant: str) -> str:
    names = ["A()", "B()", "C()", "D()"][:arity]
    if variant == "latch":
        names[0] = "Lamp(enable); " + names[0] + "; Lamp(disable)"
    elif variant == "at-once":
        names[0] = "Now()"
    blocks = ["{ " + n + " }" for n in names]
    match kind:
        case "TASK":
            body = names[0]
        case "SEQ":
            body = "; ".join(n for n in names)
            if variant == "latch":
                body = "TRY { " + body + " } CATCH { D() } DO { Now() }"
        case "TRY":
            body = f"TRY {blocks[0]} CATCH {blocks[1]} DO {blocks[2]}"
        case "AND" | "OR":
            body = "PARALLEL " + f" {kind} ".join(blocks)
        case "IF":
            body = f"IF {blocks[0]} THEN {blocks[1]}" + (f" ELSE {blocks[2]}" if arity == 3 else "")
        case "WHILE":
            body = f"WHILE {blocks[0]} DO {blocks[1]}"
        case _:
            raise ValueError(kind)
    return f"MISSION {{ {body} }}"


@cache
def template_check(kind: str, arity: int) -> tuple[bool, int, str]:
    """Verify one template with generic children (three variants); (ok, markings, detail)."""
    from .api import compile_source
    from .errors import Source
    from .tasklib import load

    library = load(["generic"])
    markings = 0
    for variant in ("generic", "at-once", "latch"):
        text = _generic_mission(kind, arity, variant)
        net = compile_source(Source(f"<template {kind}>", text), library=library).net
        verdict = verify(net)
        markings += verdict.markings
        failed = [r.name for r in verdict.results if not r.holds and r.severity == "error"]
        if failed:
            return False, markings, f"{text}: {', '.join(failed)}"
    return True, markings, ""


# -- 2. latched behaviours and concurrency on the syntax tree ---------------------------------
def _site(call: ast.Call) -> str:
    return f"{call.span.line}:{call.span.col}"


@dataclass
class _Flow:
    checked: Checked
    at_call: dict[int, State] = field(default_factory=dict)  # states while the call runs

    def latch_of(self, call: ast.Call) -> tuple[str | None, bool]:
        form = self.checked.resolved(call).form
        if form.latch:
            return form.latch, True
        return form.unlatch, False

    def sites(self, block: ast.Block) -> set[tuple[str, str]]:
        out = set()
        for c in ast.calls(block):
            b, on = self.latch_of(c)
            if b is not None and on:
                out.add((b, _site(c)))
        return out

    def writes(self, block: ast.Block) -> set[str]:
        return {b for c in ast.calls(block) for b, _ in [self.latch_of(c)] if b is not None}

    @staticmethod
    def cleanup(states: State, sites: set[tuple[str, str]]) -> State:
        return frozenset((b, OFF) if (b, s) in sites else (b, s) for b, s in states)

    @staticmethod
    def put(states: State, behaviour: str, value: str) -> State:
        return frozenset({(b, s) for b, s in states if b != behaviour} | {(behaviour, value)})

    def created(self, block: ast.Block) -> State:
        """The latch states a block may create at any moment: 'on from here' at each of its
        latching calls, 'off' at each unlatching call and at each abort that cleans up."""
        out = set()
        for c in ast.calls(block):
            b, on = self.latch_of(c)
            if b is not None:
                out |= {(b, _site(c)), (b, OFF)} if on else {(b, OFF)}
        return frozenset(out)

    def flow(self, block: ast.Block, s: State, rely: State = frozenset()
             ) -> tuple[State, State]:
        """(states at the block's normal end, states at any moment during it). ``rely``:
        states that blocks running concurrently may create at any moment."""
        s = s | rely
        match block:
            case ast.Call():
                self.at_call[id(block)] = self.at_call.get(id(block), frozenset()) | s
                b, on = self.latch_of(block)
                if b is None:
                    return s, s
                end = self.put(s, b, _site(block) if on else OFF) | rely
                return end, s | end
            case ast.Sequence(items=items):
                during = s
                for item in items:
                    s, d = self.flow(item, s, rely)
                    during |= d
                return s, during
            case ast.IfThenElse(condition=c, then=a, else_=e):
                ec, dc = self.flow(c, s, rely)
                ea, da = self.flow(a, ec, rely)
                eb, db = self.flow(e, ec, rely) if e is not None else (ec, ec)
                return ea | eb, dc | da | db
            case ast.WhileDo(condition=c, body=body):
                head, end, during = s, frozenset(), s
                for _ in range(1000):  # a finite lattice: this converges in a few rounds
                    ec, dc = self.flow(c, head, rely)
                    eb, db = self.flow(body, ec, rely)
                    end, during = end | ec | eb, during | dc | db
                    if eb <= head:
                        break
                    head = head | eb
                return end, during
            case ast.ParallelAnd(branches=bs) | ast.ParallelOr(branches=bs):
                ends, during = self._concurrent(list(bs), s, rely)
                if isinstance(block, ast.ParallelOr):
                    first_ends: State = frozenset()
                    for i in range(len(bs)):
                        # the others are aborted: cleaned up if still running, as they ended
                        # if they had just ended (a late abort)
                        others = set().union(*(self.sites(b) for j, b in enumerate(bs) if j != i))
                        first_ends |= ends[i] | self.cleanup(ends[i], others)
                    return first_ends, during
                return self._last_writers(list(bs), ends, s), during
            case ast.TryCatchDo(try_=t, catch=c, do=d):
                ends, during = self._concurrent([t, c], s, rely)
                # whichever is aborted is cleaned up if it was running, or is as it ended
                try_first = ends[0] | self.cleanup(ends[0], self.sites(c))
                at_do = self.cleanup(during, self.sites(t)) | ends[0]
                ed, dd = self.flow(d, at_do, rely)
                return try_first | ed, during | dd
        raise TypeError(block)

    def _concurrent(self, blocks: list[ast.Block], s: State, rely: State
                    ) -> tuple[list[State], State]:
        """Blocks running together: each may see, at any moment, what the others create."""
        created = [self.created(b) for b in blocks]
        ends, during = [], s
        for i, b in enumerate(blocks):
            others = frozenset().union(*(created[j] for j in range(len(blocks)) if j != i))
            e, d = self.flow(b, s, rely | others)
            ends.append(e)
            during |= d
        return ends, during

    def _last_writers(self, blocks: list[ast.Block], ends: list[State], s: State) -> State:
        """After concurrent blocks have all ended: a behaviour's state is what a block that
        writes it left, or unchanged when none writes it."""
        out: set[tuple[str, str]] = set()
        for beh in {b for st in [s, *ends] for b, _ in st}:
            writers = [i for i, blk in enumerate(blocks) if beh in self.writes(blk)]
            for st in ([ends[i] for i in writers] if writers else [s]):
                out |= {(b, v) for b, v in st if b == beh}
        return frozenset(out)


def analyse(checked: Checked, net_method: str = "") -> Verdict:
    """Structural verification of a checked mission; returns a Verdict like petri.verify."""
    from .compiler import compile_mission

    start = time.perf_counter()
    net = compile_mission(checked)
    verdict = Verdict(net, 0, 0, 0.0)
    # 1. templates
    keys = _template_keys(checked.mission.body)
    checked_templates = [(k, template_check(*k)) for k in keys]
    bad = [(k, r) for k, r in checked_templates if not r[0]]
    total = sum(r[1] for _, r in checked_templates)
    shown = ", ".join(k if k in ("TASK", "TRY", "WHILE") else f"{k}×{a}"
                      for (k, a), _ in checked_templates)
    how = (f"by construction: each template used ({shown}) verified with generic children, "
           f"{total} markings in all")
    for name, good in (("one-safe", "every place holds at most one token"),
                       ("proper-completion", "the mission ends with exactly one token, in "
                        "MISSION.ok or MISSION.fail"),
                       ("no-deadlock", "no reachable marking is stuck before the mission ends"),
                       ("final-reachable", "from every reachable marking the mission can still "
                        "end")):
        if bad:
            verdict.results.append(Result(name, False, "error",
                                          f"a template fails with generic children: {bad[0][1][2]}",
                                          how))
        else:
            verdict.results.append(Result(name, True, "error", good, how))
    # 2. latches and concurrency
    flow = _Flow(checked)
    initial: State = frozenset((b, OFF) for c in ast.calls(checked.mission.body)
                               for b, _ in [flow.latch_of(c)] if b is not None)
    end, _during = flow.flow(checked.mission.body, initial)
    static = ("static analysis of the syntax tree (latched-behaviour data flow and "
              "may-happen-in-parallel; over-approximate: no violation is missed)")
    left_on = sorted({(b, s) for b, s in end if s != OFF})
    if left_on:
        where = ", ".join(f"{b} (switched on at line {s.split(':')[0]})" for b, s in left_on)
        verdict.results.append(Result("behaviours-off-at-end", False, "error",
                                      f"the mission may end with {where} still on", static))
    else:
        verdict.results.append(Result("behaviours-off-at-end", True, "error",
                                      "no behaviour is left on when the mission ends", static))
    conflict = _dof_conflict(checked, flow)
    if conflict:
        verdict.results.append(Result("dof-exclusive", False, "error", conflict, static))
    else:
        verdict.results.append(Result("dof-exclusive", True, "error",
                                      "no two behaviours driving the same degree of freedom are "
                                      "on together", static))
    shared = _shared_owner(checked, flow)
    verdict.results.append(Result("behaviour-single-owner", not shared, "error",
                                  shared or "no behaviour is held on by two tasks at once",
                                  static))
    from petri.verify import _actions_match

    verdict.results.append(_actions_match(net))
    verdict.results.append(Result("no-dead-transitions", True, "warning",
                                  "not checked: the state space is too large to enumerate",
                                  "not established"))
    verdict.seconds = time.perf_counter() - start
    return verdict


def _running(checked: Checked, call: ast.Call) -> tuple[str, ...]:
    form = checked.resolved(call).form
    return () if form.immediate else form.behaviours_on_while_running()


def _dof_conflict(checked: Checked, flow: _Flow) -> str:
    dofs = checked.library.dofs()

    def clash(a: str, b: str) -> set[str]:
        return set(dofs.get(a, ())) & set(dofs.get(b, ())) if a != b else set()

    calls = ast.calls(checked.mission.body)
    # a task against latched behaviours that may be on while it runs
    for call in calls:
        for beh in _running(checked, call):
            for latched, site in sorted(flow.at_call.get(id(call), frozenset())):
                if site != OFF and (common := clash(beh, latched)):
                    return (f"{call.span}: {call.name} may drive {', '.join(sorted(common))} "
                            f"({beh}) while {latched}, switched on at line "
                            f"{site.split(':')[0]}, is on")
    # two tasks that may run at the same time
    for a, b, construct in _may_run_together(checked.mission.body):
        for ba in _running(checked, a):
            for bb in _running(checked, b):
                if common := clash(ba, bb):
                    return (f"{a.span}: {a.name} ({ba}) and line {b.span.line} {b.name} ({bb}) "
                            f"may drive {', '.join(sorted(common))} at once (both run inside the "
                            f"{construct} at line {construct_line(checked, a, b)})")
    return ""


def _shared_owner(checked: Checked, flow: _Flow) -> str:
    """A behaviour two tasks may hold on at once (or a task while it is latched on)."""
    for call in ast.calls(checked.mission.body):
        for beh in _running(checked, call):
            for latched, site in sorted(flow.at_call.get(id(call), frozenset())):
                if site != OFF and latched == beh:
                    return (f"{call.span}: {call.name} may hold {beh} on while it is latched "
                            f"on from line {site.split(':')[0]}")
    for a, b, construct in _may_run_together(checked.mission.body):
        common = set(_running(checked, a)) & set(_running(checked, b))
        if common:
            return (f"{a.span}: {a.name} and line {b.span.line} {b.name} may hold "
                    f"{', '.join(sorted(common))} on at once (inside the {construct} at line "
                    f"{construct_line(checked, a, b)}): the first to end switches it off")
    return ""


def construct_line(checked: Checked, a: ast.Call, b: ast.Call) -> int:
    for block in ast.walk(checked.mission.body):
        kids = ast.children(block)
        inside = [any(x is a for x in ast.calls(k)) or any(x is b for x in ast.calls(k))
                  for k in kids]
        if sum(inside) == 2:
            return block.span.line
    return checked.mission.span.line


def _may_run_together(body: ast.Block) -> list[tuple[ast.Call, ast.Call, str]]:
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
