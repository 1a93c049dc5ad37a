"""A run log's records as the messages of its MCAP file (docs/MCAP.md).

Each record of the run log (petri/execution/runlog.py) becomes one ``foxglove.Log`` message
on ``/mission/log`` with the MCL ``file`` and ``line`` it comes from: an action (the line of its
task call), an event (the line of the firing it caused, which follows it; else 0), a
firing (its line), a status change, a note, the player's cleanup, a long task's progress
(its task call's line), the vehicle's pose (a debug line; its track's messages:
mission/mcap_export.py) and the end record. Every
change of a task call's state (waiting, running, ok, fail, aborted, read from the firings of
its transitions) gives a ``mcl.MissionStatus`` message on ``/mission/status`` with every task
call's state, for Foxglove's State Transitions panel.
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass
from typing import Any

from petri.semantics import block_of

LOG_TOPIC = "/mission/log"
STATUS_TOPIC = "/mission/status"
DEBUG, INFO, WARNING, ERROR = 1, 2, 3, 4


@dataclass(frozen=True)
class Message:
    """One message of the MCAP file: its mission time (s), topic, schema name and JSON."""

    t: float
    topic: str
    schema: str
    data: dict[str, Any]


def stamp(t: float) -> dict[str, int]:
    """A Foxglove time (``sec``, ``nsec``) for mission time ``t`` (0 at the mission's start)."""
    ns = nanoseconds(t)
    return {"sec": ns // 1_000_000_000, "nsec": ns % 1_000_000_000}


def nanoseconds(t: float) -> int:
    return max(0, round(t * 1e9))


def call_line(call: str) -> int:
    """The line of a task call named ``Task@line:column`` (0 if it names none)."""
    _, _, where = call.rpartition("@")
    line = where.partition(":")[0]
    return int(line) if line.isdigit() else 0


def task_calls(records: list[dict[str, Any]]) -> list[str]:
    """The task calls whose transitions fired in the log, in source order."""
    calls = {block_of(str(r["transition"])) for r in records
             if r["kind"] == "fire" and "(" in str(r.get("construct", ""))}
    return sorted(calls, key=source_order)


def source_order(call: str) -> tuple[int, str, str]:
    """A task call's place in the mission: its line, then its column."""
    return call_line(call), call.rpartition(":")[2].zfill(6), call


def next_state(current: str, transition: str) -> str:
    """A task call's state after one of its transitions fired (``GoTo@34:9.ok.GoTo.reached``:
    ok); an instantaneous task (``StartCamera@38:13.from...``) starts and ends at once."""
    step = transition.split(".", 2)[1] if transition.count(".") else ""
    if step in ("ok", "from"):
        return "ok"
    if step == "fail":
        return "fail"
    if step in ("abort", "aborted"):
        return "aborted"
    if step == "start" or current == "waiting":
        return "running"
    return current


class LogMessages:
    """The log and status messages of a run's records, fed one at a time (:meth:`feed`), as
    a run log holds them; ``calls``: the mission's task calls (each starts ``waiting``). An
    event's message waits for the next record: the firing it caused names its line."""

    def __init__(self, header: dict[str, Any], calls: list[str]):
        self.file = str(header.get("file", ""))
        self.mission = str(header.get("mission", ""))
        self.states = {call: "waiting" for call in calls}
        self.status = "running"
        self.event: dict[str, Any] | None = None  # the last event, its line not yet known

    @classmethod
    def of_log(cls, records: list[dict[str, Any]]) -> Iterator[Message]:
        """Every message of a run log's records (read by runlog.read_log)."""
        messages = cls(records[0], task_calls(records))
        for r in records[1:]:
            yield from messages.feed(r)
        yield from messages.flush()

    def feed(self, r: dict[str, Any]) -> list[Message]:
        """The messages of one record (``t``, ``kind`` and its fields); a pose says where
        the vehicle was, a debug line that leaves a waiting event waiting (its firing
        follows)."""
        if r["kind"] == "pose":
            return [self.log(float(r["t"]), *said(r))]
        out = self.flush(r)
        t = float(r["t"])
        if r["kind"] == "event":
            self.event = r
        else:
            out.append(self.log(t, *said(r)))
        if r["kind"] == "fire":
            call = block_of(str(r["transition"]))
            if call in self.states:
                state = next_state(self.states[call], str(r["transition"]))
                if state != self.states[call]:
                    self.states[call] = state
                    out.append(self.status_message(t))
        elif r["kind"] in ("status", "end"):
            self.status = str(r.get("status", "ended")) if r["kind"] == "status" else (
                self.status if self.status in ("ok", "fail") else "ended")
            out.append(self.status_message(t))
        return out

    def flush(self, after: dict[str, Any] | None = None) -> list[Message]:
        """The waiting event's message, with the line of ``after`` if that is the firing it
        caused (else line 0)."""
        event, self.event = self.event, None
        if event is None:
            return []
        name = str(event.get("event"))
        line = (int(after.get("line") or 0) if after is not None and after["kind"] == "fire"
                and after.get("cause") == name else 0)
        data = event.get("data") or {}
        return [self.log(float(event["t"]), INFO, "vehicle", line,
                         f"event {name}" + (f" {data}" if data else ""))]

    def log(self, t: float, level: int, name: str, line: int, message: str) -> Message:
        return Message(t, LOG_TOPIC, "foxglove.Log", {
            "timestamp": stamp(t), "level": level, "message": message, "name": name,
            "file": self.file, "line": max(0, line)})

    def status_message(self, t: float) -> Message:
        return Message(t, STATUS_TOPIC, "mcl.MissionStatus", {
            "timestamp": stamp(t), "mission": self.mission, "status": self.status,
            "tasks": [{"task": c, "line": call_line(c), "state": s}
                      for c, s in self.states.items()]})


def said(r: dict[str, Any]) -> tuple[int, str, int, str]:
    """A record other than an event as a log line: level, name, MCL line, message."""
    kind = r["kind"]
    if kind == "action":
        params = ", ".join(f"{k}={v}" for k, v in (r.get("params") or {}).items())
        task = str(r.get("task", ""))
        return (INFO, task, call_line(task),
                f"{r.get('action')} {r.get('behaviour')}" + (f"({params})" if params else ""))
    if kind == "ignored":
        return (WARNING, "vehicle", 0, f"event {r.get('event')} ignored: {r.get('reason')}")
    if kind == "fire":
        return (DEBUG, str(r.get("construct", "")), int(r.get("line") or 0),
                f"fire {r.get('transition')}: {r.get('label')} ({r.get('cause')})")
    if kind == "status":
        return INFO, "mission", 0, f"mission {r.get('status')}"
    if kind == "cleanup":
        return (WARNING, "player", 0,
                f"cleanup: switching off {', '.join(map(str, r.get('behaviours') or []))}")
    if kind == "progress":
        told = r.get("progress") or {}
        text = ", ".join(f"{k} {v}" for k, v in told.items())
        if isinstance(r.get("left"), (int, float)) and isinstance(r.get("bound"), (int, float)):
            text += f"; {r['left']:g} s left of {r['bound']:g} s"
        task = str(r.get("task", ""))
        return INFO, task, call_line(task), f"progress: {text}"
    if kind == "pose":
        return (DEBUG, "vehicle", 0, "pose x={x} m, y={y} m, z={z} m, yaw={yaw} rad".format(
            **{k: r.get(k) for k in ("x", "y", "z", "yaw")}))
    if kind == "end":
        level = INFO if r.get("exit") == 0 else ERROR
        return (level, "mission", 0,
                f"run ended {r.get('how')}: {r.get('why')} (exit {r.get('exit')})")
    return INFO, "note", 0, str(r.get("note", ""))
