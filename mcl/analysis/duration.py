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

Apart from the proof, a nominal *estimate* (each task its ``estimate:`` clause, ok; watchers
never fire) and, with ``power N W`` declared per behaviour, the worst-case energy.
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass, field
from typing import Any

from mcl import ast, printer
from mcl.checker import Checked, Resolved
from mcl.tasklib import Expr, Field, TaskForm
from mcl.values import Unresolved, evaluate

INF = math.inf
WH = 3600.0  # joules per watt-hour


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
                "seconds": _num(self.seconds)}

    def describe(self) -> str:
        return f"line {self.line}: {self.text} {self.ending} ({seconds_text(self.seconds)})"


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
                "block": self.text, "best": _num(self.best), "worst": _num(self.worst),
                "ends": {k: [_num(lo), _num(hi)] for k, (lo, hi) in self.ends.items()}}


@dataclass
class Energy:
    """Worst-case energy (joules) with the power declared per behaviour."""

    worst_j: float
    latched: dict[str, float]  # behaviour latched -> watts (counted for the whole mission)
    undeclared: list[str]  # behaviours switched on whose power no library declares

    @property
    def worst_wh(self) -> float:
        return self.worst_j / WH


@dataclass
class Durations:
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

    def to_json(self) -> dict[str, Any]:
        out: dict[str, Any] = {
            "best": _num(self.best), "worst": _num(self.worst),
            "bounded": math.isfinite(self.worst),
            "ends": {k: [_num(lo), _num(hi)] for k, (lo, hi) in self.ends.items()},
            "critical_path": [s.to_json() for s in self.critical_path],
            "best_path": [s.to_json() for s in self.best_path],
            "unbounded_by": [s.to_json() for s in self.unbounded],
            "loops": [s.to_json() for s in self.loops],
            "estimate": {"seconds": None if self.estimate is None else _num(self.estimate),
                         "label": "estimate (not proved)", "notes": self.estimate_notes},
            "blocks": [b.to_json() for b in self.blocks]}
        if self.energy is not None:
            out["energy"] = {"worst_wh": _num(self.energy.worst_wh),
                             "latched_w": self.energy.latched,
                             "undeclared": self.energy.undeclared}
        return out

    def path_text(self, indent: str = "  ") -> list[str]:
        """The critical path, up to its first unbounded step (what follows never comes)."""
        out = []
        for s in self.critical_path:
            out.append(indent + s.describe())
            if not math.isfinite(s.seconds):
                break
        return out


def _num(x: float) -> float | None:
    """JSON has no infinity: an unbounded figure is null."""
    return round(x, 6) if math.isfinite(x) else None


def seconds_text(s: float) -> str:
    if not math.isfinite(s):
        return "unbounded"
    if s < 120:
        return f"{s:g} s"
    return f"{s:g} s = {s / 60:.4g} min"


# -- parsing command-line quantities ---------------------------------------------------------
_DURATION_UNITS = {"s": 1.0, "sec": 1.0, "ms": 0.001, "min": 60.0, "h": 3600.0}


def parse_quantity(text: str, units: dict[str, float], what: str, example: str) -> float:
    """``45min``, ``1.5 h``, ``120Wh``... into base units; ValueError with one clear line."""
    raw = text.strip()
    number = raw.rstrip("abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ% ")
    unit = raw[len(number):].strip()
    if unit not in units:
        raise ValueError(f"{what} {text!r}: give a unit ({', '.join(units)}), e.g. {example}")
    try:
        value = float(number)
    except ValueError:
        raise ValueError(f"{what} {text!r}: not a number, e.g. {example}") from None
    if not math.isfinite(value) or value < 0:
        raise ValueError(f"{what} {text!r}: must be finite and not negative, e.g. {example}")
    return value * units[unit]


def parse_deadline(text: str) -> float:
    return parse_quantity(text, _DURATION_UNITS, "--deadline", "--deadline 45min")


