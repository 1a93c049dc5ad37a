"""Worst-case energy of a mission, with the power a task library declares per behaviour
(``behaviour NAME ... power N W;``, docs/DURATION.md), from the proved worst-case durations.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable
from dataclasses import dataclass

from mcl import ast
from mcl.checker import Checked

INF = math.inf
WH = 3600.0  # joules per watt-hour


@dataclass
class Energy:
    """Worst-case energy (joules) with the power declared per behaviour."""

    worst_j: float
    latched: dict[str, float]  # behaviour latched -> watts (counted for the whole mission)
    undeclared: list[str]  # behaviours switched on whose power no library declares

    @property
    def worst_wh(self) -> float:
        return self.worst_j / WH


def worst_energy(checked: Checked, root: ast.Block, worst_of: Callable[[ast.Block], float],
                 worst: float) -> Energy | None:
    """Worst-case energy in joules: each block's energy bounded by the sum of its parts and by
    its peak power times its worst duration; a latched behaviour draws for the whole mission.
    ``worst_of``: each block's worst-case duration (mcl/analysis/duration.py); ``worst``: the
    mission's. None when no loaded library declares any power."""
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
                e, peak = times(p, worst_of(b)), p
            case ast.Sequence() | ast.IfThenElse() | ast.WhileDo():
                peak = max(k[1] for k in kids)
                if isinstance(b, ast.IfThenElse):
                    e = kids[0][0] + max(k[0] for k in kids[1:])
                elif isinstance(b, ast.WhileDo) and math.isinf(worst_of(b)):
                    e = times(peak, INF)
                else:
                    e = sum(k[0] for k in kids)
            case ast.ParallelAnd():
                e, peak = sum(k[0] for k in kids), sum(k[1] for k in kids)
            case ast.ParallelOr():
                span = worst_of(b)
                e = sum(min(k[0], times(k[1], span)) for k in kids)
                peak = sum(k[1] for k in kids)
            case ast.TryCatchDo():
                race = min(worst_of(b.try_), worst_of(b.catch))
                e = (min(kids[0][0], times(kids[0][1], race))
                     + min(kids[1][0], times(kids[1][1], race)) + kids[2][0])
                peak = max(kids[0][1] + kids[1][1], kids[2][1])
            case _:
                raise TypeError(b)
        energy[id(b)] = (min(e, times(peak, worst_of(b))), peak)
    total = energy[id(root)][0] + sum(times(p, worst) for p in latched.values())
    return Energy(total, latched, sorted(undeclared))
