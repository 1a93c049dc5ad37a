"""Template of ``PARALLEL {B1} AND {B2} [AND ...]``.

::

    begin ─► every branch starts; status "all ok"
    Bi ends ok ─► done_i;  Bi ends fail ─► done_i, status "some failed"
    all done_i ─► ok if all ok, else fail
    abort ─► "aborting": each branch still running is aborted and waited for
          ─► all done_i ─► (latches off) ─► aborted

The places ``calm`` and ``aborting`` are complements: the join that reports ok or fail takes
``calm``, so it cannot fire once an abort has been taken.
"""

from __future__ import annotations

from collections.abc import Callable

from mcl import ast
from mcl.templates.common import Context, Interface


def build(ctx: Context, node: ast.ParallelAnd,
          compile_block: Callable[[Context, ast.Block], Interface]) -> Interface:
    name = ctx.prefix("AND", node.span)
    origin = ctx.origin(node.span, "PARALLEL AND", "AND")
    io = ctx.interface(name, origin)
    branches = [compile_block(ctx, b) for b in node.branches]
    entry = ctx.abort_entry(node, name, io.aborted, origin)

    def place(role: str) -> int:
        return ctx.place(f"{name}.{role}", origin=origin)

    all_ok, some_fail = place("all_ok"), place("some_fail")
    calm, aborting = place("calm"), place("aborting")
    running = [place(f"run{i + 1}") for i in range(len(branches))]
    done = [place(f"done{i + 1}") for i in range(len(branches))]
    ctx.transition(f"{name}.start", [io.begin],
                   [b.begin for b in branches] + running + [all_ok, calm],
                   "start every branch", origin)
    for i, (b, run, fin) in enumerate(zip(branches, running, done), start=1):
        ctx.transition(f"{name}.branch{i}_ok", [run, b.ok], [fin], f"branch {i} ended ok",
                       origin)
        for status in (all_ok, some_fail):
            ctx.transition(f"{name}.branch{i}_fail.{ctx.net.places[status].name}",
                           [run, b.fail, status], [fin, some_fail],
                           f"branch {i} ended fail", origin)
        waiting = place(f"stop{i}")
        ctx.transition(f"{name}.abort{i}", [run, aborting], [b.abort, waiting, aborting],
                       f"stop branch {i}", origin)
        ctx.absorb(b, waiting, [fin], f"{name}.stop{i}", origin)
    ctx.transition(f"{name}.join_ok", done + [all_ok, calm], [io.ok], "every branch ok",
                   origin)
    ctx.transition(f"{name}.join_fail", done + [some_fail, calm], [io.fail],
                   "a branch failed", origin)
    ctx.transition(f"{name}.abort", [io.abort, calm], [aborting], "aborted", origin)
    for status in (all_ok, some_fail):
        ctx.transition(f"{name}.abort_joined.{ctx.net.places[status].name}",
                       done + [aborting, status], [entry], "every branch stopped", origin)
    return io
