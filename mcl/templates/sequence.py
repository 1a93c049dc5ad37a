"""Template of a sequence ``A1 ; A2 ; ... ; An``.

::

    begin ─► A1 ─(ok|fail)─► A2 ─► ... ─► An ─ok─► ok
                                               └fail─► fail
    abort while Ai runs ─► Ai.abort, wait for Ai ─► (switch latches off) ─► aborted

Each item starts when the one before it ends, whatever its status; the sequence ends with the
status of its last item.
"""

from __future__ import annotations

from collections.abc import Callable

from mcl import ast
from mcl.templates.common import Context, Interface


def build(ctx: Context, seq: ast.Sequence,
          compile_block: Callable[[Context, ast.Block], Interface]) -> Interface:
    name = ctx.prefix("SEQ", seq.span)
    origin = ctx.origin(seq.span, "sequence", "SEQ")
    io = ctx.interface(name, origin)
    items = [compile_block(ctx, item) for item in seq.items]
    running = [ctx.place(f"{name}.run{i + 1}", origin=origin) for i in range(len(items))]
    entry = ctx.abort_entry(seq, name, io.aborted, origin)

    ctx.transition(f"{name}.start", [io.begin], [items[0].begin, running[0]],
                   "start", origin)
    for i, (item, run) in enumerate(zip(items, running)):
        last = i == len(items) - 1
        for status, out in (("ok", item.ok), ("fail", item.fail)):
            outputs = ([io.ok if status == "ok" else io.fail] if last
                       else [items[i + 1].begin, running[i + 1]])
            ctx.transition(f"{name}.after{i + 1}.{status}", [run, out], outputs,
                           f"item {i + 1} ended {status}", origin)
        waiting = ctx.place(f"{name}.stop{i + 1}", origin=origin)
        ctx.transition(f"{name}.abort{i + 1}", [run, io.abort], [item.abort, waiting],
                       f"aborted during item {i + 1}", origin)
        ctx.absorb(item, waiting, [entry], f"{name}.stop{i + 1}", origin)
    return io
