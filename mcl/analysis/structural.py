"""Verification of missions too large to enumerate: by construction, and on the syntax tree.

The verification model is petri/verification/properties.py's (docs/METHODS.md): the environment delivers any
awaited event or lets any timer expire at any moment; a block is aborted only by the construct
that contains it; the external stop, ``Mission.abort``, is verified separately. MCL nets are
block-structured: every block is an instance of a template with the begin/abort ->
ok/fail/aborted interface (MCL.md §5). So this module

1. verifies, by explicit reachability, each template the mission uses with *generic* children
   (blocks that may end ok or fail at any moment; the mission's PARALLEL arity up to
   :data:`MAX_ARITY`, wider ones sharing the template's symmetric structure), one variant with
   a latched behaviour inside and one with a child that ends at once, with petri/verification/properties.py:
   every property must hold, stop-safe included (the external stop aborts the template at any
   moment, and it and zero-time firings alone must end the mission with every behaviour off).
   This establishes one-safe, proper-completion, no-deadlock and stop-safe for the whole
   mission (given that mcl/analysis/latches.py's data flow, which prunes the latch transitions the
   compiler makes, over-approximates: the explicit route checks that on random missions);
2. decides termination and Zeno behaviour exactly, by an outcome analysis on the syntax tree:
   for each block, which endings (ok, fail) it can reach from its start, which from each state
   it can be in, and which in zero time (immediate tasks, 0 s timers; a task that waits for
   an event is never zero-time). A WHILE whose condition can never fail, and whose body can
   never fail, cannot end; a WHILE whose condition and body can both end ok in zero time goes
   round without time passing;
3. decides the behaviour properties on the syntax tree: which latched behaviours may be on at
   each point (a data-flow analysis whose states are "off" or "on from call site S"), which
   tasks may run at the same time (their closest common block is a PARALLEL, or a TRY with one
   in the TRY block and one in the CATCH block), and so whether two behaviours driving the
   same degree of freedom may be on together (task and task, task and latch, latch and latch,
   two behaviours one task enables), whether a behaviour that drives a degree of freedom may be
   held by two holders at once or switched off under a holder, and whether a latched behaviour
   may be left on at the end. Behaviours that drive no degree of freedom (watchers) may be
   shared. This part over-approximates: a violation it reports may be a false alarm (the
   data flow does not relate the states of two latches, and merges the rounds of a loop), but
   it misses none.

Anything it cannot establish is reported ``undecided`` (``no-dead-transitions`` always is: the
state space is not enumerated).
"""

from __future__ import annotations

import time
from collections.abc import Iterable
from functools import cache
from typing import TYPE_CHECKING

from petri.net import Net
from petri.verification.properties import Result, Verdict, undecided, verify

from mcl import ast, printer

from mcl.analysis import latches
from mcl.checker import Checked

if TYPE_CHECKING:
    from mcl.tasklib import Expr, TaskForm

MAX_ARITY = 3
OFF = latches.OFF
OK, FAIL = "ok", "fail"
ABORT_EVENT = "Mission.abort"

State = latches.State  # (behaviour, "off" | call site "line:col")
Cap = frozenset[str]  # the endings a block can still reach: a subset of {"ok", "fail"}
NONE: Cap = frozenset()
ONLY_OK: Cap = frozenset({OK})
ONLY_FAIL: Cap = frozenset({FAIL})


# -- how big would the state space be? --------------------------------------------------------
def estimate_markings(block: ast.Block) -> float:
    """A rough product-form estimate of the reachable markings of a block's subnet (iterative:
    a deep or long mission costs time linear in its size)."""
    memo: dict[int, float] = {}
    for b in reversed(ast.walk(block)):  # children before parents
        kids = [memo[id(k)] for k in ast.children(b)]
        if isinstance(b, ast.Call):
            est = 4.0
        elif isinstance(b, (ast.ParallelAnd, ast.ParallelOr)):
            product = 1.0
            for k in kids:
                product = min(product * (k + 2), 1e300)
            est = product * 2
        elif isinstance(b, ast.TryCatchDo):
            t, c, d = kids
            est = (t + 2) * (c + 2) * 2 + d
        else:
            est = sum(kids) + len(kids)
        memo[id(b)] = min(float(est), 1e300)
    return memo[id(block)]


