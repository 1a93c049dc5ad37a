"""Template of ``TRY {T} CATCH {C} DO {D}``.

::

    begin ─► T and C together (race)
    T ends first ─► abort C, wait for it ─► ok | fail, as T ended
    C ends first ─► abort T, wait for it ─► D ─► ok | fail, as D ended
    abort during the race ─► abort T and C, wait for both ─┐
    abort while C or T is being stopped ─► wait for it ───┤─► (latches off) ─► aborted
    abort while D runs ─► abort D, wait ──────────────────┘

A CATCH block usually only watches (``Alarms()``): it ends when its event arrives.
"""

from __future__ import annotations

from collections.abc import Callable

from mcl import ast
from mcl.templates.common import Context, Interface


def build(ctx: Context, node: ast.TryCatchDo,
          compile_block: Callable[[Context, ast.Block], Interface]) -> Interface:
    name = ctx.prefix("TRY", node.span)
    origin = ctx.origin(node.span, "TRY", "TRY")
    io = ctx.interface(name, origin)
    t = compile_block(ctx, node.try_)
    c = compile_block(ctx, node.catch)
    d = compile_block(ctx, node.do)
    entry = ctx.abort_entry(node, name, io.aborted, origin)

    def place(role: str) -> int:
        return ctx.place(f"{name}.{role}", origin=origin)

    race = place("race")
    ctx.transition(f"{name}.start", [io.begin], [t.begin, c.begin, race], "start TRY and CATCH",
                   origin)
    # TRY ends first: stop CATCH, then end with TRY's status.
    for status, out, result in (("ok", t.ok, io.ok), ("fail", t.fail, io.fail)):
        stopping = place(f"stop_catch_{status}")
        ctx.transition(f"{name}.try_{status}", [race, out], [c.abort, stopping],
                       f"TRY ended {status} first → stop CATCH", origin)
        ctx.absorb(c, stopping, [result], f"{name}.stop_catch_{status}", origin)
    # CATCH ends first: stop TRY, then run DO.
    stopping_try = place("stop_try")
    running_do = place("do")
    for status, out in (("ok", c.ok), ("fail", c.fail)):
        ctx.transition(f"{name}.catch_{status}", [race, out], [t.abort, stopping_try],
                       f"CATCH ended {status} first → stop TRY", origin)
    ctx.absorb(t, stopping_try, [d.begin, running_do], f"{name}.stop_try", origin)
    ctx.transition(f"{name}.do_ok", [running_do, d.ok], [io.ok], "DO ended ok", origin)
    ctx.transition(f"{name}.do_fail", [running_do, d.fail], [io.fail], "DO ended fail", origin)

    # Aborted: stop whatever runs, wait for TRY and CATCH (or DO), then report.
    abort_try, abort_catch = place("abort_try"), place("abort_catch")
    try_done, catch_done = place("abort_try_done"), place("abort_catch_done")
    ctx.transition(f"{name}.abort_race", [race, io.abort], [t.abort, c.abort, abort_try,
                                                           abort_catch],
                   "aborted during TRY/CATCH", origin)
    ctx.absorb(t, abort_try, [try_done], f"{name}.abort_try", origin)
    ctx.absorb(c, abort_catch, [catch_done], f"{name}.abort_catch", origin)
    ctx.transition(f"{name}.abort_joined", [try_done, catch_done], [entry],
                   "TRY and CATCH stopped", origin)
    for status in ("ok", "fail"):
        ctx.transition(f"{name}.abort_stop_catch_{status}",
                       [ctx.net.place(f"{name}.stop_catch_{status}"), io.abort],
                       [abort_catch, try_done], "aborted while stopping CATCH", origin)
    ctx.transition(f"{name}.abort_stop_try", [stopping_try, io.abort],
                   [abort_try, catch_done], "aborted while stopping TRY", origin)
    abort_do = place("abort_do")
    ctx.transition(f"{name}.abort_do", [running_do, io.abort], [d.abort, abort_do],
                   "aborted during DO", origin)
    ctx.absorb(d, abort_do, [entry], f"{name}.abort_do", origin)
    return io
