"""The timers of a task call: one rule of the language, in one place.

A task library may declare a timeout for a task (``timeout: D -> ok`` or ``-> fail``, D a
duration or one of the task's ``duration`` parameters); a call of a task that waits may give
its own, ``timeout = D`` (D a duration or a mission parameter), which ends the call fail. The
rule (docs/LANGUAGE.md): **a per-call timeout replaces a declared fail timeout; a declared ok
timeout stays beside it**. Whichever timer falls due first ends the call.

The compiler (mcl/templates/task.py) makes one timed transition per timer, in the order
:func:`timers` gives; the duration bounds (mcl/analysis/duration.py, estimate.py) and the
structural route (mcl/analysis/outcomes.py) read the same timers.
"""

from __future__ import annotations

from dataclasses import dataclass

from mcl import ast
from mcl.checker import Checked, Resolved
from mcl.declarations import Expr, Field
from mcl.values import Unresolved, evaluate

OK, FAIL = "ok", "fail"


@dataclass(frozen=True)
class Timer:
    """One timer of a task call: when it falls due the call ends ``status`` ("ok" or
    "fail"). ``seconds``: its time in seconds, or the name of the mission parameter that
    gives it when that parameter has no value yet (the player fills it in at run time).
    ``declared``: the library's ``timeout:`` (False: the call's ``timeout =``)."""

    seconds: float | str
    status: str
    declared: bool

    @property
    def known(self) -> float | None:
        """Its seconds, or None when a mission parameter without a value gives them."""
        return None if isinstance(self.seconds, str) else self.seconds


def timers(checked: Checked, call: ast.Call) -> tuple[Timer, ...]:
    """The timers of a checked task call, per-call timeout first (none for a task that ends
    at once)."""
    resolved = checked.resolved(call)
    form = resolved.form
    out: list[Timer] = []
    if resolved.timeout is not None:  # a mission value: its names are mission parameters
        out.append(Timer(_seconds(resolved.timeout, checked.params), FAIL, False))
    if form.timeout is not None:
        expr, status = form.timeout
        if resolved.timeout is None or status == OK:  # the call's timeout replaces a fail one
            out.append(Timer(_seconds(_declared(expr, resolved), checked.params), status,
                             True))
    return tuple(out)


def _declared(expr: Expr, resolved: Resolved) -> ast.Value:
    """A declared timeout as this call gives it: a name is one of the task's parameters."""
    if isinstance(expr, Field):  # the library refuses these when it loads (mcl/tasklib.py)
        raise TypeError(f"a timeout is a duration, not a point's field: {expr}")
    if isinstance(expr, ast.Ref) and expr.name in resolved.args:
        return resolved.args[expr.name]
    return expr


def _seconds(value: ast.Value, params: dict[str, ast.Value]) -> float | str:
    try:
        seconds = evaluate(value, "duration", params)
    except Unresolved as missing:
        return missing.name
    assert isinstance(seconds, float | int)
    return float(seconds)
