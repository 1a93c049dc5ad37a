"""How long can it take? Proved best- and worst-case durations (and energy) of a mission.

Every block gets, for each way it can end (ok, fail), an interval [lo, hi] of seconds from its
start that holds for every run of the net the compiler builds for it, whatever the vehicle does
and whenever its events come (docs/DURATION.md). Only what the net enforces enters a proof:

* a task call: its timers (the library's ``timeout:`` or the call's ``timeout =``; the first
  to fall due ends it) bound it above; nothing else can. A task that only a timer ends (``Wait``,
  ``Timeout``) takes exactly that time; one that waits for an event may end at once (0 s),
  unless a 0 s timer ends it first (it fires before any event can come); one
  that waits for an event with no timer (a watcher: ``Alarms()``) may wait forever (inf). A
  task that ends at once takes 0 s.
* ``A ; B``: the sum (each item starts when the one before ends, whatever its status).
* ``PARALLEL AND``: the last branch to end (a failing branch does not stop the others).
* ``PARALLEL OR``: the first branch to end wins; the others are aborted at once. So no run
  lasts beyond the smallest worst case of the branches (a ``Timeout`` bounds a watcher).
* ``TRY T CATCH C DO D``: T and C race; T first ends the block; C first aborts T, then D runs.
* ``IF C THEN A ELSE B``: C, then the branch its status picks (no ELSE: fail at once).
* ``WHILE C DO B``: if C can end ok and B can end ok, the loop can go round for ever: the
  worst case is unbounded, and the WHILE is named, unless an enclosing race bounds it.

Aborts are instantaneous (untimed transitions). ``Mission.abort`` from the operator and a lost
link only shorten a run; the best case is that of a run nobody stops.

The intervals of a block are the hull of its runs' durations: exact for one task, and sound
(never narrower than the truth) for every construct. The worst case comes with its *critical
path*: the task calls in order, each with how it ends and how long it takes, that make it.

Apart from the proof, a nominal *estimate* (mcl/analysis/estimate.py: each task its
``estimate:`` clause, ok; watchers never fire) and, with ``power N W`` declared per behaviour,
the worst-case energy (mcl/analysis/energy.py). A call's timers follow the one rule of
mcl/timers.py; the text report of ``mclc`` is app/reports/duration.py.
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass, field
from typing import Any

from mcl import ast, printer
from mcl.analysis.energy import Energy, worst_energy
from mcl.analysis.estimate import estimate
from mcl.checker import Checked
from mcl.quantities import seconds_text
from mcl.timers import timers

INF = math.inf


@dataclass(frozen=True)
class Step:
    """One task call (or construct) on a path: where it is, how it ends, how long it takes."""

    line: int
    col: int
    text: str
    ending: str
    seconds: float

    def to_json(self) -> dict[str, Any]:
        return {"line": self.line, "col": self.col, "task": self.text, "ending": self.ending,
                "seconds": json_number(self.seconds)}


Path = tuple[Step, ...]


@dataclass(frozen=True)
class End:
    """The runs of a block that end one way: their durations lie in [lo, hi]; ``best`` and
    ``worst`` are paths that take lo and hi."""

    lo: float
    hi: float
    best: Path = ()
    worst: Path = ()


Ends = dict[str, End]  # "ok" / "fail" -> End; a status the block cannot end with is absent


@dataclass(frozen=True)
class BlockBound:
    """The bounds of one block, by the way it ends: ``ends`` "ok" / "fail" -> (lo, hi)."""

    construct: str
    line: int
    col: int
    text: str
    ends: dict[str, tuple[float, float]]

    @property
    def best(self) -> float:
        return min((lo for lo, _ in self.ends.values()), default=INF)

    @property
    def worst(self) -> float:
        return max((hi for _, hi in self.ends.values()), default=INF)

    def to_json(self) -> dict[str, Any]:
        return {"construct": self.construct, "line": self.line, "col": self.col,
                "block": self.text, "best": json_number(self.best),
                "worst": json_number(self.worst),
                "ends": {k: [json_number(lo), json_number(hi)]
                         for k, (lo, hi) in self.ends.items()}}


@dataclass
class Durations:
    """The proved bounds of a mission (seconds; inf: unbounded), its paths, every block's
    bounds, what makes it unbounded, and apart from the proof the nominal estimate and the
    worst-case energy."""

    best: float
    worst: float
    ends: dict[str, tuple[float, float]]
    critical_path: Path
    best_path: Path
    blocks: list[BlockBound]
    unbounded: list[Step]  # what makes the worst case infinite: watchers, WHILEs, timers
    estimate: float | None  # nominal seconds; None: the nominal run never ends
    estimate_notes: list[str]
    energy: Energy | None = None
    unset_timers: list[Step] = field(default_factory=list)
    loops: list[Step] = field(default_factory=list)  # every WHILE that can go round for ever
    laps: dict[tuple[int, int], Path] = field(default_factory=dict)  # (line, col) of such a
    # WHILE -> one round of it that comes back to its head (the worst one): what keeps it going
    steps: int = 0  # the work done: blocks analysed plus the steps of every path they keep

    def to_json(self) -> dict[str, Any]:
        out: dict[str, Any] = {
            "best": json_number(self.best), "worst": json_number(self.worst),
            "bounded": math.isfinite(self.worst),
            "ends": {k: [json_number(lo), json_number(hi)]
                     for k, (lo, hi) in self.ends.items()},
            "critical_path": [s.to_json() for s in self.critical_path],
            "best_path": [s.to_json() for s in self.best_path],
            "unbounded_by": [s.to_json() for s in self.unbounded],
            "loops": [s.to_json() for s in self.loops],
            "estimate": {"seconds": (None if self.estimate is None
                                     else json_number(self.estimate)),
                         "label": "estimate (not proved)", "notes": self.estimate_notes},
            "blocks": [b.to_json() for b in self.blocks]}
        if self.energy is not None:
            out["energy"] = {"worst_wh": json_number(self.energy.worst_wh),
                             "latched_w": self.energy.latched,
                             "undeclared": self.energy.undeclared}
        return out


def json_number(x: float) -> float | None:
    """JSON has no infinity: an unbounded figure is null."""
    return round(x, 6) if math.isfinite(x) else None


# -- the analysis ------------------------------------------------------------------------------
def analyse(checked: Checked, mission: ast.Mission | None = None) -> Durations:
    """Bounds of every block of ``mission`` (default: the checked one) and of the mission;
    the checked mission's are computed once and kept (``Checked.memo``)."""
    if mission is None or mission is checked.mission:
        if "durations" not in checked.memo:
            checked.memo["durations"] = _analyse(checked, checked.mission)
        kept: Durations = checked.memo["durations"]
        return kept
    return _analyse(checked, mission)


