"""What every adapter to a vehicle in another process shares (Zenoh, MAVLink): the vehicle's
clock followed, an inbox of events, and ``Link.lost`` raised once.

The clock. The player runs on the vehicle's clock: the last vehicle time heard (``base_t``,
at monotonic ``base_wall``), run on at ``speed`` times wall time for at most
``max_extrapolation`` wall seconds, so that a stalled vehicle does not run the player's clock
far ahead. After ``Link.lost`` it runs on wall time x the last speed, without bound, so that
the player's timers and time limits still end the run. ``now()`` never goes back, and the
events an adapter makes itself are stamped with the same reading (``now_locked``), so that
none is delivered before the time it says it was raised.

The inbox. Adapters put events in from their own threads (:meth:`deliver`); ``receive(until)``
takes them out, waiting for the first at most until the clock reads ``until`` and never longer
than ``max_poll`` wall seconds.

A subclass feeds both through public names, since it lives in another module: ``lock``,
``inbox``, ``base_t``, ``speed``, ``clock_running``, the ``*_locked`` methods (called with
``lock`` held) and ``link_lost(reason)``.
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
        # What a subclass shares (public, not _private: it lives in another module):
        self.lock = threading.Lock()  # the clock, the sequence numbers, and a subclass's state
        self.inbox: queue.Queue[EventMessage] = queue.Queue()  # the events receive() returns
        self.base_t = 0.0  # the last vehicle time heard (at monotonic _base_wall)
        self.speed = 1.0  # vehicle s per wall s
        self.clock_running = False  # the vehicle's clock runs (heard, and not paused)
        self._max_seq = -1  # the highest event seq delivered
        self._base_wall = time.monotonic()
        self._last_now = 0.0
        self._lost = False
        self.lost_at: float | None = None  # monotonic time Link.lost was raised
        self.lost_reason = ""

    # -- the clock (call with self.lock held) ---------------------------------------------------
    def vehicle_time_locked(self) -> float:
        """The vehicle's clock now, as followed (lock held)."""
        if not self.clock_running:
            return self.base_t
        elapsed = time.monotonic() - self._base_wall
        if not self._lost:
            elapsed = min(elapsed, self.max_extrapolation)
        return self.base_t + elapsed * self.speed

    def set_clock_locked(self, t: float, speed: float | None = None,
                         running: bool = True) -> None:
        """The vehicle said its clock reads ``t`` (now), running at ``speed`` x wall (lock
        held)."""
        self.base_t, self._base_wall, self.clock_running = t, time.monotonic(), running
        if speed is not None:
            self.speed = speed

    def now_locked(self) -> float:
        """The vehicle's clock now, as followed, never going back (lock held): what
        :meth:`now` answers, and what an adapter stamps the events it makes itself with. The
        followed clock alone can go back (an extrapolation the next reading of the vehicle's
        clock undercuts); an event stamped with it could then be delivered at an earlier
        mission time than it says it was raised, which ``mcl replay`` rightly refuses."""
        self._last_now = max(self._last_now, self.vehicle_time_locked())
        return self._last_now

    def now(self) -> float:
        with self.lock:
            return self.now_locked()

    # -- events -----------------------------------------------------------------------------------
    def next_seq_locked(self) -> int:
        """The sequence number of an event the adapter makes itself (lock held)."""
        self._max_seq += 1
        return self._max_seq

    def deliver(self, event: EventMessage) -> None:
        """Put an event in the inbox (any thread)."""
        with self.lock:
            self._max_seq = max(self._max_seq, event.seq)
        self.inbox.put(event)

    def link_lost(self, reason: str) -> None:
        """Raise ``Link.lost`` once; from then on the clock runs on wall time."""
        with self.lock:
            if self._lost:
                return
            t = self.now_locked()
            event = EventMessage(self.next_seq_locked(), t, "Link", "lost", {"reason": reason})
            # The event is in the inbox before ``lost`` reads true (``lost`` takes no lock):
            # whoever sees ``lost`` finds Link.lost waiting in receive().
            self.lost_at, self.lost_reason = time.monotonic(), reason
            self.inbox.put(event)
            self._lost = True
            self.set_clock_locked(t)
        log.warning("link to the vehicle lost: %s", reason)

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
                events.append(self.inbox.get_nowait())
                continue
            except queue.Empty:
                pass
            if events:
                return events
            remaining = wall_end - time.monotonic()
            with self.lock:
                speed = self.speed if self.clock_running else 0.0
            ahead = until - self.now()
            if remaining <= 0 or ahead <= 0:
                return events
            wait = remaining if speed <= 0 else min(remaining, ahead / speed)
            try:
                events.append(self.inbox.get(timeout=max(wait, 1e-4)))
            except queue.Empty:
                return events

    def idle(self) -> bool:
        return False  # a real vehicle may always say something
