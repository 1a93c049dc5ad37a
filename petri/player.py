"""The real-time Petri-net player (paper 002 §3.2): it runs the very net that was verified.

It holds the marking, fires transitions, sends their actions, and waits for events and
timers. The rules, in order of precedence:

1. *Immediate* transitions (no event, no timer) fire as soon as they are enabled, until none
   is enabled: those that carry an abort first (they put a token in, or take one from, an
   ``abort`` place), then the others, lowest index first. Aborts first means a block that is
   being stopped does not start anything new in the same instant. A firing sends its actions
   in the same step, so a task's stop actions always go out before its block reports back
   (MCL.md's abort rule).
2. A *timed* transition fires when it has been enabled without interruption for its time, at
   that time: timers that fall due before an event are fired before the event is handled.
3. An *event* fires every transition enabled and waiting for it, lowest index first, each at
   most once (one that an earlier firing of the same event disabled does not fire). An event
   nobody waits for is logged and ignored; ``Link.lost`` that no block waits for aborts the
   mission (the ``Mission.abort`` transition).

Time comes from outside (``now`` arguments): simulated time and wall time run the same code.
The same events at the same times give the same firings. Everything the player does is
reported to its observers as records (see :class:`Record`).
"""

from __future__ import annotations

import heapq
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

from .net import Action, Net, resolve

MAX_IMMEDIATE_FIRINGS = 1_000_000  # per step: a net that loops without events is a bug
MISSION_ABORT = "Mission.abort"
LINK_LOST = "Link.lost"


@dataclass(frozen=True)
class Record:
    """One thing that happened: kind is "fire", "action", "event", "ignored", "status",
    "note". ``data`` holds the details (JSON-ready)."""

    t: float
    kind: str
    data: dict[str, Any]


