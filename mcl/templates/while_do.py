"""Template of ``WHILE {C} DO {B}``.

::

    begin ─► C ─ok─► B ─ok─► C ...
               │       └fail─► fail
               └fail─► ok
    abort while C or B runs ─► abort it, wait ─► (switch latches off) ─► aborted
"""

from __future__ import annotations

from collections.abc import Callable

from mcl import ast, printer
from mcl.templates.common import Context, Interface


def build(ctx: Context, node: ast.WhileDo,
          compile_block: Callable[[Context, ast.Block], Interface]) -> Interface:
    name = ctx.prefix("WHILE", node.span)
    # the condition as written, one line, so that a report can say why the loop never ends
    written = " ".join(printer.block(node.condition, 0).split())
    origin = ctx.origin(node.span, f"WHILE {written}", "WHILE")
    io = ctx.interface(name, origin)
    cond = compile_block(ctx, node.condition)
    body = compile_block(ctx, node.body)
    entry = ctx.abort_entry(node, name, io.aborted, origin)
    in_cond = ctx.place(f"{name}.while", origin=origin)
    in_body = ctx.place(f"{name}.do", origin=origin)

    ctx.transition(f"{name}.start", [io.begin], [cond.begin, in_cond], "start", origin)
    ctx.transition(f"{name}.cond_ok", [in_cond, cond.ok], [body.begin, in_body],
                   "condition ok → DO", origin)
    ctx.transition(f"{name}.cond_fail", [in_cond, cond.fail], [io.ok],
                   "condition fail → loop ends ok", origin)
    ctx.transition(f"{name}.body_ok", [in_body, body.ok], [cond.begin, in_cond],
                   "DO ended ok → again", origin)
    ctx.transition(f"{name}.body_fail", [in_body, body.fail], [io.fail],
                   "DO ended fail → loop ends fail", origin)
    for role, place, child in (("while", in_cond, cond), ("do", in_body, body)):
        waiting = ctx.place(f"{name}.stop_{role}", origin=origin)
        ctx.transition(f"{name}.abort_{role}", [place, io.abort], [child.abort, waiting],
                       f"aborted during {role.upper()}", origin)
        ctx.absorb(child, waiting, [entry], f"{name}.stop_{role}", origin)
    return io
