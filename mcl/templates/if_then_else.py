"""Template of ``IF {C} THEN {A} [ELSE {B}]``.

::

    begin ─► C ─ok─► A ─► ok | fail
               └fail─► B ─► ok | fail        (without ELSE: ─► fail)
    abort while C, A or B runs ─► abort it, wait ─► (switch latches off) ─► aborted

C is a block, not a boolean: its status chooses the branch.
"""

from __future__ import annotations

from collections.abc import Callable

from mcl import ast
from mcl.templates.common import Context, Interface


def build(ctx: Context, node: ast.IfThenElse,
          compile_block: Callable[[Context, ast.Block], Interface]) -> Interface:
    name = ctx.prefix("IF", node.span)
    origin = ctx.origin(node.span, "IF", "IF")
    io = ctx.interface(name, origin)
    cond = compile_block(ctx, node.condition)
    then = compile_block(ctx, node.then)
    other = compile_block(ctx, node.else_) if node.else_ is not None else None
    entry = ctx.abort_entry(node, name, io.aborted, origin)

    phases = [("if", cond), ("then", then)] + ([("else", other)] if other else [])
    running = {role: ctx.place(f"{name}.{role}", origin=origin) for role, _ in phases}
    ctx.transition(f"{name}.start", [io.begin], [cond.begin, running["if"]], "start", origin)
    ctx.transition(f"{name}.cond_ok", [running["if"], cond.ok],
                   [then.begin, running["then"]], "condition ok → THEN", origin)
    if other is not None:
        ctx.transition(f"{name}.cond_fail", [running["if"], cond.fail],
                       [other.begin, running["else"]], "condition fail → ELSE", origin)
    else:
        ctx.transition(f"{name}.cond_fail", [running["if"], cond.fail], [io.fail],
                       "condition fail, no ELSE → fail", origin)
    for role, branch in phases[1:]:
        ctx.transition(f"{name}.{role}_ok", [running[role], branch.ok], [io.ok],
                       f"{role.upper()} ended ok", origin)
        ctx.transition(f"{name}.{role}_fail", [running[role], branch.fail], [io.fail],
                       f"{role.upper()} ended fail", origin)
    for role, child in phases:
        waiting = ctx.place(f"{name}.stop_{role}", origin=origin)
        ctx.transition(f"{name}.abort_{role}", [running[role], io.abort],
                       [child.abort, waiting], f"aborted during {role.upper()}", origin)
        ctx.absorb(child, waiting, [entry], f"{name}.stop_{role}", origin)
    return io
