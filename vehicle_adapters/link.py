"""What every adapter to a vehicle in another process shares (Zenoh, MAVLink): the vehicle's
clock followed, an inbox of events, and ``Link.lost`` raised once.

The clock. The player runs on the vehicle's clock: the last vehicle time heard (``base_t``,
at monotonic ``base_wall``), run on at ``speed`` times wall time for at most
``max_extrapolation`` wall seconds, so that a stalled vehicle does not run the player's clock
far ahead. After ``Link.lost`` it runs on wall time x the last speed, without bound, so that
the player's timers and time limits still end the run. ``now()`` never goes back.

The inbox. Adapters put events in from their own threads (:meth:`deliver`); ``receive(until)``
takes them out, waiting for the first at most until the clock reads ``until`` and never longer
than ``max_poll`` wall seconds.
"""

from __future__ import annotations

import logging
import queue
import threading
import time

from aal.messages import EventMessage

log = logging.getLogger(__name__)

MAX_POLL = 0.2  # wall s: the longest single wait in receive()


class RemoteVehicle:
    """The base of :class:`ZenohVehicle` and :class:`MavlinkVehicle` (not used alone)."""

    simulated = False  # the runner polls with bounded waits

    def __init__(self, *, max_poll: float = MAX_POLL, max_extrapolation: float = 0.25):
        self.max_poll = max_poll
        self.max_extrapolation = max_extrapolation
        self._lock = threading.Lock()  # the clock, the sequence numbers, and a subclass's state
        self._events: queue.Queue[EventMessage] = queue.Queue()
        self._max_seq = -1  # the highest event seq delivered
        self._base_t = 0.0
        self._base_wall = time.monotonic()
        self._speed = 1.0
        self._running = False  # the vehicle's clock runs (it has been heard, and not paused)
        self._last_now = 0.0
        self._lost = False
        self.lost_at: float | None = None  # monotonic time Link.lost was raised
        self.lost_reason = ""

    # -- the clock (call with self._lock held) --------------------------------------------------
    def _vehicle_time_locked(self) -> float:
        if not self._running:
            return self._base_t
        elapsed = time.monotonic() - self._base_wall
        if not self._lost:
            elapsed = min(elapsed, self.max_extrapolation)
        return self._base_t + elapsed * self._speed

    def _clock_locked(self, t: float, speed: float | None = None, running: bool = True) -> None:
        """The vehicle said its clock reads ``t`` (now), running at ``speed`` x wall."""
        self._base_t, self._base_wall, self._running = t, time.monotonic(), running
        if speed is not None:
            self._speed = speed

    def now(self) -> float:
        with self._lock:
            self._last_now = max(self._last_now, self._vehicle_time_locked())
            return self._last_now

    @property
    def speed(self) -> float:
        return self._speed

    # -- events -----------------------------------------------------------------------------------
    def _next_seq_locked(self) -> int:
        self._max_seq += 1
        return self._max_seq

    def deliver(self, event: EventMessage) -> None:
        """Put an event in the inbox (any thread)."""
        with self._lock:
            self._max_seq = max(self._max_seq, event.seq)
        self._events.put(event)

    def _link_lost(self, reason: str) -> None:
        """Raise ``Link.lost`` once; from then on the clock runs on wall time."""
        with self._lock:
            if self._lost:
                return
            t = self._vehicle_time_locked()
            self._lost, self.lost_at, self.lost_reason = True, time.monotonic(), reason
            self._clock_locked(t)
            event = EventMessage(self._next_seq_locked(), t, "Link", "lost", {"reason": reason})
        log.warning("link to the vehicle lost: %s", reason)
        self._events.put(event)

    @property
    def lost(self) -> bool:
        return self._lost

    # -- the Vehicle protocol -------------------------------------------------------------------
    def receive(self, until: float) -> list[EventMessage]:
        """The events that have arrived; waits for the first one at most until the clock reads
        ``until`` and never longer than ``max_poll`` wall seconds."""
        events: list[EventMessage] = []
        wall_end = time.monotonic() + self.max_poll
        while True:
            try:
                events.append(self._events.get_nowait())
                continue
            except queue.Empty:
                pass
            if events:
                return events
            remaining = wall_end - time.monotonic()
            with self._lock:
                speed = self._speed if self._running else 0.0
            ahead = until - self.now()
            if remaining <= 0 or ahead <= 0:
                return events
            wait = remaining if speed <= 0 else min(remaining, ahead / speed)
            try:
                events.append(self._events.get(timeout=max(wait, 1e-4)))
            except queue.Empty:
                return events

    def idle(self) -> bool:
        return False  # a real vehicle may always say something
