"""The mission's stop handler (MCL's ``ON STOP``) in a run: its bound, and how it went, as the
end record and the summary tell it.

A stop from outside (a signal, the time limit, an uncaught ``Link.lost``) aborts the mission's
blocks through the net; a mission with a stop handler then runs it, for at most its proved
worst case (:func:`mcl.analysis.duration.stop_handler`), and ends when it ends. A second stop,
a vehicle that fails or a lost link halts it (petri/execution/runner.py). The end record's
``stop_handler`` says which: ``{"how": "ended ok" | "ended fail" | "halted", "start": s,
"end": s, "bound": s, "why": ...}``.
"""

from __future__ import annotations

import math
from typing import Any

from mcl.analysis.duration import stop_handler as durations
from mcl.checker import Checked
from mcl.quantities import seconds_text
from mcl.templates.mission import STOP_FAIL, STOP_OK
from petri.execution.player import Record
from petri.execution.runner import StopHandler


def bound(checked: Checked) -> float:
    """The mission time the stop handler is given: its proved worst case (infinite: the
    mission has none, or none was proved — the runner then uses its own limit)."""
    d = durations(checked)
    return d.worst if d is not None else math.inf


class StopWatch:
    """An observer of the player: how the stop handler ended, if it ended by itself."""

    def __init__(self) -> None:
        self.ended: str | None = None  # "ok" | "fail"

    def __call__(self, record: Record) -> None:
        if record.kind == "fire":
            name = record.data["transition"]
            if name in (STOP_OK, STOP_FAIL):
                self.ended = "ok" if name == STOP_OK else "fail"


def as_record(handler: StopHandler, watch: StopWatch) -> dict[str, Any]:
    """The end record's ``stop_handler``."""
    how = f"ended {watch.ended}" if handler.how == "ended" and watch.ended else handler.how
    out: dict[str, Any] = {"how": how, "start": round(handler.start, 6),
                           "end": round(handler.time, 6), "bound": round(handler.bound, 6)}
    if handler.reason:
        out["why"] = handler.reason
    return out


def text(record: dict[str, Any]) -> str:
    """One line for people: the stop handler and how it went."""
    line = (f"stop handler (ON STOP) {record['how']} at {record['end']:.1f} s, started at "
            f"{record['start']:.1f} s (proved bound {seconds_text(record['bound'])})")
    return line + (f": {record['why']}" if record.get("why") else "")
