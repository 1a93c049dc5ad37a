"""The execution rules of a mission net, in one place: read by the player, the replay, the
mission status and the verifier's model, so that what is proved is what runs.

- *Roles* come from the places' typed roles (set by the templates), never from names.
- *Enabled*, *fire*: the P/T firing rule.
- *Kinds of transition*: immediate (no event, no timer), timed (``timer`` seconds, or a
  mission parameter's name), event-driven (``event``); ``Mission.abort`` is the external stop
  (:data:`MISSION_ABORT`, defined here only: the mission template and the analyses import it).
- *Timers*: a timed transition's clock starts when it becomes enabled, keeps running while it
  stays enabled, and is dropped when a firing disables it (:meth:`Semantics.rearm`); it falls
  due :meth:`Semantics.seconds` after it started.
- *Priority*: immediate transitions fire before any timer or event; among them, those that
  touch an ``abort`` place first (a block being stopped starts nothing new in that instant),
  then by index.
- *Behaviours*: a behaviour is on while some marked place holds it (a running task's place, a
  latched behaviour's "on" place). A ``disable`` is sent only when its firing leaves no holder:
  a watcher held by several tasks stays on until the last lets go.
- *End*: the mission has ended when its ``end-ok`` or ``end-fail`` place is marked. A
  behaviour still on then is switched off by the player (the *cleanup*, the last line of
  defence), which the run log records as a ``cleanup`` record naming them.
"""

from __future__ import annotations

from collections.abc import Iterable, MutableSequence, Sequence
from typing import Any

from petri.net import ABORT, END_FAIL, END_OK, LATCH_OFF, LATCH_ON, RUN, STOP_HANDLER, Net

MISSION_ABORT = "Mission.abort"  # the external stop: operator, uncaught Link.lost, a limit
LINK_LOST = "Link.lost"
# At one mission instant, past this many firings a loop spins without time passing (a vehicle
# that answers at once): the player stops the mission, and the verifier's instant-loop says so.
MAX_FIRINGS_PER_INSTANT = 10_000

Marking = Sequence[int]


