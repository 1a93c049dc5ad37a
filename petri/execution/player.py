"""The real-time Petri-net player (paper 002 §3.2): it runs the very net that was verified.

It holds the marking, fires transitions, sends their actions, and waits for events and
timers. The rules, in order of precedence:

1. *Immediate* transitions (no event, no timer) fire as soon as they are enabled, until none
   is enabled: those that carry an abort first (they put a token in, or take one from, an
   ``abort`` place), then the others, lowest index first. Aborts first means a block that is
   being stopped does not start anything new in the same instant. A firing sends its actions
   in the same step, so a task's stop actions always go out before its block reports back
   (docs/SEMANTICS.md §2).
2. A *timed* transition fires when it has been enabled without interruption for its time, at
   that time: timers that fall due before an event are fired before the event is handled.
3. An *event* fires every transition enabled and waiting for it, lowest index first, each at
   most once (one that an earlier firing of the same event disabled does not fire). An event
   nobody waits for is logged and ignored; ``Link.lost`` that no block waits for aborts the
   mission (the ``Mission.abort`` transition).
4. *No spinning at one instant*: past ``max_firings_per_instant`` firings at one mission
   instant (a loop whose events a vehicle answers at once, so that mission time never moves),
   or when one transition would fire twice in one chain of immediate firings, the player aborts
   the mission and says why in :attr:`Player.zeno` (the run's end record: ``how: "zeno"``).

Time comes from outside (``now`` arguments): simulated time and wall time run the same code.
The same events at the same times give the same firings. The rules themselves (enabled, fire,
priority, timers, holders) are :class:`petri.semantics.Semantics`'s; the player applies them.

What leaves the player:

- *Orders* for the vehicle go into its :attr:`Player.outbox`, in the order they are decided;
  whoever runs the player (petri/execution/runner.py) drains it and sends them.
- *Records* of everything it does go to its observers (see :class:`Record`), which only
  observe. A firing is one step: its marking, its orders in the outbox and its timers are
  complete before any observer hears of it, so an observer reads a settled player. An
  observer that raises (a run log on a full disk) stops neither the other observers nor the
  player: the call under way (``start``, ``settle``, ``handle_event``, ``abort``, ...) runs to
  its end, and then the first such exception propagates to the caller, whose safe exit can
  abort the run from a player that is whole. How records reach the observers, and these two
  promises, are petri/execution/reporting.py's.
"""

from __future__ import annotations

import heapq
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any, NamedTuple

from petri.execution.reporting import Observer, Record, Reporting, whole
from petri.net import Action, Net, resolve
from petri.semantics import (
    LINK_LOST,
    MAX_FIRINGS_PER_INSTANT,
    MISSION_ABORT,
    Semantics,
    block_of,
)

MAX_IMMEDIATE_FIRINGS = 1_000_000  # per step: a bound on any loop, never reached by a sound net

__all__ = ["LINK_LOST", "MAX_FIRINGS_PER_INSTANT", "MISSION_ABORT", "Order", "Player", "Record"]


class Order(NamedTuple):
    """An action the player has decided to send to the vehicle, as it waits in the outbox:
    ``kind`` enable, disable or configure; ``params`` resolved; ``task`` the task call that
    sends it (``MISSION`` for the player's own switch-off). A tuple: made at every action."""

    t: float
    task: str
    kind: str
    behaviour: str
    params: dict[str, Any]


