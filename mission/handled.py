"""What the mission's CATCH blocks handled during a run: every alarm or other event that
ended a CATCH first, when, the CATCH's line, and how its handler (the DO block) ended.

A handled alarm does not make a run fail: a mission whose CATCH caught ``Alarms.leak`` and
whose DO surfaced ends OK (exit 0) — that is what its author wrote. The run says so: the end
record's ``handled`` list and ``mcl run``'s summary (``handled: Alarms.leak at 41.0 s (CATCH
at line 48) -> DO ended ok``). A handler that should make the mission fail ends with the core
library's ``Fail()`` (docs/TASKS.md), and the run then ends FAIL (exit 1).

The player's records tell it (``try_catch_do`` template, mcl/templates/try_catch_do.py): the
transition ``TRY@L:C.catch_ok`` or ``.catch_fail`` fires when the CATCH ends first; the last
firing before it that an event or a timer caused names what was caught; ``.do_ok`` /
``.do_fail`` end the handler, ``.abort_do`` (the mission stopped from outside) cuts it.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, replace
from typing import Any

from mcl import ast
from mcl.api import Compiled
from petri.execution.player import Record

TRY_STEP = re.compile(r"^(TRY@\d+:\d+(?:#\d+)?)\.(catch_ok|catch_fail|do_ok|do_fail|abort_do)$")
UNTOLD = ("immediate", "abort", "replay")  # firing causes that are not what a CATCH caught


@dataclass(frozen=True)
class Handled:
    """One event a CATCH handled: what (an event such as ``Alarms.leak``, or ``timer of
    TASK@L:C``), at which mission time, the CATCH's line, and how its DO ended: ``ok``,
    ``fail``, ``aborted`` (the mission was stopped during it) or ``running`` (the run ended
    first)."""

    event: str
    t: float
    line: int
    ended: str = "running"

    def as_record(self) -> dict[str, Any]:
        """As the end record holds it."""
        return {"event": self.event, "t": round(self.t, 6), "line": self.line,
                "ended": self.ended}

    def text(self) -> str:
        """As ``mcl run``'s summary says it."""
        return (f"{self.event} at {self.t:.1f} s (CATCH at line {self.line}) -> DO "
                + ("still running at the end" if self.ended == "running"
                   else f"ended {self.ended}"))


def catch_lines(mission: ast.Mission) -> dict[tuple[int, int], int]:
    """Each TRY's line and column -> the line of its CATCH block."""
    return {(b.span.line, b.span.col): b.catch.span.line for part in mission.parts()
            for b in ast.walk(part)
            if isinstance(b, ast.TryCatchDo)}


class CatchWatch:
    """An observer of the player: collects what the mission's CATCH blocks handled."""

    def __init__(self, compiled: Compiled):
        self.lines = catch_lines(compiled.mission)
        self.handled: list[Handled] = []
        self.open: dict[str, int] = {}  # TRY name -> its handler under way (index in handled)
        self.cause: tuple[str, float] = ("", 0.0)  # the last event or timer that fired

    def __call__(self, record: Record) -> None:
        if record.kind != "fire":
            return
        d = record.data
        if d["cause"] not in UNTOLD:
            self.cause = (d["cause"] if d["cause"] != "timer"
                          else f"timer of {d['transition'].split('.')[0]}", record.t)
        step = TRY_STEP.match(d["transition"])
        if step is None:
            return
        name, what = step.groups()
        if what.startswith("catch_"):
            line, col = (int(x) for x in name[4:].split("#")[0].split(":"))
            event, t = self.cause if self.cause[0] else ("the CATCH ended", record.t)
            self.open[name] = len(self.handled)
            self.handled.append(Handled(event, t, self.lines.get((line, col), line)))
        elif name in self.open:
            at = self.open.pop(name)
            ended = {"do_ok": "ok", "do_fail": "fail"}.get(what, "aborted")
            self.handled[at] = replace(self.handled[at], ended=ended)