def stop_handler(checked: Checked) -> Durations | None:
    """Bounds of the mission's stop handler (``ON STOP``), analysed as a mission of its own:
    it starts once everything else has stopped (None: the mission has none); computed once."""
    handler = checked.mission.on_stop
    if handler is None:
        return None
    if "stop_durations" not in checked.memo:
        checked.memo["stop_durations"] = _analyse(
            checked, ast.Mission(checked.mission.name, handler, span=checked.mission.stop_span))
    kept: Durations = checked.memo["stop_durations"]
    return kept


def _analyse(checked: Checked, mission: ast.Mission) -> Durations:
    a = _Analysis(checked)
    ends = a.block(mission.body)
    ends = ends or {"ok": End(INF, INF, (), ())}
    best = min(ends.values(), key=lambda e: e.lo)
    worst = max(ends.values(), key=lambda e: e.hi)
    unbounded = [s for s in worst.worst if not math.isfinite(s.seconds)]
    nominal, notes = estimate(checked, mission.body)
    out = Durations(best.lo, worst.hi, {k: (e.lo, e.hi) for k, e in ends.items()},
                    worst.worst, best.best, sorted(a.bounds, key=lambda b: (b.line, b.col)),
                    unbounded, nominal, notes, unset_timers=a.unset, loops=a.loops,
                    laps=a.laps, steps=a.steps)
    out.energy = worst_energy(checked, mission.body, a.worst_of, out.worst)
    return out


def _hull(ends: Iterable[End]) -> End | None:
    items = list(ends)
    if not items:
        return None
    lo = min(items, key=lambda e: e.lo)
    hi = max(items, key=lambda e: e.hi)
    return End(lo.lo, hi.hi, lo.best, hi.worst)


def _plus(a: End, b: End) -> End:
    return End(a.lo + b.lo, a.hi + b.hi, a.best + b.best, a.worst + b.worst)


def _merge(*groups: Iterable[tuple[str, End]]) -> Ends:
    by: dict[str, list[End]] = {}
    for group in groups:
        for status, end in group:
            by.setdefault(status, []).append(end)
    out: Ends = {}
    for status in ("ok", "fail"):
        h = _hull(by.get(status, []))
        if h is not None:
            out[status] = h
    return out