def mission_estimate(checked: Checked) -> float:
    """Markings, roughly, with the latched behaviours (each one's state multiplies)."""
    latched = {b for c in ast.calls(checked.mission.body)
               for b in [_latch_of(checked.resolved(c).form)[0]] if b is not None}
    factor = 3.0 * 2.0 ** min(len(latched), 8)
    return min(estimate_markings(checked.mission.body) * factor, 1e300)


def _latch_of(form: TaskForm) -> tuple[str | None, bool]:
    if form.latch:
        return form.latch, True
    return form.unlatch, False


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


# Template properties that hold for the whole mission by construction.
BY_CONSTRUCTION = ("one-safe", "proper-completion", "no-deadlock")


@cache
def template_check(kind: str, arity: int) -> tuple[bool, int, str]:
    """Verify one template with generic children (three variants); (ok, markings, detail).
    Every error-level property the explicit route checks must hold, stop-safe included (the
    generic children can always fail, so loops can end)."""
    from diagnostics import Source

    from mcl.api import compile_source
    from mcl.tasklib import load

    library = load(["generic"])
    markings = 0
    for variant in ("generic", "at-once", "latch"):
        text = _generic_mission(kind, arity, variant)
        net = compile_source(Source(f"<template {kind}>", text), library=library).net
        verdict = verify(net)
        markings += verdict.markings
        bad = [f"{r.name} {r.status}" for r in verdict.results
               if not r.holds and r.severity == "error"]
        if not any(r.name == "stop-safe" for r in verdict.results):
            bad.append("stop-safe not checked by the explicit route")
        if bad:
            return False, markings, f"{text}: {', '.join(bad)}"
    return True, markings, ""