@dataclass
class Player:
    """The player of one compiled net: its marking, its timers' clocks, the behaviours it has
    switched on, its status, and the outbox of orders for the vehicle (the module's doc)."""

    net: Net
    params: dict[str, Any] = field(default_factory=dict)  # values of unresolved parameters
    # who hears the records: append to (or remove from) this list, which the reporting reads
    observers: list[Observer] = field(default_factory=list)
    marking: list[int] = field(init=False)
    enabled_since: dict[int, float] = field(init=False, default_factory=dict)
    behaviours_on: dict[str, str] = field(init=False, default_factory=dict)  # -> task
    status: str = field(init=False, default="ready")  # ready | running | ok | fail
    fired: int = field(init=False, default=0)
    # the orders not yet taken by whoever runs the player (the runner drains it)
    outbox: deque[Order] = field(init=False, default_factory=deque)
    # how the records reach the observers (petri/execution/reporting.py)
    reporting: Reporting = field(init=False, repr=False, compare=False)
    # past this many firings at one mission instant the mission is aborted (rule 4)
    max_firings_per_instant: int = MAX_FIRINGS_PER_INSTANT
    # why the player aborted a loop that went round without time passing (None: it did not)
    zeno: str | None = field(init=False, default=None)
    ordered: int = field(init=False, default=0)  # the orders ever put in the outbox
    zeno_ordered: int = field(init=False, default=0)  # ... before the abort of such a loop
    # where a fleet's "send" actions go (Send(CHANNEL, MESSAGE)): the fleet's channels, never
    # the vehicle. Each gets an Order of kind "send", behaviour the channel, params
    # {"message": ...}. None: a net that sends refuses to start (it needs a fleet).
    sender: Callable[[Order], None] | None = None

    def __post_init__(self) -> None:
        self.rules = Semantics(self.net)
        self.marking = self.rules.initial()
        self._candidates = [self.rules.rank[i] for i, im in enumerate(self.rules.immediate)
                            if im]
        heapq.heapify(self._candidates)  # a heap of (rank, index)
        self._queued = {i for _, i in self._candidates}
        self._clock = float("-inf")  # the time of the last firing: never goes back
        self._instant: dict[int, float] = {}  # transition -> the instant it last fired at
        self.reporting = Reporting(self.observers)
        self._instant_at = float("-inf")  # the mission instant of the last firing...
        self._instant_firings = 0  # ...and how many firings it has seen

    # -- the three ways a transition fires -------------------------------------------------
    @whole
    def start(self, now: float) -> None:
        if self.sender is None and self.sends():
            raise ValueError(f"{self.net.name} sends messages ({', '.join(self.sends())}): it "
                             "runs in its fleet, with the fleet's channels (mcl run FLEET.mcl)")
        self.status = "running"
        self._clock = now
        self._emit(now, "status", {"status": "running"})
        self._arm_timers(now)
        self.settle(now)

    def enabled(self, t: int) -> bool:
        return self.rules.enabled(self.marking, t)

    @whole
    def settle(self, now: float, before: bool = False) -> None:
        """Fire immediate transitions and the timers due by ``now`` (``before``: due strictly
        before it), in time order, until nothing more can fire. A transition that would fire
        twice in one instant means a loop that goes round without time passing (a Zeno
        cycle, which ``mclc`` refuses): the player aborts the mission instead of spinning."""
        for _ in range(MAX_IMMEDIATE_FIRINGS):
            if self.finished:
                break
            t = self._next_immediate()
            cause = "immediate"
            if t is None:
                due = self._next_timer(now - 2e-9 if before else now)
                if due is None:
                    break
                t, when = due
                self._clock = max(self._clock, when)
                cause = "timer"
            if self._instant.get(t) == self._clock and self.status == "running":
                tr = self.net.transitions[t]
                where = f" at line {tr.origin.line}" if tr.origin else ""
                self._stop_spinning(f"a loop goes round without time passing ({tr.name}"
                                    f"{where} fires twice at {self._clock:g} s)")
                break
            if self._spinning(t):
                break
            self._instant[t] = self._clock
            self._fire(t, self._clock, cause)
            self._check_end(self._clock)
        else:
            self.abort(self._clock, "more than a million firings without time passing")
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

    @whole
    def handle_event(self, event: str, now: float, data: dict[str, Any] | None = None,
                     raised: float | None = None) -> int:
        """Fire what waits for ``event``; returns how many transitions fired. ``raised``: the
        vehicle's clock when it raised the event, which the event record keeps (``vt``).

        Timers due before the event fire first. A timer due at the very instant of the event
        is a tie: the event goes first if some transition waits for it; if none does yet, the
        tied timers fire and the event is offered again (a watcher that a timer starts in
        that instant still gets it: no event is lost to a tie)."""
        self.settle(now, before=True)
        self._clock = max(self._clock, now)
        when = {} if raised is None else {"vt": raised}  # its time on the vehicle's clock
        if self.finished:
            self._emit(now, "ignored", {"event": event, "reason": "the mission has ended",
                                        **when})
            return 0
        waiting = self._waiting_for(event)
        if not waiting:
            self.settle(now)  # the ties
            waiting = [] if self.finished else self._waiting_for(event)
        if not waiting and event == LINK_LOST and not self.finished:
            waiting = [t for t in self.rules.stops if self.enabled(t)]
            if waiting:
                self._emit(now, "note", {"note": "Link.lost and no block catches it: the "
                                                 "mission is aborted"})
        if not waiting:
            reason = "the mission has ended" if self.finished else "nobody waits for it"
            self._emit(now, "ignored", {"event": event, "reason": reason, **when})
            return 0
        self._emit(now, "event", {"event": event, "data": data or {}} if raised is None else
                   {"event": event, "data": data or {}, "vt": raised})
        self._instant.clear()  # an event starts a new chain of firings in this instant
        count = 0
        for t in waiting:
            if self._spinning(t):
                return count
            if self.enabled(t):
                self._instant[t] = self._clock
                self._fire(t, now, event)
                count += 1
        self.settle(now)
        return count

    def _waiting_for(self, event: str) -> list[int]:
        return [t for t in self.rules.waiting.get(event, []) if self.enabled(t)]

    def _spinning(self, t: int) -> bool:
        """Would firing ``t`` now pass the bound of firings at one instant (rule 4)? If so,
        the mission is aborted (and True)."""
        if self._clock != self._instant_at or self.status != "running":
            return False
        if self._instant_firings < self.max_firings_per_instant:
            return False
        tr = self.net.transitions[t]
        where = f" (line {tr.origin.line})" if tr.origin else ""
        self._stop_spinning(f"more than {self.max_firings_per_instant:,} firings at "
                            f"{self._clock:g} s of mission time: a loop goes round without "
                            f"time passing, the next was {tr.name}{where}")
        return True

    def _stop_spinning(self, reason: str) -> None:
        self.zeno, self.zeno_ordered = reason, self.ordered
        self.abort(self._clock, reason)

    @whole
    def abort(self, now: float, reason: str) -> None:
        """Stop the mission from outside (an operator, a limit, a signal, a lost link): the
        ``Mission.abort`` transition fires, the blocks stop their tasks and switch their
        latched behaviours off (immediate firings, all at ``now``), and the mission ends fail.
        Anything still on after that is switched off too. Does nothing once it has ended.

        A mission with a stop handler (MCL's ``ON STOP``) does not end there: the handler
        starts (:attr:`handling`), and the mission ends when it does; a second abort while it
        runs aborts the handler in turn (the net's ``MISSION.halt``), and the mission ends."""
        if self.finished:
            return
        self._clock = max(self._clock, now)
        self._emit(self._clock, "note", {"note": f"mission aborted: {reason}"})
        if self.status == "running":
            for t in self.rules.stops:
                if self.enabled(t):
                    self._fire(t, self._clock, "abort")
            self._settle_immediate()
            if self.handling:  # the mission's stop handler runs now; a second abort stops it
                self._instant_firings = 0  # its firings count afresh
                return
        self.status = "running"  # so that _check_end reports (and switches off what is on)
        self._check_end(self._clock)
        if not self.finished:  # the net could not end (a bug, or not started): end it here
            with self.reporting.step():
                self._switch_off(self._clock)
                self.status = "fail"
                self._emit(self._clock, "status", {"status": "fail"})

    @property
    def handling(self) -> bool:
        """The mission's stop handler is running (after an abort, until it ends)."""
        return any(self.marking[p] for p in self.rules.stop_handler)

    @whole
    def note_ignored(self, event: str, now: float, reason: str) -> None:
        """Record that an event was not handled (a runner dropping a duplicate, say): it
        fires nothing."""
        self._emit(now, "ignored", {"event": event, "reason": reason})

    def _settle_immediate(self) -> None:
        for _ in range(MAX_IMMEDIATE_FIRINGS):
            t = self._next_immediate()
            if t is None:
                return
            self._fire(t, self._clock, "immediate")

    @whole
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
        return self.rules.seconds(t, self.params)

    def _arm_timers(self, now: float) -> None:
        self.rules.rearm(self.marking, self.enabled_since, now)

    # -- firing ---------------------------------------------------------------------------
    def _fire(self, t: int, now: float, cause: str) -> None:
        """One step: the marking, the orders in the outbox, the candidates and the timers,
        and only then the records to the observers."""
        tr = self.net.transitions[t]
        rules = self.rules
        reporting = self.reporting
        reporting.steps += 1  # as reporting.step(), written out: the player's hot path
        try:
            rules.fire(self.marking, t)
            self.fired += 1
            if now != self._instant_at:  # time has passed: a new instant
                self._instant_at, self._instant_firings = now, 0
            self._instant_firings += 1
            task = block_of(tr.name)
            self._emit(now, "fire", {"transition": tr.name, "index": t, "cause": cause,
                                     "label": tr.label, "construct": tr.origin.text
                                     if tr.origin else "",
                                     "line": tr.origin.line if tr.origin else None})
            for action in tr.actions:
                self._send(action, task, now)
            for p, _ in tr.outputs:
                for r in rules.readers[p]:
                    if rules.immediate[r] and r not in self._queued:
                        heapq.heappush(self._candidates, rules.rank[r])
                        self._queued.add(r)
            rules.rearm(self.marking, self.enabled_since, now, fired=t)
        finally:
            reporting.end_step()

    def _send(self, action: Action, task: str, now: float, last_resort: bool = False) -> None:
        """Send an action. A ``disable`` that leaves another holder of the behaviour (a
        watcher shared by several tasks, a latch) is not sent: it stays on until the last
        holder lets go. ``last_resort``: the player's own switch-off at the end."""
        params = {k: self._resolve(v) for k, v in action.params}
        if action.kind == "send":  # a fleet's message: to its channel, never to the vehicle
            if self.sender is None:
                raise ValueError(f"{task} sends on {action.behaviour}: no channel to send on")
            self.sender(Order(now, task, "send", action.behaviour, params))
            self._emit(now, "action", {"action": "send", "behaviour": action.behaviour,
                                       "params": params, "task": task})
            return
        if action.kind == "disable":
            holders = [] if last_resort else self.rules.held(self.marking, action.behaviour)
            if holders:
                names = ", ".join(block_of(self.net.places[p].name) for p in holders)
                self._emit(now, "note", {"note": f"{action.behaviour} stays on: still held "
                                                 f"by {names}", "task": task})
                return
            self.behaviours_on.pop(action.behaviour, None)
        elif action.kind == "enable":
            self.behaviours_on[action.behaviour] = task
        self.outbox.append(Order(now, task, action.kind, action.behaviour, params))
        self.ordered += 1
        self._emit(now, "action", {"action": action.kind, "behaviour": action.behaviour,
                                   "params": params, "task": task})

    def _resolve(self, value: Any) -> Any:
        if isinstance(value, dict) and "param" in value and value["param"] not in self.params:
            raise ValueError(f"parameter {value['param']!r} has no value")
        return resolve(value, self.params)

    def _check_end(self, now: float) -> None:
        if self.status != "running":
            return
        status = self.rules.end_status(self.marking)
        if status is None:
            return
        with self.reporting.step():  # the end: its status, the cleanup and its orders
            self.status = status
            if self.behaviours_on:  # the last line of defence (docs/SEMANTICS.md)
                left = ", ".join(sorted(self.behaviours_on))
                self._emit(now, "note", {"note": f"switching off behaviours left on at the "
                                                 f"end: {left}"})
                self._switch_off(now)
            self._emit(now, "status", {"status": status})

    def _switch_off(self, now: float) -> None:
        """The cleanup: a ``cleanup`` record naming what is still on, then a disable of each
        (sent whatever holds it: the mission is over)."""
        left = sorted(self.behaviours_on)
        if not left:
            return
        self._emit(now, "cleanup", {"behaviours": left})
        for b in left:
            self._send(Action("disable", b), "MISSION", now, last_resort=True)

    # -- telling the observers --------------------------------------------------------------
    def _emit(self, now: float, kind: str, data: dict[str, Any]) -> None:
        self.reporting.emit(Record(now, kind, data))

    def sends(self) -> list[str]:
        """The channels this net's "send" actions go to (a fleet's vehicle), sorted."""
        return sorted({a.behaviour for t in self.net.transitions for a in t.actions
                       if a.kind == "send"})

    # -- for observers ----------------------------------------------------------------------
    @property
    def finished(self) -> bool:
        return self.status in ("ok", "fail")

    def snapshot(self) -> dict[str, Any]:
        """The current marking, running tasks and enabled behaviours (for monitors)."""
        marked = [self.net.places[p].name for p, n in enumerate(self.marking) if n]
        return {"status": self.status, "marking": marked,
                "running_tasks": self.rules.running_tasks(self.marking),
                "behaviours_on": sorted(self.behaviours_on), "fired": self.fired}
