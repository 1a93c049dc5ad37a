"""The loop that runs a player against a vehicle: it owns time, and every way out of it.

Each round: settle the player (immediate firings, due timers), then wait for the vehicle's
events until the next timer falls due — in simulated time the clock jumps there; in wall time
the wait is real but bounded. After each call of the player (start, an event, a settle, the
abort) the runner drains the player's outbox and sends its orders to the vehicle, in order;
the player's observers (the run log, a monitor) only observe.

One clock for people: the player runs on *mission time*, which counts from the mission's
start (0 s); the vehicle's clock at that start is the :class:`MissionClock`'s ``origin``, so
that a second mission on a vehicle that has been running for 1400 s still starts at 0 s.

Every exit is a safe exit. The run ends when the mission ends (ok or fail), and otherwise
*through* :meth:`Player.abort` — the net's ``Mission.abort``, so that the blocks stop their
tasks and switch their latches off, then the player switches off anything left — when:

- the mission time limit is reached (at the limit itself, never at the next timer after it);
- nothing can happen any more (no timer armed and the vehicle idle: "stuck");
- ``stop()`` asks for it (a signal, an operator);
- the vehicle or its adapter raised an exception (sending, receiving, reading its clock);
- an observer of the player raised one (the run log on a full disk): the player finishes
  the call under way first, so the net is never left half-fired;
- the player itself aborted a loop that went round without mission time passing
  (:attr:`Player.zeno`; its bound ``max_firings_per_instant``): the outcome is ``zeno``.

After an abort the vehicle is given a bounded time (``confirm`` wall seconds) to confirm that
what was switched off is off, where its link can say so (``vehicle.confirm_off``).
"""

from __future__ import annotations

import itertools
import logging
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

from aal.messages import ActionMessage, EventMessage, Vehicle

from petri.execution.player import Order, Player

log = logging.getLogger(__name__)

MAX_ROUNDS = 10_000_000
UNBOUNDED_MAX_TIME = 7200.0  # s: the limit of a mission whose timeouts do not bound it
CONFIRM_TIMEOUT = 3.0  # wall s: the longest wait for the vehicle to confirm the switch-off
UNBOUNDED_STOP_BOUND = 600.0  # s: the stop handler's limit when no bound was proved for it
STUCK = "waiting for an event that will never come: no timer is armed and the vehicle is idle"


@dataclass
class MissionClock:
    """Mission time (0 at the mission's start) and the vehicle's clock beside it."""

    origin: float | None = None  # the vehicle's clock at the mission's start

    def vehicle(self, t: float) -> float:
        """The vehicle's clock at mission time ``t``."""
        return t + (self.origin or 0.0)


@dataclass
class Outcome:
    status: str  # "ok" | "fail" | "stuck" | "timeout" | "stopped" | "error" | "zeno"
    time: float  # mission time at the end
    rounds: int
    reason: str = ""
    confirmed: str = ""  # what the vehicle confirmed of the final switch-off
    switched_off: list[str] = field(default_factory=list)  # disabled by the abort
    # the mission's stop handler (MCL's ON STOP), when a stop started it: how it went
    stop_handler: StopHandler | None = None


@dataclass
class StopHandler:
    """How the mission's stop handler went: ``ended`` (it ended by itself, at ``time``) or
    ``halted`` (stopped in turn: ``reason``), within ``bound`` s of mission time from its
    ``start``."""

    start: float
    bound: float
    how: str = "running"  # "ended" | "halted"
    time: float = 0.0
    reason: str = ""