# -- 2. outcomes on the syntax tree: termination and Zeno cycles -------------------------------
class Outcomes:
    """Which endings each block can reach: from its start (:meth:`start`), in zero time
    (``zero`` "must": only immediate tasks and timers of 0 s; "may": also timers whose value
    is a mission parameter without a value), and from every state it can be in
    (:meth:`states`: the set of the endings reachable from each reachable state; a state from
    which none is reachable is ``NONE``). Exact in the untimed model: every awaited event and
    timer may happen, branches interleave freely, and latches never block a task."""

    def __init__(self, checked: Checked):
        self.checked = checked
        self._start: dict[tuple[int, str], Cap] = {}
        self._states: dict[int, frozenset[Cap]] = {}

    # endings a task call can reach
    def call(self, call: ast.Call, zero: str) -> Cap:
        resolved = self.checked.resolved(call)
        form = resolved.form
        if form.immediate:
            return ONLY_OK
        out: set[str] = set()
        if not zero:
            out |= {OK} if form.ok else set()
            out |= {FAIL} if form.fail else set()
        for seconds, status in _timeouts(self.checked, call):
            if zero == "" or seconds == 0 or (zero == "may" and isinstance(seconds, str)):
                out.add(status)
        return frozenset(out)

    def start(self, block: ast.Block, zero: str = "") -> Cap:
        """The endings ``block`` can reach from its start (in zero time if ``zero``)."""
        if (id(block), zero) in self._start:
            return self._start[(id(block), zero)]
        for b in reversed(ast.walk(block)):  # children first, without deep recursion
            key = (id(b), zero)
            if key not in self._start:
                self._start[key] = self._start_of(b, zero)
        return self._start[(id(block), zero)]

    def _start_of(self, b: ast.Block, zero: str) -> Cap:
        s = self._start
        match b:
            case ast.Call():
                return self.call(b, zero)
            case ast.Sequence(items=items):
                if all(s[(id(i), zero)] for i in items[:-1]):
                    return s[(id(items[-1]), zero)]
                return NONE
            case ast.IfThenElse(condition=c, then=t, else_=e):
                oc, out = s[(id(c), zero)], set[str]()
                if OK in oc:
                    out |= s[(id(t), zero)]
                if FAIL in oc:
                    out |= s[(id(e), zero)] if e is not None else {FAIL}
                return frozenset(out)
            case ast.WhileDo(condition=c, body=body):
                return _while_exit(s[(id(c), zero)], s[(id(body), zero)])
            case ast.ParallelAnd(branches=bs):  # waits for every branch to end
                outs = [s[(id(x), zero)] for x in bs]
                if not all(outs):
                    return NONE
                return frozenset(({OK} if all(OK in o for o in outs) else set())
                                 | ({FAIL} if any(FAIL in o for o in outs) else set()))
            case ast.ParallelOr(branches=bs):
                return frozenset().union(*(s[(id(x), zero)] for x in bs))
            case ast.TryCatchDo(try_=t, catch=c, do=d):
                return s[(id(t), zero)] | (s[(id(d), zero)] if s[(id(c), zero)] else NONE)
        raise TypeError(b)

    def states(self, block: ast.Block) -> frozenset[Cap]:
        """For each state the block can be in (from its start until it ends, never aborted),
        the endings reachable from there."""
        if id(block) in self._states:
            return self._states[id(block)]
        self.start(block)
        for b in reversed(ast.walk(block)):
            if id(b) not in self._states:
                self._states[id(b)] = self._states_of(b)
        return self._states[id(block)]

    def _states_of(self, b: ast.Block) -> frozenset[Cap]:
        st, out = self._states, set[Cap]()

        def o(x: ast.Block) -> Cap:
            return self._start[(id(x), "")]

        match b:
            case ast.Call():
                out.add(o(b))
            case ast.Sequence(items=items):
                # after[i]: the endings reachable from the start of item i + 1 (linear time)
                after: list[Cap | None] = [None] * len(items)
                for i in range(len(items) - 2, -1, -1):
                    nxt = items[i + 1]
                    later = after[i + 1]
                    after[i] = o(nxt) if later is None else (later if o(nxt) else NONE)
                for i, item in enumerate(items):
                    if i and not o(items[i - 1]):
                        break  # this item and those after it are never reached
                    rest = after[i]
                    out |= {c if rest is None else (rest if c else NONE) for c in st[id(item)]}
            case ast.IfThenElse(condition=c, then=t, else_=e):
                other = o(e) if e is not None else ONLY_FAIL
                out |= {(o(t) if OK in cc else NONE) | (other if FAIL in cc else NONE)
                        for cc in st[id(c)]}
                if OK in o(c):
                    out |= st[id(t)]
                if FAIL in o(c) and e is not None:
                    out |= st[id(e)]
            case ast.WhileDo(condition=c, body=body):
                head = o(b)
                at_body = (ONLY_FAIL if FAIL in o(body) else NONE) | (head if OK in o(body)
                                                                      else NONE)
                out |= {(ONLY_OK if FAIL in cc else NONE) | (at_body if OK in cc else NONE)
                        for cc in st[id(c)]}
                if OK in o(c):
                    out |= {(ONLY_FAIL if FAIL in bc else NONE) | (head if OK in bc else NONE)
                            for bc in st[id(body)]}
            case ast.ParallelAnd(branches=bs):
                # every branch must end (a failed one does not stop the others): per joint
                # state (all can end, all can end ok, one ended or can end fail, one runs)
                combos = {(True, True, False, False)}
                for x in bs:
                    options = {(bool(c), OK in c, FAIL in c, True) for c in st[id(x)]}
                    if OK in o(x):
                        options.add((True, True, False, False))  # ended ok
                    if FAIL in o(x):
                        options.add((True, False, True, False))  # ended fail
                    combos = {(e1 and e2, k1 and k2, f1 or f2, r1 or r2)
                              for e1, k1, f1, r1 in combos for e2, k2, f2, r2 in options}
                out |= {frozenset(({OK} if k else set()) | ({FAIL} if f else set()))
                        if e else NONE for e, k, f, r in combos if r}
            case ast.ParallelOr(branches=bs):
                unions = {NONE}
                for x in bs:
                    unions = {u | c for u in unions for c in st[id(x)]}
                out |= unions
                out |= {frozenset({e}) for x in bs for e in o(x)}  # one won, the rest stop
            case ast.TryCatchDo(try_=t, catch=c, do=d):
                then = o(d) if o(c) else NONE
                out |= {ct | (o(d) if cc else NONE) for ct in st[id(t)] for cc in st[id(c)]}
                out |= {frozenset({e}) for e in o(t)}  # TRY ended first: CATCH is stopped
                if o(c):
                    out |= {then} | set(st[id(d)])
        return frozenset(out)

    def reachable(self, body: ast.Block) -> set[int]:
        """ids of the blocks of ``body`` that can start (``body`` itself starts)."""
        self.start(body)
        seen, stack = set(), [body]
        while stack:
            b = stack.pop()
            seen.add(id(b))
            match b:
                case ast.Sequence(items=items):
                    for i, item in enumerate(items):
                        if i and not self.start(items[i - 1]):
                            break
                        stack.append(item)
                case ast.IfThenElse(condition=c, then=t, else_=e):
                    stack.append(c)
                    if OK in self.start(c):
                        stack.append(t)
                    if FAIL in self.start(c) and e is not None:
                        stack.append(e)
                case ast.WhileDo(condition=c, body=inner):
                    stack.append(c)
                    if OK in self.start(c):
                        stack.append(inner)
                case ast.TryCatchDo(try_=t, catch=c, do=d):
                    stack += [t, c] + ([d] if self.start(c) else [])
                case _:
                    stack.extend(ast.children(b))
        return seen


