"""Template of ``PARALLEL {B1} OR {B2} [OR ...]``.

::

    begin ─► every branch starts (race)
    Bi ends first ─► abort every other branch, wait for them ─► ok | fail, as Bi ended
    abort during the race ─► abort every branch, wait ─► (latches off) ─► aborted
    abort while the others are being stopped ─► wait ─► (latches off) ─► aborted
"""

from __future__ import annotations

from collections.abc import Callable

from mcl import ast
from mcl.templates.common import Context, Interface


def build(ctx: Context, node: ast.ParallelOr,
          compile_block: Callable[[Context, ast.Block], Interface]) -> Interface:
    name = ctx.prefix("OR", node.span)
    origin = ctx.origin(node.span, "PARALLEL OR", "OR")
    io = ctx.interface(name, origin)
    branches = [compile_block(ctx, b) for b in node.branches]
    entry = ctx.abort_entry(node, name, io.aborted, origin)

    def place(role: str) -> int:
        return ctx.place(f"{name}.{role}", origin=origin)

    race = place("race")
    won = {"ok": place("won_ok"), "fail": place("won_fail")}
    aborting = place("aborting")
    stopping = [place(f"stop{i + 1}") for i in range(len(branches))]
    stopped = [place(f"stopped{i + 1}") for i in range(len(branches))]
    ctx.transition(f"{name}.start", [io.begin], [b.begin for b in branches] + [race],
                   "start every branch", origin)
    for i, b in enumerate(branches):
        others = [j for j in range(len(branches)) if j != i]
        for status, out in (("ok", b.ok), ("fail", b.fail)):
            ctx.transition(f"{name}.first{i + 1}_{status}", [race, out],
                           [won[status], stopped[i]]
                           + [branches[j].abort for j in others] + [stopping[j] for j in others],
                           f"branch {i + 1} ended {status} first → stop the others", origin)
        ctx.absorb(b, stopping[i], [stopped[i]], f"{name}.stop{i + 1}", origin)
    for status, result in (("ok", io.ok), ("fail", io.fail)):
        ctx.transition(f"{name}.end_{status}", stopped + [won[status]], [result],
                       f"the others stopped → {status}", origin)
        ctx.transition(f"{name}.abort_won_{status}", [won[status], io.abort], [aborting],
                       "aborted while stopping the others", origin)
    ctx.transition(f"{name}.abort", [race, io.abort],
                   [b.abort for b in branches] + stopping + [aborting],
                   "aborted during the race", origin)
    ctx.transition(f"{name}.abort_joined", stopped + [aborting], [entry],
                   "every branch stopped", origin)
    return io