def parse_battery(text: str) -> float:
    """Watt-hours."""
    value = parse_quantity(text, {"Wh": 1.0, "kWh": 1000.0}, "--battery", "--battery 800Wh")
    if value == 0:
        raise ValueError(f"--battery {text!r}: must be above 0 Wh, e.g. --battery 800Wh")
    return value


def parse_reserve(text: str) -> float:
    """A fraction in [0, 1)."""
    value = parse_quantity(text, {"%": 0.01}, "--reserve", "--reserve 20%")
    if value >= 1:
        raise ValueError(f"--reserve {text!r}: must be below 100%, e.g. --reserve 20%")
    return value


# -- the analysis ------------------------------------------------------------------------------
def analyse(checked: Checked, mission: ast.Mission | None = None) -> Durations:
    """Bounds of every block of ``mission`` (default: the checked one) and of the mission."""
    mission = mission or checked.mission
    a = _Analysis(checked)
    ends = a.block(mission.body)
    ends = ends or {"ok": End(INF, INF, (), ())}
    best = min(ends.values(), key=lambda e: e.lo)
    worst = max(ends.values(), key=lambda e: e.hi)
    unbounded = [s for s in worst.worst if not math.isfinite(s.seconds)]
    estimate, notes = _Nominal(checked).mission(mission.body)
    out = Durations(best.lo, worst.hi, {k: (e.lo, e.hi) for k, e in ends.items()},
                    worst.worst, best.best, sorted(a.bounds, key=lambda b: (b.line, b.col)),
                    unbounded, estimate, notes, unset_timers=a.unset, loops=a.loops)
    out.energy = _energy(checked, mission.body, a, out.worst)
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

    def block(self, root: ast.Block) -> Ends:
        # children before parents, without recursion (deep missions are fine)
        for b in reversed(ast.walk(root)):
            if id(b) not in self.memo:
                ends = self._one(b)
                self.memo[id(b)] = ends
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

    # -- a task call -------------------------------------------------------------------------
    def call(self, call: ast.Call) -> Ends:
        resolved = self.checked.resolved(call)
        form = resolved.form
        text = printer.call(call)
        line, col = call.span.line, call.span.col

        def step(ending: str, seconds: float) -> Path:
            return (Step(line, col, text, ending, seconds),)

        if form.immediate:
            p = step("ends ok at once", 0.0)
            return {"ok": End(0.0, 0.0, p, p)}
        timers: list[tuple[float, str]] = []
        unknown: list[str] = []  # timers naming a parameter without a value: any time
        for expr, status in timeouts(form, resolved):
            seconds = self.timer(expr, resolved)
            if seconds is None:
                self.unset.append(step(f"has a timer without a value ({status})", INF)[0])
                unknown.append(status)
                continue
            timers.append((seconds, status))
        first = min((s for s, _ in timers), default=INF)
        groups: list[tuple[str, End]] = []
        for status, events in (("ok", form.ok), ("fail", form.fail)):
            if events and first > 0:  # a 0 s timer fires before any event can come
                worst = (step(f"ends {status} on {events[0]} just before its timeout", first)
                         if math.isfinite(first) else
                         step(f"waits for {' / '.join(events)} for ever (no timeout)", INF))
                groups.append((status, End(0.0, first, step(
                    f"ends {status} at once on {events[0]}", 0.0), worst)))
        for seconds, status in timers:
            if seconds <= first:
                p = step(f"ends {status} by its {seconds_text(seconds)} timeout", seconds)
                groups.append((status, End(seconds, seconds, p, p)))
        for status in unknown:
            groups.append((status, End(0.0, first, step(f"ends {status} by its timer", 0.0),
                                       step(f"ends {status} by a timer without a value",
                                            first))))
        return _merge(groups)

    def timer(self, expr: Expr, resolved: Resolved) -> float | None:
        if isinstance(expr, Field):
            return None
        value: ast.Value = expr
        if isinstance(expr, ast.Ref) and expr.name in resolved.args:
            value = resolved.args[expr.name]
        try:
            seconds = evaluate(value, "duration", self.checked.params)
        except Unresolved:
            return None
        assert isinstance(seconds, float | int)
        return float(seconds)

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