class Semantics:
    """What the rules need of one net, indexed once."""

    def __init__(self, net: Net):
        self.net = net
        places, transitions = net.places, net.transitions
        self.inputs = [t.inputs for t in transitions]  # the arcs, read at every firing
        self.outputs = [t.outputs for t in transitions]
        aborts = set(net.places_with(ABORT))
        self.immediate = [t.immediate for t in transitions]
        # the order in which enabled immediate transitions fire: aborts first, then by index
        self.rank = [(0 if any(p in aborts for p, _ in t.inputs + t.outputs) else 1, i)
                     for i, t in enumerate(transitions)]
        self.timed = [i for i, t in enumerate(transitions) if t.timer is not None]
        self.waiting: dict[str, list[int]] = {}
        for i, t in enumerate(transitions):
            if t.event is not None:
                self.waiting.setdefault(t.event, []).append(i)
        self.stops = self.waiting.get(MISSION_ABORT, [])
        self.readers: list[list[int]] = [[] for _ in places]  # transitions reading a place
        for i, t in enumerate(transitions):
            for p, _ in t.inputs:
                self.readers[p].append(i)
        self.timers_reading = [[r for r in rs if transitions[r].timer is not None]
                               for rs in self.readers]
        self.ends = {p: "ok" for p in net.places_with(END_OK)} | {
            p: "fail" for p in net.places_with(END_FAIL)}
        self.latch_states = net.places_with(LATCH_OFF, LATCH_ON)
        self.run_places = net.places_with(RUN)
        self.stop_handler = net.places_with(STOP_HANDLER)  # marked while ON STOP runs
        self.holders: dict[str, list[int]] = {}  # behaviour -> the places that hold it on
        for p, place in enumerate(places):
            for b in place.behaviours:
                self.holders.setdefault(b, []).append(p)

    # -- the firing rule ---------------------------------------------------------------------
    def enabled(self, marking: Marking, t: int) -> bool:
        """Every input place of ``t`` holds at least its arc's weight."""
        return all(marking[p] >= w for p, w in self.inputs[t])

    def fire(self, marking: MutableSequence[int], t: int) -> None:
        """Fire ``t`` (enabled) in place: take its inputs' weights, add its outputs'. A
        ``bytearray`` marking raises ValueError where a place would exceed 255 tokens."""
        for p, w in self.inputs[t]:
            marking[p] -= w
        for p, w in self.outputs[t]:
            marking[p] += w

    def initial(self) -> list[int]:
        marking = [0] * len(self.net.places)
        for p, n in self.net.initial.items():
            marking[p] = n
        return marking

    # -- time -------------------------------------------------------------------------------
    def delay(self, t: int, params: dict[str, Any]) -> float | None:
        """A timed transition's delay in seconds; None if its timer names a mission parameter
        that has no value (a number) in ``params``. ValueError if the delay is not a finite
        number >= 0 (the player refuses to run such a timer)."""
        timer = self.net.transitions[t].timer
        if isinstance(timer, str):
            value = params.get(timer)
            if isinstance(value, bool) or not isinstance(value, (int, float)):
                return None
            timer = float(value)
        assert timer is not None, f"{self.net.transitions[t].name} has no timer"
        if not 0.0 <= float(timer) < float("inf"):
            raise ValueError(f"timer of {timer} s: a duration must be finite and >= 0")
        return float(timer)

    def seconds(self, t: int, params: dict[str, Any]) -> float:
        """A timed transition's delay; a parameter's value must be a finite number >= 0."""
        seconds = self.delay(t, params)
        if seconds is None:
            raise ValueError(f"timer parameter {self.net.transitions[t].timer!r} has no value")
        return seconds

    def rearm(self, marking: Marking, since: dict[int, float], now: float,
              fired: int | None = None) -> None:
        """Keep the timers' clocks, ``since`` (timed transition -> the time it became
        enabled), up to date at ``now``: a timer enabled keeps its start, or starts now; one
        not enabled is dropped. ``fired``: only the timers that read a place the firing of
        that transition touched (the others' enabling has not changed)."""
        if fired is None:
            timers: Iterable[int] = self.timed
        else:
            timers = {r for p, _ in self.inputs[fired] + self.outputs[fired]
                      for r in self.timers_reading[p]}
        for t in timers:
            if self.enabled(marking, t):
                since.setdefault(t, now)
            else:
                since.pop(t, None)

    def zero_time(self, t: int, params: dict[str, Any] | None = None) -> bool:
        """Fires without time passing: immediate, or a timer of 0 s (a parameter without a
        value counts as possibly 0)."""
        tr = self.net.transitions[t]
        if tr.immediate:
            return True
        if tr.timer is None:
            return False
        if isinstance(tr.timer, str):
            value = (params or {}).get(tr.timer)
            return not isinstance(value, (int, float)) or float(value) == 0.0
        return float(tr.timer) == 0.0

    # -- behaviours and the end ---------------------------------------------------------------
    def held(self, marking: Marking, behaviour: str) -> list[int]:
        """The marked places that hold ``behaviour`` on."""
        return [p for p in self.holders.get(behaviour, ()) if marking[p] > 0]

    def behaviours_on(self, marking: Marking) -> list[str]:
        return sorted(b for b, ps in self.holders.items() if any(marking[p] > 0 for p in ps))

    def end_status(self, marking: Marking) -> str | None:
        """"ok" or "fail" once the mission has ended, else None."""
        for p, status in self.ends.items():
            if marking[p] > 0:
                return status
        return None

    def running_tasks(self, marking: Marking) -> list[str]:
        """The task calls running (``GoTo@12:9``), from the marked ``run`` places."""
        return sorted({block_of(self.net.places[p].name) for p in self.run_places
                       if marking[p] > 0})


def block_of(name: str) -> str:
    """'GoTo@12:9.start' -> 'GoTo@12:9' (the block a transition or place belongs to)."""
    return name.split(".", 1)[0]