class _Analysis:
    def __init__(self, checked: Checked):
        self.checked = checked
        self.bounds: list[BlockBound] = []
        self.memo: dict[int, Ends] = {}
        self.unset: list[Step] = []
        self.loops: list[Step] = []
        self.laps: dict[tuple[int, int], Path] = {}
        self.steps = 0  # blocks analysed plus the steps of the paths they keep

    def block(self, root: ast.Block) -> Ends:
        # children before parents, without recursion (deep missions are fine)
        for b in reversed(ast.walk(root)):
            if id(b) not in self.memo:
                ends = self._one(b)
                self.memo[id(b)] = ends
                self.steps += 1 + sum(len(e.best) + len(e.worst) for e in ends.values())
                self.bounds.append(BlockBound(type(b).__name__, b.span.line, b.span.col,
                                              _head(b), {k: (e.lo, e.hi)
                                                         for k, e in ends.items()}))
        return self.memo[id(root)]

    def _one(self, b: ast.Block) -> Ends:
        m = self.memo
        match b:
            case ast.Call():
                return self.call(b)
            case ast.Sequence(items=items):
                acc = End(0.0, 0.0)
                for item in items[:-1]:
                    h = _hull(m[id(item)].values())
                    if h is None:  # an item that never ends
                        return {}
                    acc = _plus(acc, h)
                return {k: _plus(acc, e) for k, e in m[id(items[-1])].items()}
            case ast.ParallelAnd(branches=branches):
                return self.parallel_and([m[id(x)] for x in branches])
            case ast.ParallelOr(branches=branches):
                return self.parallel_or([m[id(x)] for x in branches])
            case ast.TryCatchDo(try_=t, catch=c, do=d):
                return self.try_catch(m[id(t)], m[id(c)], m[id(d)], c)
            case ast.IfThenElse(condition=c, then=t, else_=e):
                cond, then = m[id(c)], m[id(t)]
                groups = [[(k, _plus(cond["ok"], x)) for k, x in then.items()]] \
                    if "ok" in cond else []
                if "fail" in cond:
                    if e is None:
                        groups.append([("fail", cond["fail"])])
                    else:
                        groups.append([(k, _plus(cond["fail"], x))
                                       for k, x in m[id(e)].items()])
                return _merge(*groups)
            case ast.WhileDo(condition=c, body=body):
                return self.while_do(b, m[id(c)], m[id(body)])
        raise TypeError(b)

    def worst_of(self, block: ast.Block) -> float:
        """The worst case of a block already analysed, whichever way it ends."""
        return max((e.hi for e in self.memo[id(block)].values()), default=INF)

    # -- a task call -------------------------------------------------------------------------
    def call(self, call: ast.Call) -> Ends:
        form = self.checked.resolved(call).form
        text = printer.call(call)
        line, col = call.span.line, call.span.col

        def step(ending: str, seconds: float) -> Path:
            return (Step(line, col, text, ending, seconds),)

        if form.immediate:
            p = step("ends ok at once", 0.0)
            return {"ok": End(0.0, 0.0, p, p)}
        known: list[tuple[float, str]] = []
        unknown: list[str] = []  # timers naming a parameter without a value: any time
        for timer in timers(self.checked, call):  # the rule: mcl/timers.py
            if timer.known is None:
                self.unset.append(step(f"has a timer without a value ({timer.status})",
                                       INF)[0])
                unknown.append(timer.status)
                continue
            known.append((timer.known, timer.status))
        first = min((s for s, _ in known), default=INF)
        groups: list[tuple[str, End]] = []
        for status, events in (("ok", form.ok), ("fail", form.fail)):
            if events and first > 0:  # a 0 s timer fires before any event can come
                worst = (step(f"ends {status} on {events[0]} just before its timeout", first)
                         if math.isfinite(first) else
                         step(f"waits for {' / '.join(events)} for ever (no timeout)", INF))
                groups.append((status, End(0.0, first, step(
                    f"ends {status} at once on {events[0]}", 0.0), worst)))
        for seconds, status in known:
            if seconds <= first:
                p = step(f"ends {status} by its {seconds_text(seconds)} timeout", seconds)
                groups.append((status, End(seconds, seconds, p, p)))
        for status in unknown:
            groups.append((status, End(0.0, first, step(f"ends {status} by its timer", 0.0),
                                       step(f"ends {status} by a timer without a value",
                                            first))))
        return _merge(groups)

    # -- constructs ---------------------------------------------------------------------------
    def parallel_and(self, branches: list[Ends]) -> Ends:
        if any(not b for b in branches):
            return {}
        alls = [_hull(b.values()) for b in branches]
        groups: list[tuple[str, End]] = []
        if all("ok" in b for b in branches):
            oks = [b["ok"] for b in branches]
            lo = max(oks, key=lambda e: e.lo)
            hi = max(oks, key=lambda e: e.hi)
            groups.append(("ok", End(lo.lo, hi.hi, lo.best, hi.worst)))
        for j, b in enumerate(branches):
            if "fail" not in b:
                continue
            others = [x for i, x in enumerate(alls) if i != j and x is not None]
            lo = max([End(b["fail"].lo, 0, b["fail"].best)] +
                     [End(x.lo, 0, x.best) for x in others], key=lambda e: e.lo)
            hi = max([End(0, b["fail"].hi, (), b["fail"].worst)] +
                     [End(0, x.hi, (), x.worst) for x in others], key=lambda e: e.hi)
            groups.append(("fail", End(lo.lo, hi.hi, lo.best, hi.worst)))
        return _merge(groups)

    def parallel_or(self, branches: list[Ends]) -> Ends:
        alls = [_hull(b.values()) for b in branches]
        groups: list[tuple[str, End]] = []
        for j, b in enumerate(branches):
            others = [x for i, x in enumerate(alls) if i != j and x is not None]
            cap = min(others, key=lambda e: e.hi) if others else None
            for status, e in b.items():
                groups.append((status, _race(e, cap)))
        out = _merge([g for g in groups if g[1].lo <= g[1].hi])
        return out

    def try_catch(self, t: Ends, c: Ends, d: Ends, catch: ast.Block) -> Ends:
        t_all, c_all = _hull(t.values()), _hull(c.values())
        groups: list[tuple[str, End]] = []
        for status, e in t.items():
            groups.append((status, _race(e, c_all)))
        if c_all is not None:
            won = _race(c_all, t_all)
            mark = (Step(catch.span.line, catch.span.col, "CATCH " + _head(catch),
                         "ends first: TRY aborted, DO runs", 0.0),)
            if won.lo <= won.hi:
                won = End(won.lo, won.hi, won.best + mark, won.worst + mark)
                groups += [(k, _plus(won, x)) for k, x in d.items()]
        return _merge([g for g in groups if g[1].lo <= g[1].hi])

    def while_do(self, w: ast.WhileDo, c: Ends, b: Ends) -> Ends:
        groups: list[tuple[str, End]] = []
        again = "ok" in c and "ok" in b
        if again:
            lap = _plus(c["ok"], b["ok"])
            loop = (Step(w.span.line, w.span.col, "WHILE " + _head(w.condition),
                         "can go round for ever (nothing bounds the loop)", INF),)
            self.loops.append(loop[0])
            self.laps[(w.span.line, w.span.col)] = lap.worst
            if "fail" in c:
                groups.append(("ok", End(c["fail"].lo, INF, c["fail"].best,
                                         lap.worst + loop)))
            if "fail" in b:
                f = _plus(c["ok"], b["fail"])
                groups.append(("fail", End(f.lo, INF, f.best, lap.worst + loop)))
            if not groups:  # it never ends
                return {}
        else:
            if "fail" in c:
                groups.append(("ok", c["fail"]))
            if "ok" in c and "fail" in b:
                groups.append(("fail", _plus(c["ok"], b["fail"])))
        return _merge(groups)


def _race(e: End, cap: End | None) -> End:
    """The runs that end as ``e`` while a rival that ends within [cap.lo, cap.hi] has not yet
    ended: at most cap.hi (lo > hi: impossible)."""
    if cap is None or e.hi <= cap.hi:
        return e
    return End(e.lo, cap.hi, e.best, cap.worst)


def _head(b: ast.Block) -> str:
    match b:
        case ast.Call():
            return printer.call(b)
        case ast.Sequence(items=items):
            return f"sequence of {len(items)}"
        case ast.ParallelAnd():
            return "PARALLEL ... AND"
        case ast.ParallelOr():
            return "PARALLEL ... OR"
        case ast.TryCatchDo():
            return "TRY ... CATCH ... DO"
        case ast.IfThenElse():
            return "IF ... THEN"
        case ast.WhileDo():
            return "WHILE ... DO"
    return type(b).__name__