def _while_exit(cond: Cap, body: Cap) -> Cap:
    """Endings of a WHILE from its head: the condition fails (ok), or it ends ok and the body
    fails (fail); each round that ends ok comes back to the same head."""
    return frozenset(({OK} if FAIL in cond else set())
                     | ({FAIL} if OK in cond and FAIL in body else set()))


def _timeouts(checked: Checked, call: ast.Call) -> list[tuple[float | str, str]]:
    """The call's timers as the task template makes them: (seconds or parameter, status)."""
    from mcl.templates.common import Context
    from mcl.templates.task import _timer

    resolved = checked.resolved(call)
    form = resolved.form
    timeouts: list[tuple[Expr, str]] = []
    if resolved.timeout is not None:  # a per-call timeout replaces a declared fail timeout
        timeouts.append((resolved.timeout, FAIL))
        if form.timeout is not None and form.timeout[1] == OK:
            timeouts.append(form.timeout)
    elif form.timeout is not None:
        timeouts.append(form.timeout)
    ctx = Context(Net("timers"), checked)
    return [(_timer(ctx, expr, resolved), status) for expr, status in timeouts]


def _shown(block: ast.Block) -> str:
    """A block as written, on one line (shortened)."""
    text = " ".join(printer.block(block, 0).split())
    text = text[2:-2] if text.startswith("{ ") and text.endswith(" }") else text
    return text if len(text) <= 60 else text[:57] + "..."


def _cannot_end(out: Outcomes, body: ast.Block, reach: set[int]) -> str:
    """Why the mission cannot always end: the innermost reachable WHILE that cannot end."""
    stack = [body]
    while stack:
        b = stack.pop()
        if id(b) not in reach or NONE not in out.states(b):
            continue
        inner = [k for k in ast.children(b) if id(k) in reach and NONE in out.states(k)]
        if inner:
            stack.extend(inner)
            continue
        if isinstance(b, ast.WhileDo):
            text = (f"the WHILE at line {b.span.line} cannot end: its condition "
                    f"`{_shown(b.condition)}` can never fail")
            if OK in out.start(b.condition):
                text += " and its body never fails, so it goes round for ever"
            return text
    return "a block can reach a state from which it never ends"


def _zeno(out: Outcomes, body: ast.Block, reach: set[int], zero: str) -> ast.WhileDo | None:
    for b in ast.walk(body):
        if isinstance(b, ast.WhileDo) and id(b) in reach and OK in out.start(
                b.condition, zero) and OK in out.start(b.body, zero):
            return b
    return None


