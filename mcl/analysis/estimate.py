"""A nominal estimate of how long a mission takes: not a proof (docs/DURATION.md).

One run where every task takes its ``estimate:`` (a duration, or a distance or a path's length
at a speed) and ends ok, timers fire on time and watchers never fire. Reported apart from the
proved bounds (mcl/analysis/duration.py), and labelled as an estimate everywhere.
"""

from __future__ import annotations

import math

from mcl import ast
from mcl.checker import Checked, Resolved
from mcl.declarations import Field
from mcl.timers import timers
from mcl.values import Unresolved, evaluate


def estimate(checked: Checked, body: ast.Block) -> tuple[float | None, list[str]]:
    """The nominal seconds of ``body`` (None: the nominal run never ends) and notes on what
    was assumed."""
    return Nominal(checked).mission(body)


Point = tuple[float, ...] | None  # where the vehicle was last sent (None: nowhere yet)
Outcome = tuple[str, float] | None  # how a block ends and after how long (None: never)


class Nominal:
    """One run where every task takes its ``estimate:`` and ends ok, timers fire on time and
    watchers never fire. Not a proof: labelled as an estimate everywhere.

    The run is deterministic, and the only thing a block's nominal run depends on besides the
    block is the point the vehicle was last sent to (a distance is measured from it). So each
    block is walked at most once per such point (a memo), and a WHILE whose lap starts again
    from a point it started from before goes round for ever: it is never walked lap by lap
    beyond the number of distinct points, and the cost is polynomial in the mission's size
    (``steps`` counts the blocks entered), however deeply its loops nest.
    """

    def __init__(self, checked: Checked):
        self.checked = checked
        self.notes: list[str] = []
        self.position: list[float] | None = None  # the last point a task was sent to
        self.memo: dict[tuple[int, Point], tuple[Outcome, list[float] | None]] = {}
        self.steps = 0  # blocks entered, memo hits included: the work done

    def mission(self, body: ast.Block) -> tuple[float | None, list[str]]:
        end = self.block(body)
        return (None if end is None else end[1]), list(dict.fromkeys(self.notes))

    def block(self, b: ast.Block) -> Outcome:
        """The nominal end of ``b`` started from the current point (memoised per point)."""
        self.steps += 1
        key = (id(b), None if self.position is None else tuple(self.position))
        if key not in self.memo:
            outcome = self.walk(b)
            self.memo[key] = outcome, self.position
        outcome, position = self.memo[key]
        self.position = position
        return outcome

    def walk(self, b: ast.Block) -> Outcome:
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
            case ast.WhileDo():
                return self.while_do(b)
        raise TypeError(b)

    def while_do(self, w: ast.WhileDo) -> Outcome:
        """Lap after lap until the condition fails or the body fails; a lap that starts from
        a point an earlier lap started from repeats that lap for ever (the run is
        deterministic), so there are at most as many laps as distinct points, plus one."""
        total = 0.0
        starts: set[Point] = set()
        while (start := None if self.position is None else tuple(self.position)) \
                not in starts:
            starts.add(start)
            rc = self.block(w.condition)
            if rc is None:
                return None
            total += rc[1]
            if rc[0] == "fail":
                return "ok", total
            rb = self.block(w.body)
            if rb is None:
                return None
            total += rb[1]
            if rb[0] == "fail":
                return "fail", total
        self.notes.append(f"line {w.span.line}: WHILE goes round for ever nominally")
        return None

    def call(self, call: ast.Call) -> Outcome:
        resolved = self.checked.resolved(call)
        form = resolved.form
        if form.immediate:
            return "ok", 0.0
        known = [(t.known, t.status) for t in timers(self.checked, call) if t.known is not None]
        first = min(known, default=None)
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
