"""The in-process adapter: a vehicle stack in the same Python process, in simulated time.

Messages still cross as JSON and are validated on receipt, exactly as over a network, so the
schemas are exercised even here. The clock is simulated: ``receive(until)`` jumps it to the
next event the stack has scheduled, or to ``until`` if none comes before.
"""

from __future__ import annotations

import logging
import time
from typing import Any, Protocol

from aal.messages import ActionMessage, Declaration, EventMessage, InvalidMessage
from behaviours.base import progress_of

log = logging.getLogger(__name__)

MAX_WAIT = 0.2  # wall s: the longest single wait of a real-time run


class SimulatedStack(Protocol):
    def on_action(self, action: ActionMessage, now: float) -> None: ...
    def next_time(self) -> float | None: ...
    def due(self, t: float) -> list[EventMessage]: ...


class InProcess:
    """Adapter to a simulated vehicle stack (e.g. :class:`ScriptedVehicle`)."""

    simulated = True  # its clock jumps to the next event: the runner need not poll

    def __init__(self, stack: SimulatedStack, start: float = 0.0, speed: float | None = None,
                 declaration: Declaration | None = None):
        """``speed``: run the simulated clock at this many times wall time (1: real time);
        None: as fast as possible. ``declaration``: what the stack can do (its behaviours and
        events, in the task library's form)."""
        self.stack = stack
        self._declaration = declaration
        self._now = self._start = start
        self.speed = speed
        self._wall0 = time.monotonic()
        self.dropped = 0  # invalid messages received and dropped

    def __enter__(self) -> InProcess:
        return self

    def __exit__(self, *exc: object) -> None:
        return None

    def now(self) -> float:
        return self._now

    def send(self, action: ActionMessage) -> None:
        try:
            received = ActionMessage.from_json(action.to_json())
        except InvalidMessage as exc:  # the stack drops what it cannot read
            log.warning("vehicle dropped an invalid action: %s", exc)
            self.dropped += 1
            return
        self.stack.on_action(received, self._now)

    def receive(self, until: float) -> list[EventMessage]:
        """With ``speed``, the clock is held back to wall time: it waits at most
        ``MAX_WAIT`` wall seconds and returns (perhaps nothing, the clock advanced as far as
        wall time allows), so that the caller can look at other things (a stop) meanwhile."""
        nxt = self.stack.next_time()
        target = until if nxt is None or nxt > until else nxt
        if self.speed:  # hold the simulated clock back to wall time
            ahead = (target - self._start) / self.speed - (time.monotonic() - self._wall0)
            if ahead > 0:
                time.sleep(min(ahead, MAX_WAIT))
                reached = self._start + (time.monotonic() - self._wall0) * self.speed
                if reached < target:
                    self._now = max(self._now, reached)
                    return []
        if nxt is None or nxt > until:
            self._now = max(self._now, until)
            return []
        self._now = max(self._now, nxt)
        events = []
        for event in self.stack.due(self._now):
            try:
                events.append(EventMessage.from_json(event.to_json()))
            except InvalidMessage as exc:
                log.warning("player dropped an invalid event: %s", exc)
                self.dropped += 1
        return events

    def idle(self) -> bool:
        return self.stack.next_time() is None

    def declaration(self) -> Declaration | None:
        return self._declaration

    def active(self) -> list[str] | None:
        """The behaviours the stack has on (None if it cannot say)."""
        active = getattr(self.stack, "active", None)
        if callable(active):
            return sorted(active())
        behaviours: Any = getattr(self.stack, "behaviours", None)
        if isinstance(behaviours, dict):
            return sorted(n for n, b in behaviours.items() if getattr(b, "active", False))
        return None

    def progress(self) -> dict[str, Any]:
        """Each active behaviour's progress (waypoint k of n, distance to go), by its name;
        empty if the stack cannot say."""
        behaviours: Any = getattr(self.stack, "behaviours", None)
        return progress_of(behaviours.values()) if isinstance(behaviours, dict) else {}

    def confirm_off(self, names: list[str], timeout: float) -> str:
        """The stack takes actions at once: read what it has on."""
        active = self.active()
        if active is None:
            return "not confirmed: the stack cannot say what it has on"
        if active:
            return f"NOT confirmed: the vehicle still has {', '.join(active)} on"
        return "confirmed: the vehicle has no behaviour on"