def timeouts(form: TaskForm, resolved: Resolved) -> list[tuple[Expr, str]]:
    """The timers of a call, as mcl/templates/task.py builds them: a per-call timeout (fail)
    replaces a declared fail timeout; a declared ok timeout stays."""
    out: list[tuple[Expr, str]] = []
    if resolved.timeout is not None:
        out.append((resolved.timeout, "fail"))
        if form.timeout is not None and form.timeout[1] == "ok":
            out.append(form.timeout)
    elif form.timeout is not None:
        out.append(form.timeout)
    return out


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


# -- energy -----------------------------------------------------------------------------------
def _energy(checked: Checked, root: ast.Block, a: _Analysis, worst: float) -> Energy | None:
    """Worst-case energy in joules: each block's energy bounded by the sum of its parts and by
    its peak power times its worst duration; a latched behaviour draws for the whole mission.
    None when no loaded library declares any power."""
    behaviours = checked.library.behaviours
    if all(b.power is None for b in behaviours.values()):
        return None
    undeclared: set[str] = set()
    latched: dict[str, float] = {}

    def watts(names: Iterable[str]) -> float:
        total = 0.0
        for n in names:
            p = behaviours[n].power if n in behaviours else None
            if p is None:
                undeclared.add(n)
            total += p or 0.0
        return total

    energy: dict[int, tuple[float, float]] = {}  # block -> (joules, peak watts)

    def hi(x: ast.Block) -> float:
        ends = a.memo[id(x)]
        return max((e.hi for e in ends.values()), default=INF)

    def times(p: float, s: float) -> float:
        return 0.0 if p == 0 else p * s

    for b in reversed(ast.walk(root)):
        kids = [energy[id(k)] for k in ast.children(b)]
        match b:
            case ast.Call():
                form = checked.resolved(b).form
                if form.latch:
                    latched[form.latch] = watts([form.latch])
                p = watts(form.behaviours_on_while_running())
                e, peak = times(p, hi(b)), p
            case ast.Sequence() | ast.IfThenElse() | ast.WhileDo():
                peak = max(k[1] for k in kids)
                if isinstance(b, ast.IfThenElse):
                    e = kids[0][0] + max(k[0] for k in kids[1:])
                elif isinstance(b, ast.WhileDo) and math.isinf(hi(b)):
                    e = times(peak, INF)
                else:
                    e = sum(k[0] for k in kids)
            case ast.ParallelAnd():
                e, peak = sum(k[0] for k in kids), sum(k[1] for k in kids)
            case ast.ParallelOr():
                span = hi(b)
                e = sum(min(k[0], times(k[1], span)) for k in kids)
                peak = sum(k[1] for k in kids)
            case ast.TryCatchDo():
                race = min(hi(b.try_), hi(b.catch))
                e = (min(kids[0][0], times(kids[0][1], race))
                     + min(kids[1][0], times(kids[1][1], race)) + kids[2][0])
                peak = max(kids[0][1] + kids[1][1], kids[2][1])
            case _:
                raise TypeError(b)
        energy[id(b)] = (min(e, times(peak, hi(b))), peak)
    total = energy[id(root)][0] + sum(times(p, worst) for p in latched.values())
    return Energy(total, latched, sorted(undeclared))


