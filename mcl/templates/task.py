"""Template of a task call.

A task that waits::

    begin ──start──► run ──ok event──► ok          (each ending sends the stop actions)
                      ├──fail event──► fail
                      ├──timeout─────► ok | fail
    abort ─────────── └──abort───────► aborted

A task that ends at once sends its start actions and puts its token in ``ok``. If it latches
a behaviour (``latch:``) it also moves that behaviour's state machine to "on from here";
``unlatch:`` moves it to "off". Such a task never holds a token while it could be aborted, so
an abort that reaches it is a late one and its parent absorbs it.
"""

from __future__ import annotations

from petri.net import POINT_FIELDS, RUN, Action

from mcl import ast, printer
from mcl.checker import Resolved
from mcl.declarations import ActionSpec, Expr, Field
from mcl.timers import timers
from mcl.values import Unresolved, evaluate
from mcl.templates.common import Context, Interface


def build(ctx: Context, call: ast.Call) -> Interface:
    resolved = ctx.checked.resolved(call)
    form = resolved.form
    name = ctx.prefix(call.name, call.span)
    origin = ctx.origin(call.span, printer.call(call), "task")
    io = ctx.interface(name, origin)
    points: dict[str, object] = {}  # each point argument evaluated once, not once per field
    start = tuple(_action(ctx, a, resolved, points) for a in form.start)
    stop = tuple(_action(ctx, a, resolved, points) for a in form.stop)

    if form.immediate:
        if form.latch or form.unlatch:
            latch = ctx.latches[form.latch or form.unlatch or ""]
            target = latch.sites[id(call)] if form.latch else latch.off
            for state in ctx.states_at_call(latch, call):
                ctx.transition(f"{name}.from.{ctx.net.places[state].name}",
                               [io.begin, state], [io.ok, target], "start and end",
                               origin, actions=start)
        else:
            ctx.transition(f"{name}.do", [io.begin], [io.ok], "start and end", origin,
                           actions=start)
        return io

    run = ctx.place(f"{name}.run", form.behaviours_on_while_running(), origin, RUN)
    ctx.transition(f"{name}.start", [io.begin], [run], "start", origin, actions=start)
    for event in form.ok:
        ctx.transition(f"{name}.ok.{event}", [run], [io.ok], f"{event} → ok", origin,
                       actions=stop, event=event)
    for event in form.fail:
        ctx.transition(f"{name}.fail.{event}", [run], [io.fail], f"{event} → fail", origin,
                       actions=stop, event=event)
    for i, timer in enumerate(timers(ctx.checked, call)):  # the rule: mcl/timers.py
        seconds = timer.seconds
        shown = f"{seconds:g} s" if isinstance(seconds, float) else seconds
        ctx.transition(f"{name}.timeout{i or ''}", [run],
                       [io.ok if timer.status == "ok" else io.fail],
                       f"timeout {shown} → {timer.status}", origin, actions=stop, timer=seconds)
    ctx.transition(f"{name}.abort", [run, io.abort], [io.aborted], "aborted", origin,
                   actions=stop)
    return io


def _value(ctx: Context, expr: Expr, resolved: Resolved, kind: str,
           points: dict[str, object] | None = None) -> object:
    """An action parameter: a number or list, or {"param": name} when the mission
    parameter it comes from has no value yet (the player fills it in at run time).
    ``points``: the call's point arguments already evaluated (or the missing parameter's
    name, as an Unresolved), by formal."""
    env = ctx.checked.params
    if isinstance(expr, Field):
        points = {} if points is None else points
        if expr.formal not in points:
            try:
                points[expr.formal] = evaluate(resolved.args[expr.formal], "point", env)
            except Unresolved as missing:
                points[expr.formal] = missing
        point = points[expr.formal]
        if isinstance(point, Unresolved):
            return {"param": point.name, "field": expr.field}
        index = POINT_FIELDS[expr.field]
        assert isinstance(point, list)
        return point[index] if index < len(point) else None
    if isinstance(expr, ast.Ref) and expr.name in resolved.args:
        formal = next(f for f in resolved.form.formals if f.name == expr.name)
        value, kind = resolved.args[expr.name], formal.kind or kind
    else:
        value = expr
    try:
        return evaluate(value, kind, env)
    except Unresolved as missing:
        return {"param": missing.name}


def _action(ctx: Context, spec: ActionSpec, resolved: Resolved,
            points: dict[str, object] | None = None) -> Action:
    if spec.kind == "send":  # Send(CHANNEL, MESSAGE) of a fleet: names, not values
        return Action("send", spec.behaviour, tuple(
            (key, expr.name) for key, expr in spec.bindings if isinstance(expr, ast.Ref)))
    params = tuple((key, _value(ctx, expr, resolved, "list", points))
                   for key, expr in spec.bindings)
    return Action(spec.kind, spec.behaviour, params)

