"""The in-process adapter: a vehicle stack in the same Python process, in simulated time.

Messages still cross as JSON and are validated on receipt, exactly as over a network, so the
schemas are exercised even here. The clock is simulated: ``receive(until)`` jumps it to the
next event the stack has scheduled, or to ``until`` if none comes before.
"""

from __future__ import annotations

import logging
import time
from typing import Protocol

from .aal import ActionMessage, EventMessage, InvalidMessage

log = logging.getLogger(__name__)


class SimulatedStack(Protocol):
    def on_action(self, action: ActionMessage, now: float) -> None: ...
    def next_time(self) -> float | None: ...
    def due(self, t: float) -> list[EventMessage]: ...


class InProcess:
    """Adapter to a simulated vehicle stack (e.g. :class:`ScriptedVehicle`)."""

    simulated = True  # its clock jumps to the next event: the runner need not poll

    def __init__(self, stack: SimulatedStack, start: float = 0.0, speed: float | None = None):
        """``speed``: run the simulated clock at this many times wall time (1: real time);
        None: as fast as possible."""
        self.stack = stack
        self._now = start
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
        nxt = self.stack.next_time()
        if nxt is None or nxt > until:
            self._now = max(self._now, until)
            return []
        self._now = max(self._now, nxt)
        if self.speed:  # hold the simulated clock back to wall time
            ahead = self._now / self.speed - (time.monotonic() - self._wall0)
            if ahead > 0:
                time.sleep(min(ahead, 1.0))
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
