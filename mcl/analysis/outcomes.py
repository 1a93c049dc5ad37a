"""Which endings each block of a mission can reach: ``can-end``, Zeno cycles and instant loops
(``instant-loop``: a loop that spins at one instant when the vehicle answers at once), decided on
the syntax tree (the structural route's part 2, mcl/analysis/structural.py; ``terminates``,
that every run ends, is decided from the proved worst case: mcl/analysis/termination.py).

For each block, which endings (ok, fail) it can reach from its start, which from each state it
can be in, and which in zero time (immediate tasks, 0 s timers; a task that waits for an event
is never zero-time). A WHILE whose condition can never fail, and whose body can never fail,
cannot end; a WHILE whose condition and body can both end ok in zero time goes round without
time passing. Exact in the verification model (petri/verification/properties.py): every
awaited event and timer may happen, branches interleave freely, and latches never block a task.
"""

from __future__ import annotations

from petri.verification.properties import Result, undecided
from petri.verification.termination import instant_text
from petri.verification.verdict import INSTANT_OK

from mcl import ast, printer
from mcl.checker import Checked
from mcl.timers import timers

OK, FAIL = "ok", "fail"
Cap = frozenset[str]  # the endings a block can still reach: a subset of {"ok", "fail"}
NONE: Cap = frozenset()
ONLY_OK: Cap = frozenset({OK})
ONLY_FAIL: Cap = frozenset({FAIL})
METHOD = ("outcome analysis of the syntax tree (which endings each block can reach, and "
          "which in zero time; exact in the verification model)")


class Outcomes:
    """Which endings each block can reach: from its start (:meth:`start`), in zero time
    (``zero`` "must": only immediate tasks and timers of 0 s; "may": also timers whose value
    is a mission parameter without a value; "instant": also awaited events, which a vehicle
    may answer at once — only a timer of a positive delay takes time), and from every state it can be in
    (:meth:`states`: the set of the endings reachable from each reachable state; a state from
    which none is reachable is ``NONE``). Exact in the untimed model: every awaited event and
    timer may happen, branches interleave freely, and latches never block a task."""

    def __init__(self, checked: Checked):
        self.checked = checked
        self._start: dict[tuple[int, str], Cap] = {}
        self._states: dict[int, frozenset[Cap]] = {}
        self.steps = 0  # blocks analysed (each once per question): the work done

    # endings a task call can reach
    def call(self, call: ast.Call, zero: str) -> Cap:
        resolved = self.checked.resolved(call)
        form = resolved.form
        if form.immediate:
            return ONLY_OK
        out: set[str] = set()
        if zero in ("", "instant"):  # "instant": the vehicle may answer at once
            out |= {OK} if form.ok else set()
            out |= {FAIL} if form.fail else set()
        for timer in timers(self.checked, call):  # the rule: mcl/timers.py
            seconds = timer.seconds
            if zero == "" or seconds == 0 or (zero in ("may", "instant")
                                              and isinstance(seconds, str)):
                out.add(timer.status)
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
        self.steps += 1
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
                return while_exit(s[(id(c), zero)], s[(id(body), zero)])
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
        self.steps += 1
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


def while_exit(cond: Cap, body: Cap) -> Cap:
    """Endings of a WHILE from its head: the condition fails (ok), or it ends ok and the body
    fails (fail); each round that ends ok comes back to the same head."""
    return frozenset(({OK} if FAIL in cond else set())
                     | ({FAIL} if OK in cond and FAIL in body else set()))


def results(out: Outcomes, body: ast.Block, reach: set[int], method: str
            ) -> list[Result]:
    """The properties ``can-end`` and ``no-zeno`` of the mission ``body``; ``reach``: the
    blocks that can start (:meth:`Outcomes.reachable`)."""
    found: list[Result] = []
    if NONE in out.states(body):
        found.append(Result("can-end", False, "error", cannot_end(out, body, reach),
                            method))
    else:
        found.append(Result("can-end", True, "error", "from every reachable marking the "
                            "mission can still end without an external stop", method))
    looping = zeno(out, body, reach, "must")
    if looping is not None:
        found.append(Result("no-zeno", False, "error", zeno_text(looping), method))
    elif (maybe := zeno(out, body, reach, "may")) is not None:
        found.append(undecided("no-zeno", f"{zeno_text(maybe)} if a timer whose value is a "
                               "mission parameter without a value is 0 s", method))
    else:
        found.append(Result("no-zeno", True, "error", "no cycle can go round without time "
                            "passing", method))
    found.append(instant_result(out, body, reach, method))
    return found


def instant_result(out: Outcomes, body: ast.Block, reach: set[int], method: str) -> Result:
    """``instant-loop`` (a warning): a reachable WHILE whose condition and body can both end
    ok with no mission time passing when the vehicle answers every event at once."""
    loop = zeno(out, body, reach, "instant")
    if loop is None:
        return Result("instant-loop", True, "warning", INSTANT_OK, method)
    forms = [out.checked.resolved(b).form for b in ast.walk(loop.condition)
             + ast.walk(loop.body) if isinstance(b, ast.Call) and id(b) in reach]
    events = list(dict.fromkeys(e for f in forms for e in f.ok + f.fail))
    return Result("instant-loop", False, "warning",
                  instant_text(f"the WHILE at line {loop.span.line}", events, among=True),
                  method)


def shown(block: ast.Block) -> str:
    """A block as written, on one line (shortened)."""
    text = " ".join(printer.block(block, 0).split())
    text = text[2:-2] if text.startswith("{ ") and text.endswith(" }") else text
    return text if len(text) <= 60 else text[:57] + "..."


def cannot_end(out: Outcomes, body: ast.Block, reach: set[int]) -> str:
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
                    f"`{shown(b.condition)}` can never fail")
            if OK in out.start(b.condition):
                text += " and its body never fails, so it goes round for ever"
            return text
    return "a block can reach a state from which it never ends"


def zeno(out: Outcomes, body: ast.Block, reach: set[int], zero: str) -> ast.WhileDo | None:
    for b in ast.walk(body):
        if isinstance(b, ast.WhileDo) and id(b) in reach and OK in out.start(
                b.condition, zero) and OK in out.start(b.body, zero):
            return b
    return None


def zeno_text(loop: ast.WhileDo) -> str:
    return (f"the WHILE at line {loop.span.line} can go round without time passing: its "
            f"condition `{shown(loop.condition)}` and its body `{shown(loop.body)}` can both "
            "end ok at once")
