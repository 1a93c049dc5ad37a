"""The trace harness shared by the tests of the player, the runner, the in-process adapter,
the run log and replay (tests/petri/execution/test_player.py, test_runner.py, test_inprocess.py,
test_runlog.py, test_replay.py).

Trace tests in the py_trees style: each test writes the trace it expects *before* driving the
player, then drives it with ``handle_event`` / ``settle`` at chosen simulated times and asserts
the exact sequence of what the player did. A trace item is one of::

    ("enable", "Alpha")        an action the player sent (kind, behaviour)
    ("event", "Alpha.ok")      an event that fired something
    ("ignored", "Beta.ok")     an event nobody waited for (logged, no effect)
    ("note", "...")            a note (Link.lost turned into an abort, last line of defence)
    ("status", "ok")           the mission ended

The task library below gives every task its own behaviour, so that the actions say which
task sent them: A() drives Alpha, B() Beta, C() Gamma, D() Delta; Watch() is a CATCH that
switches the Watch behaviour on; Sentinel() only watches (like KeepHeadDistException);
LinkWatch() catches Link.lost; Light and Cam are latched behaviours.

``Harness.assert_finished`` checks that a run ended with no behaviour on and the net in a
proper final marking, and that its records, written as a run log, replay as conformant.
``ListStack`` is a simulated vehicle stack that sends prepared (possibly duplicated,
out-of-order or malformed) messages, for the runner through the in-process adapter.
"""

from __future__ import annotations

from typing import Any

from aal.messages import ActionMessage, EventMessage
from diagnostics import Source
from mcl import tasklib
from mcl.api import compile_source
from petri.net import Net
from petri.execution.player import Player, Record
from petri.execution.replay import check
from petri.execution.runlog import FORMAT, net_digest
from petri.execution.runner import run
from tests.support import REPO
from vehicle_adapters.inprocess import InProcess

CORE_TASKS = (REPO / "mcl" / "tasks" / "core.tasks").read_text("utf-8")  # Wait, Timeout
TRACE_TASKS = """
behaviour Alpha events ok, fail;
behaviour Beta  events ok, fail;
behaviour Gamma events ok, fail;
behaviour Delta events ok, fail;
behaviour Watch events alarm, clear;
behaviour Light;
behaviour Cam;
task A() { start: enable Alpha; ok: Alpha.ok; fail: Alpha.fail; stop: disable Alpha; }
task B() { start: enable Beta;  ok: Beta.ok;  fail: Beta.fail;  stop: disable Beta; }
task C() { start: enable Gamma; ok: Gamma.ok; fail: Gamma.fail; stop: disable Gamma; }
task D() { start: enable Delta; ok: Delta.ok; fail: Delta.fail; stop: disable Delta; }
task Watch() { start: enable Watch; ok: Watch.clear; fail: Watch.alarm; stop: disable Watch; }
task Sentinel() { fail: Watch.alarm; }
task AlphaWatch() { fail: Alpha.fail; }
task LinkWatch() { fail: Link.lost; }
task Now() { }
task Light(enable)  { start: enable Light;  latch: Light; }
task Light(disable) { start: disable Light; unlatch: Light; }
task Cam(enable)    { start: enable Cam;    latch: Cam; }
task Cam(disable)   { start: disable Cam;   unlatch: Cam; }
"""
LIBRARY = tasklib.load_sources([Source("core.tasks", CORE_TASKS),
                                Source("trace.tasks", TRACE_TASKS)])

Trace = list[tuple[str, str]]


# -- the harness --------------------------------------------------------------------------
def log_records(net: Net, records: list[Record]) -> list[dict[str, Any]]:
    """The records as ``read_log`` returns them from a RunLog file (header first)."""
    out: list[dict[str, Any]] = [{"kind": "header", "format": FORMAT, "net": net_digest(net),
                                  "_line": 1}]
    for i, r in enumerate(records, start=2):
        out.append({"t": round(r.t, 6), "kind": r.kind, **r.data, "_line": i})
    return out


