"""Template of the mission itself: the root that the player starts and may stop from outside.

::

    begin (marked) ─► body ─ok─► ok
                           └fail─► fail
    event Mission.abort (the operator, a limit, or Link.lost that no block catches)
         ─► abort body, wait ─► every latched behaviour off ─► fail

With a stop handler (``ON STOP { H }``), the stop does not end there::

         ─► abort body, wait ─► every latched behaviour off ─► H ─ok/fail─► fail
    event Mission.abort again, while H runs (a second signal, or H past its proved bound)
         ─► abort H, wait ─► fail

H starts only once the body has stopped and switched off everything it had on; the checker
refuses a latching task in it, so nothing is on when the mission ends. The place
``MISSION.stop_handler`` (role :data:`~petri.net.STOP_HANDLER`) holds a token while H runs.

The proper final markings are one token in ``MISSION.ok`` or ``MISSION.fail`` with every
latched behaviour off.
"""

from __future__ import annotations

from collections.abc import Callable

from petri.net import BEGIN, END_FAIL, END_OK, STOP_HANDLER
from petri.semantics import MISSION_ABORT as ABORT_EVENT  # the external stop, defined there

from mcl import ast
from mcl.templates.common import Context, Interface

__all__ = ["ABORT_EVENT", "HALT", "STOP_FAIL", "STOP_OK", "STOP_START", "build"]

NAME = "MISSION"
# The stop handler's transitions, by name (mission/run.py tells from them how it ended).
STOP_START = f"{NAME}.on_stop"  # the body has stopped: the handler starts
STOP_OK = f"{NAME}.on_stop.ok"  # the handler ended ok
STOP_FAIL = f"{NAME}.on_stop.fail"  # the handler ended fail
HALT = f"{NAME}.halt"  # a second stop while the handler runs: it is aborted in turn


def build(ctx: Context, mission: ast.Mission,
          compile_block: Callable[[Context, ast.Block], Interface]) -> Interface:
    name = NAME
    origin = ctx.origin(mission.span, f"MISSION {mission.name or ''}".strip(), "MISSION")
    begin = ctx.place(f"{name}.begin", origin=origin, role=BEGIN)
    ok = ctx.place(f"{name}.ok", origin=origin, role=END_OK)
    fail = ctx.place(f"{name}.fail", origin=origin, role=END_FAIL)
    body = compile_block(ctx, mission.body)
    running = ctx.place(f"{name}.running", origin=origin)
    stopping = ctx.place(f"{name}.stopping", origin=origin)
    stopped = fail if mission.on_stop is None else ctx.place(f"{name}.stopped", origin=origin)
    cleanup = ctx.abort_entry(mission.body, name, stopped, origin)

    ctx.transition(f"{name}.start", [begin], [body.begin, running], "mission starts",
                   origin)
    ctx.transition(f"{name}.ok", [running, body.ok], [ok], "mission ends ok", origin)
    ctx.transition(f"{name}.fail", [running, body.fail], [fail], "mission ends fail",
                   origin)
    ctx.transition(f"{name}.abort", [running], [body.abort, stopping], "mission aborted",
                   origin, event=ABORT_EVENT)
    ctx.absorb(body, stopping, [cleanup], f"{name}.stop", origin)
    if mission.on_stop is not None:
        stop_handler(ctx, mission, stopped, fail, compile_block)
    return Interface(name, begin, -1, ok, fail, -1)


def stop_handler(ctx: Context, mission: ast.Mission, stopped: int, fail: int,
                 compile_block: Callable[[Context, ast.Block], Interface]) -> None:
    """ON STOP: from ``stopped`` (the body has stopped, everything off) the handler runs, and
    the mission ends ``fail`` however it ends; a second stop aborts it."""
    assert mission.on_stop is not None
    origin = ctx.origin(mission.stop_span, "ON STOP", "ON STOP")
    handler = compile_block(ctx, mission.on_stop)
    running = ctx.place(f"{NAME}.stop_handler", origin=origin, role=STOP_HANDLER)
    halting = ctx.place(f"{NAME}.halting", origin=origin)
    ctx.transition(STOP_START, [stopped], [handler.begin, running],
                   "the mission has stopped: its stop handler starts", origin)
    ctx.transition(STOP_OK, [running, handler.ok], [fail], "the stop handler ended ok",
                   origin)
    ctx.transition(STOP_FAIL, [running, handler.fail], [fail], "the stop handler ended fail",
                   origin)
    ctx.transition(HALT, [running], [handler.abort, halting],
                   "stopped again while the stop handler runs: it is aborted", origin,
                   event=ABORT_EVENT)
    ctx.absorb(handler, halting, [ctx.abort_entry(mission.on_stop, f"{NAME}.halt", fail,
                                                  origin)], f"{NAME}.halt", origin)