# -- the nominal estimate ---------------------------------------------------------------------
class _Nominal:
    """One run where every task takes its ``estimate:`` and ends ok, timers fire on time and
    watchers never fire. Not a proof: labelled as an estimate everywhere."""

    MAX_LAPS = 10_000

    def __init__(self, checked: Checked):
        self.checked = checked
        self.notes: list[str] = []
        self.position: list[float] | None = None  # the last point a task was sent to

    def mission(self, body: ast.Block) -> tuple[float | None, list[str]]:
        end = self.block(body)
        return (None if end is None else end[1]), self.notes

    def block(self, b: ast.Block) -> tuple[str, float] | None:
        match b:
            case ast.Call():
                return self.call(b)
            case ast.Sequence(items=items):
                total, status = 0.0, "ok"
                for item in items:
                    r = self.block(item)
                    if r is None:
                        return None
                    status, total = r[0], total + r[1]
                return status, total
            case ast.ParallelAnd(branches=branches):
                rs = [self.block(x) for x in branches]
                if any(r is None for r in rs):
                    return None
                ends = [r for r in rs if r is not None]
                return ("ok" if all(s == "ok" for s, _ in ends) else "fail",
                        max(t for _, t in ends))
            case ast.ParallelOr(branches=branches):
                done = [r for r in (self.block(x) for x in branches) if r is not None]
                return min(done, key=lambda r: r[1]) if done else None
            case ast.TryCatchDo(try_=t, catch=c, do=d):
                rt, rc = self.block(t), self.block(c)
                if rc is not None and (rt is None or rc[1] < rt[1]):
                    rd = self.block(d)
                    return None if rd is None else (rd[0], rc[1] + rd[1])
                return rt
            case ast.IfThenElse(condition=c, then=t, else_=e):
                rc = self.block(c)
                if rc is None:
                    return None
                if rc[0] == "fail" and e is None:
                    return rc
                r = self.block(t if rc[0] == "ok" else e)  # type: ignore[arg-type]
                return None if r is None else (r[0], rc[1] + r[1])
            case ast.WhileDo(condition=c, body=body):
                total = 0.0
                for _ in range(self.MAX_LAPS):
                    rc = self.block(c)
                    if rc is None:
                        return None
                    total += rc[1]
                    if rc[0] == "fail":
                        return "ok", total
                    rb = self.block(body)
                    if rb is None:
                        return None
                    total += rb[1]
                    if rb[0] == "fail":
                        return "fail", total
                self.notes.append(f"line {b.span.line}: WHILE goes round for ever nominally")
                return None
        raise TypeError(b)

    def call(self, call: ast.Call) -> tuple[str, float] | None:
        resolved = self.checked.resolved(call)
        form = resolved.form
        if form.immediate:
            return "ok", 0.0
        timers = []
        for expr, status in timeouts(form, resolved):
            seconds = _Analysis(self.checked).timer(expr, resolved)
            if seconds is not None:
                timers.append((seconds, status))
        first = min(timers, default=None)
        guess = self.guess(call, resolved)
        if guess is not None and form.ok:
            if first is not None and first[0] <= guess:
                return first[1], first[0]
            return "ok", guess
        if first is not None and not form.ok:
            return first[1], first[0]  # a timer, or a watcher that its timer ends
        if form.ok:
            self.notes.append(f"line {call.span.line}: {call.name} has no estimate: "
                              "counted as 0 s")
            return "ok", 0.0
        return None  # a watcher: its alarm never comes in the nominal run

    def guess(self, call: ast.Call, resolved: Resolved) -> float | None:
        est = resolved.form.estimate
        if est is None:
            return None
        env = self.checked.params
        try:
            if est.measure == "time":
                assert est.value is not None and not isinstance(est.value, Field)
                value: ast.Value = est.value
                if isinstance(value, ast.Ref) and value.name in resolved.args:
                    value = resolved.args[value.name]
                return float(evaluate(value, "duration", env))  # type: ignore[arg-type]
            arg = resolved.args[est.formal]
            if est.measure == "distance":
                target = evaluate(arg, "point", env)
                assert isinstance(target, list)
                here = self.position or [0.0, 0.0, 0.0]
                if self.position is None:
                    self.notes.append(f"line {call.span.line}: {call.name}: distance "
                                      "from (0, 0, 0), the first point of the mission")
                self.position = [float(v) for v in target[:3]]
                return math.dist(here, self.position) / est.speed
            points = evaluate(arg, "path", env)
            assert isinstance(points, list)
            return sum(math.dist(a[:n], b[:n]) for a, b in zip(points, points[1:])
                       for n in [min(len(a), len(b))]) / est.speed
        except Unresolved as missing:
            self.notes.append(f"line {call.span.line}: {call.name}: parameter "
                              f"{missing.name} has no value: counted as 0 s")
            return 0.0