class Harness:
    """A player on a mission written in the trace library, recording what it does."""

    def __init__(self, body: str, params: dict[str, Any] | None = None, header: str = ""):
        text = f"{header}MISSION {{\n{body}\n}}\n"
        self.net = compile_source(Source("m.mcl", text), library=LIBRARY).net
        self.records: list[Record] = []
        self.params = params or {}
        self.player = Player(self.net, dict(self.params), observers=[self.records.append])

    def start(self, now: float = 0.0) -> Harness:
        self.player.start(now)
        return self

    def event(self, name: str, now: float) -> int:
        return self.player.handle_event(name, now)

    def trace(self, since: int = 0) -> Trace:
        out: Trace = []
        for r in self.records[since:]:
            if r.kind == "action":
                out.append((r.data["action"], r.data["behaviour"]))
            elif r.kind == "event":
                out.append(("event", r.data["event"]))
            elif r.kind == "ignored":
                out.append(("ignored", r.data["event"]))
            elif r.kind == "note":
                out.append(("note", r.data["note"]))
            elif r.kind == "status" and r.data["status"] != "running":
                out.append(("status", r.data["status"]))
        return out

    def timed(self) -> list[tuple[float, str, str]]:
        """Actions with their times."""
        return [(r.t, r.data["action"], r.data["behaviour"]) for r in self.records
                if r.kind == "action"]

    def fired(self) -> list[str]:
        return [r.data["transition"] for r in self.records if r.kind == "fire"]

    def on(self) -> set[str]:
        return set(self.player.behaviours_on)

    def assert_finished(self, status: str, defence: bool = False) -> None:
        """Ended with ``status``; no behaviour on; a proper final marking; the records
        replay as conformant. ``defence``: the last line of defence was expected."""
        p = self.player
        assert p.status == status
        assert p.finished
        assert p.behaviours_on == {}, p.behaviours_on
        marking = {i: n for i, n in enumerate(p.marking) if n}
        if not defence:  # else the net itself leaves the latch on: not a proper final
            assert marking in self.net.finals, self.net.describe_marking(marking)
        notes = [r.data["note"] for r in self.records if r.kind == "note"]
        assert any("switching off" in n for n in notes) == defence, notes
        self.assert_conformant()

    def assert_conformant(self) -> None:
        result = check(self.net, log_records(self.net, self.records), self.params)
        assert result.ok, (result.line, result.reason)


# A trace helper for the expected side: ("enable", "Alpha") etc. from short strings.
def T(*items: str) -> Trace:  # a short name: it reads like a table
    """``T("+Alpha", "Alpha.ok>", "-Alpha", "Beta.ok?", "=ok")``: + enable, - disable,
    ``X.y>`` event, ``X.y?`` ignored, ``=s`` status."""
    out: Trace = []
    for it in items:
        if it.startswith("+"):
            out.append(("enable", it[1:]))
        elif it.startswith("-"):
            out.append(("disable", it[1:]))
        elif it.endswith(">"):
            out.append(("event", it[:-1]))
        elif it.endswith("?"):
            out.append(("ignored", it[:-1]))
        elif it.startswith("="):
            out.append(("status", it[1:]))
        else:
            raise ValueError(it)
    return out


def without_notes(trace: Trace) -> Trace:
    return [x for x in trace if x[0] != "note"]


# -- the TRY / CATCH / DO mission the player, runner and run-log tests share ---------------
TRY = "TRY { A() } CATCH { Watch() } DO { B() }"


# -- driving a harness as a runner would ----------------------------------------------------
def drive(h: Harness, schedule: list[tuple[float, str]]) -> None:
    """Events at their times, and every timer that falls due in between, as a runner would."""
    h.start(0)
    for t, event in schedule:
        while (d := h.player.next_deadline()) is not None and d <= t:
            h.player.settle(d)
        h.event(event, t)


# -- a vehicle stack that sends prepared messages (duplicated, out of order, malformed) ---
class Raw:
    """A message as it travels: ``to_json`` gives exactly this text."""

    def __init__(self, text: str):
        self.text = text

    def to_json(self) -> str:
        return self.text


class ListStack:
    """A simulated vehicle stack that sends prepared messages at given times, whatever the
    actions (which it records)."""

    def __init__(self, messages: list[tuple[float, Any]]):
        self.pending = sorted(messages, key=lambda m: m[0])
        self.actions: list[ActionMessage] = []

    def on_action(self, action: ActionMessage, now: float) -> None:
        self.actions.append(action)

    def next_time(self) -> float | None:
        return self.pending[0][0] if self.pending else None

    def due(self, t: float) -> list[Any]:
        out = [m for when, m in self.pending if when <= t]
        self.pending = [(when, m) for when, m in self.pending if when > t]
        return out


def ev(seq: int, t: float, event: str) -> EventMessage:
    source, name = event.split(".")
    return EventMessage(seq, t, source, name)


def run_with(body: str, messages: list[tuple[float, Any]]) -> tuple[Harness, Any, InProcess]:
    h = Harness(body)
    vehicle = InProcess(ListStack(messages))
    outcome = run(h.player, vehicle, "m", max_time=1000)
    return h, outcome, vehicle