# -- 3. latched behaviours and concurrency on the syntax tree ---------------------------------
class _Flow(latches.Flow):
    """mcl/analysis/latches.py's data flow, checking at each latching call whether another latched
    behaviour sharing a degree of freedom may be on: two latches are first on together just
    after one of them is switched on."""

    def __init__(self, checked: Checked, outcomes: Outcomes):
        super().__init__(checked)
        self.clash = ""
        self._dofs = checked.library.dofs()
        self.outcomes = outcomes

    def flow(self, block: ast.Block, s: State, rely: State = frozenset()
             ) -> tuple[State, State]:
        """As mcl/analysis/latches.py's, but a block that can never end has no end states (so a latch
        switched on in a loop that never ends is not "left on at the end")."""
        end, during = super().flow(block, s, rely)
        return (end if self.outcomes.start(block) else frozenset()), during

    def _flow(self, block: ast.Block, s: State, rely: State) -> tuple[State, State]:
        """WHILE and IF take only the exits and branches their outcomes allow."""
        can = self.outcomes.start
        match block:
            case ast.WhileDo(condition=c, body=body):
                head, end, during = s, frozenset[tuple[str, str]](), s
                for _ in range(1000):  # a finite lattice: this converges in a few rounds
                    ec, dc = self.flow(c, head, rely)
                    eb, db = self.flow(body, ec, rely) if OK in can(c) else (frozenset(), ec)
                    end |= (ec if FAIL in can(c) else frozenset()) | (
                        eb if FAIL in can(body) else frozenset())
                    during = during | dc | db
                    if eb <= head:
                        break
                    head = head | eb
                return end, during
            case ast.IfThenElse(condition=c, then=a, else_=e):
                ec, dc = self.flow(c, s, rely)
                ea, da = self.flow(a, ec, rely) if OK in can(c) else (frozenset(), ec)
                if FAIL not in can(c):
                    eb, db = frozenset[tuple[str, str]](), ec
                else:
                    eb, db = self.flow(e, ec, rely) if e is not None else (ec, ec)
                return ea | eb, dc | da | db
            case ast.ParallelOr(branches=bs):
                ends, during = self._concurrent(list(bs), s, rely)
                return self._race_ends(list(bs), ends), during
            case ast.TryCatchDo(try_=t, catch=c, do=d):
                ends, during = self._concurrent([t, c], s, rely)
                # TRY ended first: CATCH stopped (cleaned up), or it had ended too
                try_first = self.cleanup(ends[0], self.sites(c)) | (ends[0] & ends[1])
                at_do = self.cleanup(during, self.sites(t)) | ends[0]
                ed, dd = self.flow(d, at_do, rely)
                return try_first | ed, during | dd
        return super()._flow(block, s, rely)

    def switched_on(self, call: ast.Call, behaviour: str, after: State) -> None:
        if self.clash:
            return
        mine = set(self._dofs.get(behaviour, ()))
        for other, site in sorted(after):
            if other != behaviour and site != OFF and (common := mine & set(
                    self._dofs.get(other, ()))):
                self.clash = (f"{call.span}: {call.name} switches {behaviour} on while "
                              f"{other}, switched on at line {site.split(':')[0]}, may be on: "
                              f"both drive {', '.join(sorted(common))}")
                return

    def _race_ends(self, blocks: list[ast.Block], ends: list[State]) -> State:
        """The states after a race (PARALLEL OR): branch i ended first and the others were
        stopped, their latches cleaned up, or some of them had ended too (a late abort). A
        branch's end states include everything the others may create meanwhile, so a state
        after branches i and j both ended lies in both their end sets."""
        sites = [self.sites(b) for b in blocks]
        out: set[tuple[str, str]] = set()
        for i in range(len(blocks)):
            running = set().union(*(sites[k] for k in range(len(blocks)) if k != i))
            out |= self.cleanup(ends[i], running)
            for j in range(len(blocks)):
                if j != i:
                    rest = set().union(*(sites[k] for k in range(len(blocks)) if k not in (i, j)))
                    out |= self.cleanup(ends[i] & ends[j], rest)
        return frozenset(out)


STATIC = ("static analysis of the syntax tree (latched-behaviour data flow and "
          "may-happen-in-parallel; over-approximate: a violation may be a false alarm, none "
          "is missed)")
OUTCOMES = ("outcome analysis of the syntax tree (which endings each block can reach, and "
            "which in zero time; exact in the verification model)")


