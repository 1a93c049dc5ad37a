"""Template of the mission itself: the root that the player starts and may abort.

::

    begin (marked) ─► body ─ok─► ok
                           └fail─► fail
    event Mission.abort (the operator, or Link.lost that no block catches)
         ─► abort body, wait ─► every latched behaviour off ─► fail

The proper final markings are one token in ``MISSION.ok`` or ``MISSION.fail`` with every
latched behaviour off.
"""

from __future__ import annotations

from collections.abc import Callable

from petri.net import BEGIN, END_FAIL, END_OK
from petri.semantics import MISSION_ABORT as ABORT_EVENT  # the external stop, defined there

from mcl import ast
from mcl.templates.common import Context, Interface

__all__ = ["ABORT_EVENT", "build"]


def build(ctx: Context, mission: ast.Mission,
          compile_block: Callable[[Context, ast.Block], Interface]) -> Interface:
    name = "MISSION"
    origin = ctx.origin(mission.span, f"MISSION {mission.name or ''}".strip(), "MISSION")
    begin = ctx.place(f"{name}.begin", origin=origin, role=BEGIN)
    ok = ctx.place(f"{name}.ok", origin=origin, role=END_OK)
    fail = ctx.place(f"{name}.fail", origin=origin, role=END_FAIL)
    body = compile_block(ctx, mission.body)
    running = ctx.place(f"{name}.running", origin=origin)
    stopping = ctx.place(f"{name}.stopping", origin=origin)
    cleanup = ctx.abort_entry(mission.body, name, fail, origin)

    ctx.transition(f"{name}.start", [begin], [body.begin, running], "mission starts",
                   origin)
    ctx.transition(f"{name}.ok", [running, body.ok], [ok], "mission ends ok", origin)
    ctx.transition(f"{name}.fail", [running, body.fail], [fail], "mission ends fail",
                   origin)
    ctx.transition(f"{name}.abort", [running], [body.abort, stopping], "mission aborted",
                   origin, event=ABORT_EVENT)
    ctx.absorb(body, stopping, [cleanup], f"{name}.stop", origin)
    return Interface(name, begin, -1, ok, fail, -1)
