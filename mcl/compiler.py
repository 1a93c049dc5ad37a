"""Compile a checked mission into a Petri net: one template per construct (mcl/templates/).

The net carries, on each transition, the actions it sends, the event or timer it waits for
and the MCL source it comes from, so the net that ``mclc`` verifies is the net the player runs.
"""

from __future__ import annotations

from petri.net import LATCH_OFF, LATCH_ON, Net

from mcl import ast

from mcl.analysis import latches
from mcl.checker import Checked
from mcl.templates import (
    if_then_else,
    mission,
    parallel_and,
    parallel_or,
    sequence,
    task,
    try_catch_do,
    while_do,
)
from mcl.templates.common import Context, Interface, Latch


def compile_mission(checked: Checked) -> Net:
    m = checked.mission
    net = Net(m.name or "mission", dofs=checked.library.dofs())
    ctx = Context(net, checked)
    _latches(ctx)
    if ctx.latches:
        ctx.flow = latch_flow(checked)
    root = mission.build(ctx, m, compile_block)
    net.initial = {root.begin: 1} | {latch.off: 1 for latch in ctx.latches.values()}
    offs = {latch.off: 1 for latch in ctx.latches.values()}
    net.finals = [{root.ok: 1} | offs, {root.fail: 1} | offs]
    return net


def compile_block(ctx: Context, block: ast.Block) -> Interface:
    match block:
        case ast.Call():
            return task.build(ctx, block)
        case ast.Sequence():
            return sequence.build(ctx, block, compile_block)
        case ast.TryCatchDo():
            return try_catch_do.build(ctx, block, compile_block)
        case ast.ParallelAnd():
            return parallel_and.build(ctx, block, compile_block)
        case ast.ParallelOr():
            return parallel_or.build(ctx, block, compile_block)
        case ast.IfThenElse():
            return if_then_else.build(ctx, block, compile_block)
        case ast.WhileDo():
            return while_do.build(ctx, block, compile_block)
    raise TypeError(f"not a block: {block!r}")


def latch_flow(checked: Checked) -> latches.Flow:
    """Which latch states may hold at each call and in each block (mcl/analysis/latches.py): each
    latching call and each abort cleanup gets transitions for those states only."""
    return latches.analyse(checked)[0]


def _latches(ctx: Context) -> None:
    """One state machine per latched behaviour: an "off" place and an "on" place per call
    that switches it on, made before the templates so that any block can switch them off."""
    for call in ast.calls(ctx.checked.mission.body):  # ON STOP latches nothing (checker)
        form = ctx.checked.resolved(call).form
        behaviour = form.latch or form.unlatch
        if behaviour is None:
            continue
        latch = ctx.latches.get(behaviour)
        if latch is None:
            latch = ctx.latches[behaviour] = Latch(
                behaviour, ctx.place(f"{behaviour}.off", role=LATCH_OFF))
        if form.latch:
            origin = ctx.origin(call.span, f"{behaviour} on from {call.name}", "latch")
            latch.by_site[latches.site(call)] = latch.sites[id(call)] = ctx.place(
                f"{behaviour}.on@{call.span.line}:{call.span.col}", (behaviour,), origin,
                LATCH_ON)
