"""How many markings the explicit route would enumerate for a mission: a rough estimate from
the syntax tree, by which ``--method auto`` (mcl/analysis/verification.py) chooses its route
before it explores anything. It needs no numpy and none of the structural route."""

from __future__ import annotations

from mcl import ast
from mcl.checker import Checked
from mcl.declarations import TaskForm


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
    latched = {b for c in checked.mission.calls()
               for b in [latch_of(checked.resolved(c).form)[0]] if b is not None}
    factor = 3.0 * 2.0 ** min(len(latched), 8)
    blocks = sum(estimate_markings(part) for part in checked.mission.parts())
    return min(blocks * factor, 1e300)


def latch_of(form: TaskForm) -> tuple[str | None, bool]:
    """The behaviour a task form latches (True) or unlatches (False), if any."""
    if form.latch:
        return form.latch, True
    return form.unlatch, False