# -- a report for mclc --------------------------------------------------------------------------
@dataclass
class Verdict:
    """What ``--deadline``, ``--battery`` and ``--reserve`` conclude."""

    failures: list[str]
    lines: list[str]
    report: dict[str, Any]


def judge(d: Durations, deadline: float | None = None, battery_wh: float | None = None,
          reserve: float | None = None) -> Verdict:
    """The text and JSON of the bounds, and the checks asked for (each failure one line)."""
    report = d.to_json()
    lines = [f"  duration: best {seconds_text(d.best)}, worst {seconds_text(d.worst)} "
             "(proved: timeouts and timers only)"]
    if d.estimate is not None:
        lines.append(f"  estimate (not proved): {seconds_text(d.estimate)}")
    failures: list[str] = []
    if deadline is not None:
        report["deadline"] = {"seconds": deadline, "holds": d.worst <= deadline}
        if d.worst > deadline:
            failures.append(f"deadline {seconds_text(deadline)}: some run can take "
                            f"{seconds_text(d.worst)}" if math.isfinite(d.worst) else
                            f"deadline {seconds_text(deadline)}: some run can last for ever"
                            + "".join(f" ({s.describe()})" for s in d.unbounded[:1]))
        else:
            lines.append(f"  deadline {seconds_text(deadline)} holds for every run")
    if d.energy is not None:
        lines.append(f"  energy: worst {_wh(d.energy.worst_wh)}")
    if battery_wh is not None:
        worst = d.energy.worst_wh if d.energy is not None else INF
        usable = battery_wh * (1 - (reserve or 0.0))
        margin = battery_wh - worst
        report["battery"] = {"wh": battery_wh, "worst_wh": _num(worst), "margin_wh": _num(margin),
                             "reserve": reserve, "usable_wh": usable, "holds": worst <= usable}
        if d.energy is None:
            failures.append("--battery: no task library declares the power of any behaviour "
                            "('behaviour NAME ... power N W;')")
        elif worst > usable:
            what = (f"the {reserve:.0%} reserve ({battery_wh - usable:g} Wh)" if reserve
                    else "the battery")
            failures.append(f"battery {battery_wh:g} Wh: the worst case {_wh(worst)} eats "
                            f"into {what}")
        else:
            lines.append(f"  battery {battery_wh:g} Wh: margin {_wh(margin)}"
                         + (f", reserve {reserve:.0%} kept" if reserve else ""))
    if not math.isfinite(d.worst):
        lines.append("  unbounded by:")
        lines += [f"    line {s.line}: {s.text} {s.ending}" for s in d.unbounded[:1]]
        if d.loops:
            lines.append("  loops that can go round for ever (unless a race bounds them):")
            lines += [f"    line {s.line}: {s.text}" for s in d.loops]
    if failures:
        lines += ["  critical path (worst case):"] + d.path_text("    ")
    report["failures"] = failures
    return Verdict(failures, lines, report)


def _wh(x: float) -> str:
    return f"{x:.4g} Wh" if math.isfinite(x) else "unbounded"


@dataclass(frozen=True)
class Limits:
    """``mclc --deadline/--battery/--reserve``, parsed (None: not asked)."""

    deadline: float | None = None
    battery_wh: float | None = None
    reserve: float | None = None

    @property
    def asked(self) -> bool:
        return any(x is not None for x in (self.deadline, self.battery_wh, self.reserve))


def parse_limits(deadline: str | None, battery: str | None, reserve: str | None) -> Limits:
    """The three options; ValueError with one clear line for a bad value."""
    if reserve is not None and battery is None:
        raise ValueError(f"--reserve {reserve!r} needs --battery WH (the reserve is a share "
                         "of it), e.g. --battery 800Wh --reserve 20%")
    return Limits(None if deadline is None else parse_deadline(deadline),
                  None if battery is None else parse_battery(battery),
                  None if reserve is None else parse_reserve(reserve))


def check(checked: Checked, limits: Limits) -> Verdict:
    """What mclc calls: the bounds of the checked mission against the limits asked."""
    return judge(analyse(checked), limits.deadline, limits.battery_wh, limits.reserve)