@dataclass
class Player:
    net: Net
    params: dict[str, Any] = field(default_factory=dict)  # values of unresolved parameters
    observers: list[Callable[[Record], None]] = field(default_factory=list)
    marking: list[int] = field(init=False)
    enabled_since: dict[int, float] = field(init=False, default_factory=dict)
    behaviours_on: dict[str, str] = field(init=False, default_factory=dict)  # -> task
    status: str = field(init=False, default="ready")  # ready | running | ok | fail
    fired: int = field(init=False, default=0)

    def __post_init__(self) -> None:
        self.marking = [0] * len(self.net.places)
        for p, n in self.net.initial.items():
            self.marking[p] = n
        self._timed = [i for i, t in enumerate(self.net.transitions) if t.timer is not None]
        self._waiting: dict[str, list[int]] = {}
        for i, t in enumerate(self.net.transitions):
            if t.event is not None:
                self._waiting.setdefault(t.event, []).append(i)
        # transitions to re-examine when a place changes
        self._readers: list[list[int]] = [[] for _ in self.net.places]
        for i, t in enumerate(self.net.transitions):
            for p, _ in t.inputs:
                self._readers[p].append(i)
        self._immediate = [t.immediate for t in self.net.transitions]
        aborts = {p for p, place in enumerate(self.net.places) if place.name.endswith(".abort")}
        # the order in which enabled immediate transitions fire: aborts first, then by index
        self._rank = [(0 if any(p in aborts for p, _ in t.inputs + t.outputs) else 1, i)
                      for i, t in enumerate(self.net.transitions)]
        self._candidates = [self._rank[i] for i, im in enumerate(self._immediate) if im]
        heapq.heapify(self._candidates)  # a heap of (rank, index)
        self._queued = {i for _, i in self._candidates}
        self._clock = float("-inf")  # the time of the last firing: never goes back
        ends = [n for n in ("MISSION.ok", "MISSION.fail") if n in self.net._index]
        self._ends = {self.net.place(n): n.split(".")[1] for n in ends}

    # -- the three ways a transition fires -------------------------------------------------
    def start(self, now: float) -> None:
        self.status = "running"
        self._clock = now
        self._emit(now, "status", {"status": "running"})
        self._arm_timers(now)
        self.settle(now)

    def enabled(self, t: int) -> bool:
        return all(self.marking[p] >= w for p, w in self.net.transitions[t].inputs)

    def settle(self, now: float, before: bool = False) -> None:
        """Fire immediate transitions and the timers due by ``now`` (``before``: due strictly
        before it), in time order, until nothing more can fire."""
        for _ in range(MAX_IMMEDIATE_FIRINGS):
            t = self._next_immediate()
            if t is not None:
                self._fire(t, self._clock, "immediate")
                continue
            due = self._next_timer(now - 2e-9 if before else now)
            if due is None:
                break
            t, when = due
            self._clock = max(self._clock, when)
            self._fire(t, self._clock, "timer")
            self._check_end(self._clock)
        else:
            raise RuntimeError("more than a million firings without an event: the net loops")
        if not before:
            self._clock = max(self._clock, now)
        self._check_end(self._clock)

    def _next_immediate(self) -> int | None:
        # Only a transition that reads a place that gained a token can have become enabled:
        # those are the candidates, examined in rank order.
        while self._candidates:
            _, t = self._candidates[0]
            if self.enabled(t):
                return t
            heapq.heappop(self._candidates)
            self._queued.discard(t)
        return None

    def _next_timer(self, now: float) -> tuple[int, float] | None:
        """The timer that falls due first, if it falls due by ``now`` (ties: lowest index)."""
        best: tuple[float, int] | None = None
        for t, since in self.enabled_since.items():
            when = since + self._seconds(t)
            if when <= now + 1e-9 and (best is None or (when, t) < best):
                best = (when, t)
        return None if best is None else (best[1], best[0])

    def handle_event(self, event: str, now: float, data: dict[str, Any] | None = None) -> int:
        """Fire what waits for ``event``; returns how many transitions fired."""
        self.settle(now, before=True)  # timers due before the event fire first; a tie
        self._clock = max(self._clock, now)  # goes to the event, which was delivered first
        if self.finished:
            self._emit(now, "ignored", {"event": event, "reason": "the mission has ended"})
            return 0
        waiting = [t for t in self._waiting.get(event, []) if self.enabled(t)]
        if not waiting and event == LINK_LOST:
            waiting = [t for t in self._waiting.get(MISSION_ABORT, []) if self.enabled(t)]
            if waiting:
                self._emit(now, "note", {"note": "Link.lost and no block catches it: the "
                                                 "mission is aborted"})
        if not waiting:
            self._emit(now, "ignored", {"event": event, "reason": "nobody waits for it"})
            return 0
        self._emit(now, "event", {"event": event, "data": data or {}})
        count = 0
        for t in waiting:
            if self.enabled(t):
                self._fire(t, now, event)
                count += 1
        self.settle(now)
        return count

    def abort(self, now: float, reason: str) -> None:
        """Stop the mission from outside (an operator, a limit, a signal, a lost link): the
        ``Mission.abort`` transition fires, the blocks stop their tasks and switch their
        latched behaviours off (immediate firings, all at ``now``), and the mission ends fail.
        Anything still on after that is switched off too. Does nothing once it has ended."""
        if self.finished:
            return
        self._clock = max(self._clock, now)
        self._emit(self._clock, "note", {"note": f"mission aborted: {reason}"})
        if self.status == "running":
            for t in self._waiting.get(MISSION_ABORT, []):
                if self.enabled(t):
                    self._fire(t, self._clock, "abort")
            self._settle_immediate()
        self.status = "running"  # so that _check_end reports (and switches off what is on)
        self._check_end(self._clock)
        if not self.finished:  # the net could not end (a bug, or not started): end it here
            for b in sorted(self.behaviours_on):
                self._send(Action("disable", b), "MISSION", self._clock)
            self.status = "fail"
            self._emit(self._clock, "status", {"status": "fail"})

    def _settle_immediate(self) -> None:
        for _ in range(MAX_IMMEDIATE_FIRINGS):
            t = self._next_immediate()
            if t is None:
                return
            self._fire(t, self._clock, "immediate")

    def fire(self, t: int, now: float, cause: str = "replay") -> None:
        """Fire one given transition (it must be enabled): for replaying a firing sequence,
        such as a verifier's counterexample, step by step."""
        if not self.enabled(t):
            raise ValueError(f"{self.net.transitions[t].name} is not enabled")
        self._fire(t, now, cause)

    # -- time ---------------------------------------------------------------------------------
    def next_deadline(self) -> float | None:
        """When the earliest armed timer falls due (None if no timer is armed)."""
        deadlines = [since + self._seconds(t) for t, since in self.enabled_since.items()]
        return min(deadlines) if deadlines else None

    def _seconds(self, t: int) -> float:
        timer = self.net.transitions[t].timer
        if isinstance(timer, str):
            value = self.params.get(timer)
            if not isinstance(value, (int, float)):
                raise ValueError(f"timer parameter {timer!r} has no value")
            return float(value)
        assert timer is not None
        return float(timer)

    def _arm_timers(self, now: float) -> None:
        for t in self._timed:
            if self.enabled(t):
                self.enabled_since.setdefault(t, now)
            else:
                self.enabled_since.pop(t, None)

    # -- firing ---------------------------------------------------------------------------
    def _fire(self, t: int, now: float, cause: str) -> None:
        tr = self.net.transitions[t]
        for p, w in tr.inputs:
            self.marking[p] -= w
        for p, w in tr.outputs:
            self.marking[p] += w
        self.fired += 1
        task = _task_of(tr.name)
        self._emit(now, "fire", {"transition": tr.name, "index": t, "cause": cause,
                                 "label": tr.label, "construct": tr.origin.text if tr.origin
                                 else "", "line": tr.origin.line if tr.origin else None})
        for action in tr.actions:
            self._send(action, task, now)
        for p, _ in tr.outputs:
            for r in self._readers[p]:
                if self._immediate[r] and r not in self._queued:
                    heapq.heappush(self._candidates, self._rank[r])
                    self._queued.add(r)
        self._rearm_after(tr.inputs + tr.outputs, now)

    def _rearm_after(self, arcs: tuple[tuple[int, int], ...], now: float) -> None:
        touched = {t for p, _ in arcs for t in self._readers[p]
                   if self.net.transitions[t].timer is not None}
        for t in touched:
            if self.enabled(t):
                self.enabled_since.setdefault(t, now)
            else:
                self.enabled_since.pop(t, None)

    def _send(self, action: Action, task: str, now: float) -> None:
        params = {k: self._resolve(v) for k, v in action.params}
        if action.kind == "enable":
            self.behaviours_on[action.behaviour] = task
        elif action.kind == "disable":
            self.behaviours_on.pop(action.behaviour, None)
        self._emit(now, "action", {"action": action.kind, "behaviour": action.behaviour,
                                   "params": params, "task": task})

    def _resolve(self, value: Any) -> Any:
        if isinstance(value, dict) and "param" in value and value["param"] not in self.params:
            raise ValueError(f"parameter {value['param']!r} has no value")
        return resolve(value, self.params)

    def _check_end(self, now: float) -> None:
        if self.status != "running":
            return
        for p, status in self._ends.items():
            if self.marking[p] > 0:
                self.status = status
                if self.behaviours_on:  # the last line of defence (MCL.md)
                    left = sorted(self.behaviours_on)
                    self._emit(now, "note", {"note": "switching off behaviours left on at the "
                                                     f"end: {', '.join(left)}"})
                    for b in left:
                        self._send(Action("disable", b), "MISSION", now)
                self._emit(now, "status", {"status": status})
                return

    def _emit(self, now: float, kind: str, data: dict[str, Any]) -> None:
        record = Record(now, kind, data)
        for observe in self.observers:
            observe(record)

    # -- for observers ----------------------------------------------------------------------
    @property
    def finished(self) -> bool:
        return self.status in ("ok", "fail")

    def snapshot(self) -> dict[str, Any]:
        """The current marking, running tasks and enabled behaviours (for monitors)."""
        marked = [self.net.places[p].name for p, n in enumerate(self.marking) if n]
        running = sorted({_task_of(n) for n in marked if n.endswith(".run")})
        return {"status": self.status, "marking": marked, "running_tasks": running,
                "behaviours_on": sorted(self.behaviours_on), "fired": self.fired}


def _task_of(name: str) -> str:
    """'GoTo@12:9.start' -> 'GoTo@12:9' (the block a transition or place belongs to)."""
    return name.split(".", 1)[0]