def run(player: Player, vehicle: Vehicle, mission: str, max_time: float = UNBOUNDED_MAX_TIME,
        max_rounds: int = MAX_ROUNDS, poll: float = 0.05,
        stop: Callable[[], str | None] | None = None, clock: MissionClock | None = None,
        confirm: float = CONFIRM_TIMEOUT, stop_bound: float = math.inf,
        rounds: Sequence[Callable[[float], None]] = ()) -> Outcome:
    """Run to the end. ``rounds``: told the mission time at each round (progress reports:
    the mission status, ``mcl run``'s timeline); ``poll``: the longest single wait
    (wall-time vehicles); ``stop``:
    called every round, returns why to stop now (or None) — once per request: while the
    stop handler runs, a reason means a new request; ``stop_bound``: the mission time the
    stop handler is given (its proved worst case)."""
    clock = clock if clock is not None else MissionClock()
    try:
        clock.origin = vehicle.now()
    except Exception as exc:  # noqa: BLE001
        return Outcome("error", 0.0, 0, f"the vehicle's clock: {type(exc).__name__}: {exc}")
    this = Run(player, vehicle, mission, clock.origin, max_time, poll, stop, confirm,
               stop_bound)
    this.rounds_told = list(rounds)
    why = stop() if stop is not None else None
    if why:  # stopped before anything was sent
        return this.end("stopped", 0.0, why)
    return this.play(max_rounds)