def analyse(checked: Checked, net: Net | None = None, note: str = "") -> Verdict:
    """Structural verification of a checked mission; returns a Verdict like petri.verification.properties.
    ``net``: the mission's compiled net (compiled here if not given); ``note``: added to each
    method (e.g. why this route was chosen)."""
    from mcl.compiler import compile_mission

    start = time.perf_counter()
    if net is None:
        net = compile_mission(checked)
    verdict = Verdict(net, 0, 0, 0.0)
    results = verdict.results
    suffix = f" ({note})" if note else ""
    body = checked.mission.body
    # 1. templates
    keys = _template_keys(body)
    checked_templates = [(k, template_check(*k)) for k in keys]
    bad = [(k, r) for k, r in checked_templates if not r[0]]
    total = sum(r[1] for _, r in checked_templates)
    shown = ", ".join(k if k in ("TASK", "TRY", "WHILE") else f"{k}×{a}"
                      for (k, a), _ in checked_templates)
    how = (f"by construction: each template used ({shown}) verified with generic children, "
           f"{total} markings in all{suffix}")
    goods = {"one-safe": "every place holds at most one token",
             "proper-completion": "the mission ends with exactly one token, in MISSION.ok or "
                                  "MISSION.fail",
             "no-deadlock": "no reachable marking is stuck before the mission ends",
             "stop-safe": "from every marking, the external stop ends the mission at once "
                          "with every behaviour off"}
    for name, good in goods.items():
        if bad:
            results.append(undecided(name, "a template fails with generic children, so "
                                     f"nothing follows by construction: {bad[0][1][2]}", how))
        else:
            results.append(Result(name, True, "error", good, how))
    # 2. outcomes: termination and Zeno cycles
    out = Outcomes(checked)
    reach = out.reachable(body)
    ohow = OUTCOMES + suffix
    if NONE in out.states(body):
        results.append(Result("terminates", False, "error", _cannot_end(out, body, reach),
                              ohow))
    else:
        results.append(Result("terminates", True, "error", "from every reachable marking the "
                              "mission can end without an external stop", ohow))
    looping = _zeno(out, body, reach, "must")
    if looping is not None:
        results.append(Result("no-zeno", False, "error", _zeno_text(looping), ohow))
    elif (maybe := _zeno(out, body, reach, "may")) is not None:
        results.append(undecided("no-zeno", f"{_zeno_text(maybe)} if a timer whose value is a "
                                 "mission parameter without a value is 0 s", ohow))
    else:
        results.append(Result("no-zeno", True, "error", "no cycle can go round without time "
                              "passing", ohow))
    # 3. latches and concurrency
    reached = [c for c in ast.calls(body) if id(c) in reach]
    flow = _Flow(checked, out)
    end, _during = flow.flow(body, flow.initial(body))
    static = STATIC + suffix
    left_on = sorted({(b, s) for b, s in end if s != OFF})
    if left_on:
        where = ", ".join(f"{b} (switched on at line {s.split(':')[0]})" for b, s in left_on)
        results.append(Result("behaviours-off-at-end", False, "error",
                              f"the mission may end with {where} still on", static))
    else:
        results.append(Result("behaviours-off-at-end", True, "error",
                              "no behaviour is left on when the mission ends", static))
    together = [(a, b, k) for a, b, k in _may_run_together(body)
                if id(a) in reach and id(b) in reach]
    conflict = _dof_conflict(checked, flow, reached, together)
    results.append(Result("dof-exclusive", not conflict, "error",
                          conflict or "no two behaviours driving the same degree of freedom "
                          "are on together", static))
    shared = _shared_owner(checked, flow, reached, together)
    results.append(Result("behaviour-single-owner", not shared, "error",
                          shared or "no behaviour that drives a degree of freedom is held on "
                          "by two tasks at once", static))
    under = _disable_while_held(checked, flow, reached, together)
    results.append(Result("no-disable-while-held", not under, "error",
                          under or "no firing switches off a behaviour another task or latch "
                          "still holds", static))
    from petri.verification.properties import _actions_match

    results.append(_actions_match(net))
    results.append(undecided("no-dead-transitions", "not checked: the state space is not "
                             "enumerated", "not established" + suffix, severity="warning"))
    verdict.seconds = time.perf_counter() - start
    return verdict


def _zeno_text(loop: ast.WhileDo) -> str:
    return (f"the WHILE at line {loop.span.line} can go round without time passing: its "
            f"condition `{_shown(loop.condition)}` and its body `{_shown(loop.body)}` can both "
            "end ok at once")


def _running(checked: Checked, call: ast.Call) -> tuple[str, ...]:
    form = checked.resolved(call).form
    return () if form.immediate else form.behaviours_on_while_running()


def _on_latches(flow: _Flow, call: ast.Call) -> list[tuple[str, str]]:
    return sorted((b, s) for b, s in flow.at_call.get(id(call), frozenset()) if s != OFF)


def _dof_conflict(checked: Checked, flow: _Flow, calls: list[ast.Call],
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


def _shared_owner(checked: Checked, flow: _Flow, calls: list[ast.Call],
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


def _disable_while_held(checked: Checked, flow: _Flow, calls: list[ast.Call],
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
