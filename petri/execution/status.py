"""The mission's status as an operator sees it: which tasks run, how far along, what last
happened. A player observer keeps it up to date; adapters publish it (Zenoh:
``mcl/<vehicle>/mission/status``) and ``mcl monitor`` shows it.

The status is one small JSON object (``v`` 1)::

    {"v": 1, "mission": "dam_inspection", "run": "…", "t": 123.4, "clock": 123.5,
     "status": "running",
     "running": [{"task": "WallInspect@39:13", "since": 100.2, "bound": 1500.0, "left": 1377.6,
                  "progress": {"waypoint": 12, "of": 84, "to_go": 96.3}}],
     "done": 5, "total": 17,
     "behaviours": ["AchieveHeadDist", "StartCamera", "WallInspection"], "fired": 80,
     "last_event": {"t": 98.1, "event": "GoTo.reached", "line": 34},
     "last_action": {"t": 100.2, "action": "enable", "behaviour": "WallInspection"}}

``last_event`` gains ``line``, the MCL line of the firing it caused, once it has fired (an
event nobody waited for has none). ``total`` counts the task calls of the mission (each ``Task@line:col`` once), ``done`` those
that have started and are no longer running (ended, or never run because their block was
aborted before them is not counted); a task in a loop counts once. ``t`` is mission time (0 at
the mission's start; the player runs on it, petri/execution/runner.py) at the last change, ``clock`` the
vehicle's clock then (``vehicle_time(t)``; the same as ``t`` without one): a monitor adds the
vehicle clock's progress since, and shows the vehicle's clock beside mission time.

A running task shows its proved ``bound`` (its shortest timer, in seconds; absent for a task
without one) and the time ``left`` of it, and what its behaviours say of their progress (the
vehicle's :meth:`progress`, behaviours/base.py: waypoint k of n, metres to go). The status is
published whenever the running tasks change (a timer's task, ``Timeout(5 min)``, runs without
any action or event) and, while a task runs, every ``every`` seconds of mission time
(:meth:`MissionStatus.tick`, called by the runner at each of its rounds).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from typing import Any

from petri.execution.player import Player, Record
from petri.net import Net
from petri.semantics import block_of

VERSION = 1


def task_calls(player: Player) -> list[str]:
    """The task calls of the net, in source order (``GoTo@12:9``)."""
    calls = {_call(t.name) for t in player.net.transitions
             if t.origin is not None and t.origin.kind == "task"}
    return sorted(calls, key=_source_order)


_call = block_of


def task_bounds(net: Net, params: Mapping[str, Any] | None = None) -> dict[str, float]:
    """Each task call's proved bound: its shortest timer (seconds), for the calls with one
    whose time is known (a timer a mission parameter gives is read off ``params``)."""
    bounds: dict[str, float] = {}
    for t in net.transitions:
        if t.origin is None or t.origin.kind != "task" or t.timer is None:
            continue
        seconds = (params or {}).get(t.timer) if isinstance(t.timer, str) else t.timer
        if isinstance(seconds, (int, float)) and math.isfinite(seconds):
            call = _call(t.name)
            bounds[call] = min(float(seconds), bounds.get(call, math.inf))
    return bounds


def _source_order(call: str) -> tuple[int, int, str]:
    _, _, where = call.rpartition("@")
    line, _, col = where.partition(":")
    try:
        return int(line), int(col), call
    except ValueError:
        return 1 << 30, 0, call


class MissionStatus:
    """A player observer (append it to ``player.observers``) that keeps the status.

    ``publish``: called with the status dict whenever it changes in a way an operator would
    see (a task starts or ends, an action, an event, the mission's status), at most once per
    record.
    """

    def __init__(self, player: Player, mission: str, run: str = "",
                 publish: Any = None, vehicle_time: Callable[[float], float] | None = None,
                 progress: Callable[[], dict[str, Any]] | None = None, every: float = 5.0):
        self.player = player
        self.mission = mission
        self.run = run
        self.publish = publish
        self.vehicle_time = vehicle_time
        self.calls = set(task_calls(player))
        self.total = len(self.calls)
        # the places that hold a running task's token (as Player.snapshot reads them), indexed
        # once: this observer runs at every firing, on the player's path from event to action
        self._run_places = [(i, block_of(player.net.places[i].name))
                            for i in player.rules.run_places]
        self.since: dict[str, float] = {}  # running task call -> mission time it started
        self.started: set[str] = set()  # task calls that have fired a transition
        self.start: float | None = None
        self.t = 0.0
        self.clock = 0.0  # the player's clock (the vehicle's) at mission time t
        self.last_event: dict[str, Any] | None = None
        self.last_action: dict[str, Any] | None = None
        self.bounds = task_bounds(player.net, player.params)
        self.progress = progress
        self.every = every
        self.published_at = -math.inf  # mission time of the last publication

    def __call__(self, record: Record) -> None:
        if self.start is None:
            self.start = record.t
        self.t = record.t - self.start
        self.clock = self.vehicle_time(record.t) if self.vehicle_time else record.t
        d = record.data
        if record.kind == "event":
            self.last_event = {"t": round(self.t, 3), "event": d["event"]}
        elif record.kind == "action":
            self.last_action = {"t": round(self.t, 3), "action": d["action"],
                                "behaviour": d["behaviour"], "task": d["task"]}
        elif record.kind != "status":
            if record.kind == "fire":
                call = _call(d["transition"])
                if call in self.calls:
                    self.started.add(call)
                ev = self.last_event
                caused = ev is not None and "line" not in ev and d.get("cause") == ev["event"]
                if caused and ev is not None:  # the event's line: that of the firing it caused
                    ev["line"] = d.get("line")
                if self._update_running() or caused:
                    self._publish()
            return
        self._update_running()
        self._publish()

    def tick(self, t: float) -> None:
        """Mission time ``t`` passed (the runner's round): publish again, with the running
        tasks' time left and progress, if ``every`` seconds passed since the last time."""
        if self.since and self.start is not None and t - self.published_at >= self.every:
            self.t = max(self.t, t - self.start)
            self.clock = self.vehicle_time(t) if self.vehicle_time else t
            self._publish()

    def _publish(self) -> None:
        self.published_at = self.t + (self.start or 0.0)
        if self.publish is not None:
            self.publish(self.view())

    def _update_running(self) -> bool:
        """Take the running tasks off the marking; whether they changed."""
        marking = self.player.marking
        running = {call for index, call in self._run_places if marking[index]}
        if running == self.since.keys():
            return False
        for call in list(self.since):
            if call not in running:
                del self.since[call]
        for call in running:
            self.since.setdefault(call, self.t)
        return True

    def running(self) -> list[dict[str, Any]]:
        """The running tasks in source order: since when, their bound and the time left of
        it, their behaviours' progress."""
        told = self.progress() if self.progress is not None else {}
        out: list[dict[str, Any]] = []
        for call, since in sorted(self.since.items(), key=lambda kv: _source_order(kv[0])):
            entry: dict[str, Any] = {"task": call, "since": round(since, 3)}
            bound = self.bounds.get(call)
            if bound is not None:
                entry["bound"] = bound
                entry["left"] = round(max(0.0, since + bound - self.t), 1)
            for behaviour, task in self.player.behaviours_on.items():
                if task == call and isinstance(told.get(behaviour), dict):
                    entry["progress"] = told[behaviour]
            out.append(entry)
        return out

    def view(self) -> dict[str, Any]:
        """The status now (JSON-ready)."""
        snap = self.player.snapshot()
        return {"v": VERSION, "mission": self.mission, "run": self.run,
                "t": round(self.t, 3), "clock": round(self.clock, 3), "status": snap["status"],
                "running": self.running(),
                "done": len(self.started - self.since.keys()), "total": self.total,
                "behaviours": snap["behaviours_on"], "fired": snap["fired"],
                "last_event": self.last_event, "last_action": self.last_action}