class Run:
    """One run of a player against a vehicle, between its start and its outcome: the orders
    sent (numbered in order), what the vehicle refused, and what was switched off once the run
    was being stopped. :func:`run` makes one; its methods are the run's steps: a round, the
    end of the mission, the abort path."""

    def __init__(self, player: Player, vehicle: Vehicle, mission: str, origin: float,
                 max_time: float, poll: float, stop: Callable[[], str | None] | None,
                 confirm: float, stop_bound: float = math.inf) -> None:
        self.player = player
        self.vehicle = vehicle
        self.mission = mission
        self.origin = origin  # the vehicle's clock at the mission's start
        self.max_time = max_time
        self.limit = max_time if math.isfinite(max_time) else math.inf
        self.poll = poll
        self.stop = stop
        self.confirm = confirm
        self.stop_bound = stop_bound if math.isfinite(stop_bound) else UNBOUNDED_STOP_BOUND
        self.simulated = bool(getattr(vehicle, "simulated", False))
        self.seq = itertools.count()  # the numbers of the orders sent
        self.failures: list[str] = []  # what the vehicle raised while an action was sent
        self.disabled: list[str] = []  # behaviours disabled once the run is being stopped
        self.stopping = False
        self.last_seq = -1  # the sequence number of the last event delivered
        self.now = 0.0  # mission time at the last reading of the vehicle's clock
        self.rounds = 0
        self.taken = 0  # the orders taken from the player's outbox
        self.rounds_told: list[Callable[[float], None]] = []  # told the time at each round

    # -- orders out ---------------------------------------------------------------------------
    def send(self, order: Order, stop: bool = False) -> None:
        """Send one order; what the vehicle raises is kept, to stop the run at the next round.
        ``stop``: the order belongs to a stop (a disable then counts as switched off)."""
        if (self.stopping or stop) and order.kind == "disable":
            self.disabled.append(order.behaviour)
        try:
            self.vehicle.send(ActionMessage(next(self.seq), order.t, self.mission, order.task,
                                            order.kind, order.behaviour, order.params))
        except Exception as exc:  # noqa: BLE001 - reported, then the run is stopped safely
            self.failures.append(f"sending {order.kind} {order.behaviour}: "
                                 f"{type(exc).__name__}: {exc}")
            log.warning("vehicle refused an action: %s", self.failures[-1])

    def drain(self) -> None:
        """Send the orders waiting in the player's outbox, oldest first."""
        outbox = self.player.outbox
        while outbox:
            self.taken += 1  # an order of the player's own abort of a spinning loop: a stop
            self.send(outbox.popleft(),
                      self.player.zeno is not None and self.taken > self.player.zeno_ordered)

    # -- the loop -----------------------------------------------------------------------------
    def mission_time(self) -> float:
        return self.vehicle.now() - self.origin

    def play(self, max_rounds: int) -> Outcome:
        """Start the player and go round until the run ends; any exception (the vehicle, its
        adapter, the player or an observer) stops it safely."""
        try:
            try:
                self.player.start(0.0)
            finally:
                self.drain()
            for rounds in range(1, max_rounds + 1):
                self.rounds = rounds
                outcome = self.round()
                if outcome is not None:
                    return outcome
        except Exception as exc:  # noqa: BLE001 - stop safely, then say
            try:
                self.now = max(self.now, self.mission_time())
            except Exception:  # noqa: BLE001 - the clock itself failed: keep the last reading
                pass
            return self.end("error", self.now, f"{type(exc).__name__}: {exc}")
        return self.end("timeout", self.mission_time(), "round limit reached")

    def round(self) -> Outcome | None:
        """One round: the outcome if the run ends here, else wait for the vehicle's events
        until the next timer falls due (never past the limit), then settle the player."""
        self.now = now = self.mission_time()
        for told in self.rounds_told:
            told(now)
        ending = self.reason_to_end(now)
        if ending is not None:
            return ending
        if self.player.handling:  # the player stopped the mission itself: its handler runs
            return self.own_stop(now)
        if not self.step(now):
            return self.end("stuck", now, STUCK)
        return None

    def step(self, now: float) -> bool:
        """Wait for the vehicle's events until the next timer falls due (never past the
        limit), deliver them, settle the player; False if nothing can happen any more."""
        deadline = self.player.next_deadline()
        if deadline is None and self.vehicle.idle():
            return False
        limit = self.limit
        if self.simulated:  # the clock jumps: no need to poll, but never past the limit
            until = min(deadline if deadline is not None else limit, limit)
        else:
            until = min(deadline if deadline is not None else now + self.poll,
                        now + self.poll, limit)
        for event in self.vehicle.receive(until + self.origin):
            self.deliver(event)
        try:
            self.player.settle(min(self.mission_time(), limit))
        finally:
            self.drain()
        return True

    def reason_to_end(self, now: float) -> Outcome | None:
        """The outcome, if the run ends at this round: the mission ended, the vehicle failed,
        ``stop()`` asked for it, or the time limit is reached."""
        if self.player.finished:
            return self.ended(now)
        if self.failures:
            return self.end("error", now, f"the vehicle failed: {self.failures[0]}")
        why = self.stop() if self.stop is not None else None
        if why:
            return self.end("stopped", now, why)
        if now >= self.limit - 1e-9:
            return self.end("timeout", self.limit if self.simulated else now,
                            f"mission time limit of {self.max_time:g} s reached")
        return None

    def deliver(self, event: EventMessage) -> None:
        """Give one event to the player, unless it is a duplicate or comes out of order."""
        t = self.mission_time()
        if event.seq <= self.last_seq:
            self.player.note_ignored(event.event, t, f"seq {event.seq} after {self.last_seq}: "
                                     "duplicate or out of order")
            return
        self.last_seq = event.seq
        try:
            self.player.handle_event(event.event, t, event.data, raised=event.t)
        finally:
            self.drain()

    # -- the end ------------------------------------------------------------------------------
    def ended(self, now: float) -> Outcome:
        """The mission ended by itself, ok or fail, or the player stopped a loop that spun at
        one instant (``zeno``)."""
        outcome = Outcome(self.player.status, now, self.rounds)
        if self.player.zeno is not None:
            outcome = Outcome("zeno", now, self.rounds, self.player.zeno,
                              switched_off=sorted(set(self.disabled)))
        outcome.confirmed = self.confirmation(sorted(set(self.disabled)))
        return outcome

    def end(self, status: str, t: float, reason: str) -> Outcome:
        """The abort path: what the player decided goes out, then (at the time limit) the
        timers due at the limit itself fire, then :meth:`Player.abort`, then, if the player
        could not abort cleanly, a disable of everything still on; the vehicle is asked to
        confirm the switch-off."""
        self.stopping = True
        self.drain()  # what the player decided before the stop goes out first
        trouble: list[Exception] = []
        if status == "timeout" and not self.player.finished:
            try:
                self.player.settle(t)  # the timers due at the limit itself still fire
            except Exception as exc:  # noqa: BLE001 - the abort below still runs
                trouble.append(exc)
            self.drain()
            if self.player.finished and not trouble:  # they ended the mission by themselves
                return self.ended(t)
        try:
            if not self.player.handling:  # (a stop handler already running is not restarted)
                self.player.abort(t, reason)
        except Exception as exc:  # noqa: BLE001 - an observer, or a bug in the player
            trouble.append(exc)
        self.drain()
        handler = None
        if self.player.handling and not trouble:
            handler = StopHandler(t, self.stop_bound)
            t = self.run_stop_handler(handler, trouble)
        self.force_off(t, trouble)
        outcome = Outcome(status, t, self.rounds, reason, switched_off=sorted(set(self.disabled)),
                          stop_handler=handler)
        outcome.confirmed = self.confirmation(outcome.switched_off)
        return outcome

    def own_stop(self, now: float) -> Outcome:
        """The player stopped the mission itself (``Link.lost`` that no block catches, a loop
        spinning at one instant) and the mission's stop handler runs: play it, then end as
        the mission ended."""
        handler = StopHandler(now, self.stop_bound)
        trouble: list[Exception] = []
        t = self.run_stop_handler(handler, trouble)
        self.force_off(t, trouble)
        outcome = self.ended(t)
        outcome.stop_handler = handler
        return outcome

    def force_off(self, t: float, trouble: list[Exception]) -> None:
        """If the player could not abort cleanly: a disable of everything still on."""
        if not trouble:
            return
        log.error("the player could not abort cleanly (%s): switching off what is on",
                  trouble[0])
        for b in sorted(self.player.behaviours_on):  # what the net could not switch off
            self.send(Order(t, "MISSION", "disable", b, {}))

    def run_stop_handler(self, handler: StopHandler, trouble: list[Exception]) -> float:
        """Play the mission's stop handler after an abort: rounds as usual until it ends, for
        at most its bound of mission time. A new stop request, a vehicle that fails, a lost
        link (it carries no actions), nothing left to wait for, or the bound halts it: the
        net aborts it in turn (``Player.abort`` again). Returns the mission time at its end."""
        self.stopping = False  # what the handler switches off is its own doing, not the stop's
        self.limit = handler.start + handler.bound
        now = handler.start
        try:
            for _ in range(MAX_ROUNDS):
                self.now = now = max(now, self.mission_time())
                why = self.halt_reason(now)
                if why is None and now >= self.limit - 1e-9:
                    self.player.settle(self.limit)  # what falls due at the bound still fires
                    self.drain()
                    now = self.limit if self.simulated else now
                    if not self.player.finished:
                        why = f"not ended within its proved bound of {handler.bound:g} s"
                if self.player.finished:
                    handler.how, handler.time = "ended", now
                    return now
                if why is None and not self.step(now):
                    why = STUCK
                if why is not None:
                    handler.how, handler.time, handler.reason = "halted", now, why
                    break
            else:
                handler.how, handler.time, handler.reason = "halted", now, "round limit reached"
        except Exception as exc:  # noqa: BLE001 - the handler's own trouble: halt it safely
            handler.how, handler.time = "halted", now
            handler.reason = f"{type(exc).__name__}: {exc}"
        self.stopping = True
        try:
            self.player.abort(now, f"the stop handler was halted: {handler.reason}")
        except Exception as exc:  # noqa: BLE001 - the forced switch-off below still runs
            trouble.append(exc)
        self.drain()
        return now

    def halt_reason(self, now: float) -> str | None:
        """Why to halt the stop handler now, if it must be: a new stop request, a vehicle
        that failed, or a link that carries no actions any more."""
        if self.failures:
            return f"the vehicle failed: {self.failures[0]}"
        if getattr(self.vehicle, "lost", False):
            return "the link to the vehicle is lost: it carries no actions"
        why = self.stop() if self.stop is not None else None
        return f"stopped again: {why}" if why else None

    def confirmation(self, names: list[str]) -> str:
        """Ask the vehicle (if its adapter can) to confirm that everything is off, bounded."""
        check = getattr(self.vehicle, "confirm_off", None)
        if check is None:
            return "not confirmed: this link cannot say"
        try:
            return str(check(names, self.confirm))
        except Exception as exc:  # noqa: BLE001 - a report, not a reason to fail the exit path
            return f"not confirmed: {type(exc).__name__}: {exc}"
