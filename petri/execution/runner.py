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

import logging
import math
from collections.abc import Callable
from dataclasses import dataclass, field

from aal.messages import ActionMessage, Vehicle

from petri.execution.player import Order, Player

log = logging.getLogger(__name__)

MAX_ROUNDS = 10_000_000
UNBOUNDED_MAX_TIME = 7200.0  # s: the limit of a mission whose timeouts do not bound it
CONFIRM_TIMEOUT = 3.0  # wall s: the longest wait for the vehicle to confirm the switch-off


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


def run(player: Player, vehicle: Vehicle, mission: str, max_time: float = UNBOUNDED_MAX_TIME,
        max_rounds: int = MAX_ROUNDS, poll: float = 0.05,
        stop: Callable[[], str | None] | None = None, clock: MissionClock | None = None,
        confirm: float = CONFIRM_TIMEOUT) -> Outcome:
    """Run to the end. ``poll``: the longest single wait (wall-time vehicles); ``stop``:
    called every round, returns why to stop now (or None)."""
    clock = clock if clock is not None else MissionClock()
    seq = iter(range(1 << 62))
    failures: list[str] = []  # what the vehicle raised while an action was sent
    disabled: list[str] = []  # behaviours disabled once the run is being stopped
    stopping = [False]
    taken = [0]  # the orders taken from the player's outbox

    def send(order: Order, stop: bool = False) -> None:
        if (stopping[0] or stop) and order.kind == "disable":
            disabled.append(order.behaviour)
        try:
            vehicle.send(ActionMessage(next(seq), order.t, mission, order.task, order.kind,
                                       order.behaviour, order.params))
        except Exception as exc:  # noqa: BLE001 - reported, then the run is stopped safely
            failures.append(f"sending {order.kind} {order.behaviour}: "
                            f"{type(exc).__name__}: {exc}")
            log.warning("vehicle refused an action: %s", failures[-1])

    def drain() -> None:
        """Send the orders waiting in the player's outbox, oldest first."""
        while player.outbox:
            taken[0] += 1  # an order of the player's own abort of a spinning loop: a stop
            send(player.outbox.popleft(),
                 player.zeno is not None and taken[0] > player.zeno_ordered)

    def end(status: str, t: float, rounds: int, reason: str) -> Outcome:
        stopping[0] = True
        drain()  # what the player decided before the stop goes out first
        trouble: list[Exception] = []
        if status == "timeout" and not player.finished:
            try:
                player.settle(t)  # the timers due at the limit itself still fire
            except Exception as exc:  # noqa: BLE001 - the abort below still runs
                trouble.append(exc)
            drain()
            if player.finished and not trouble:  # they ended the mission by themselves
                return _ended(player, vehicle, t, rounds, disabled, confirm)
        try:
            player.abort(t, reason)
        except Exception as exc:  # noqa: BLE001 - an observer, or a bug in the player
            trouble.append(exc)
        drain()
        if trouble:
            log.error("the player could not abort cleanly (%s): switching off what is on",
                      trouble[0])
            for b in sorted(player.behaviours_on):  # what the net could not switch off
                send(Order(t, "MISSION", "disable", b, {}))
        outcome = Outcome(status, t, rounds, reason, switched_off=sorted(set(disabled)))
        outcome.confirmed = _confirm(vehicle, outcome.switched_off, confirm)
        return outcome

    try:
        clock.origin = vehicle.now()
    except Exception as exc:  # noqa: BLE001
        return Outcome("error", 0.0, 0, f"the vehicle's clock: {type(exc).__name__}: {exc}")
    origin = clock.origin
    why = stop() if stop is not None else None
    if why:  # stopped before anything was sent
        return end("stopped", 0.0, 0, why)
    limit = max_time if math.isfinite(max_time) else math.inf
    simulated = bool(getattr(vehicle, "simulated", False))
    last_seq, now, rounds = -1, 0.0, 0
    try:
        try:
            player.start(0.0)
        finally:
            drain()
        for rounds in range(1, max_rounds + 1):
            now = vehicle.now() - origin
            if player.finished:
                return _ended(player, vehicle, now, rounds, disabled, confirm)
            if failures:
                return end("error", now, rounds, f"the vehicle failed: {failures[0]}")
            why = stop() if stop is not None else None
            if why:
                return end("stopped", now, rounds, why)
            if now >= limit - 1e-9:
                return end("timeout", limit if simulated else now, rounds,
                           f"mission time limit of {max_time:g} s reached")
            deadline = player.next_deadline()
            if deadline is None and vehicle.idle():
                return end("stuck", now, rounds, "waiting for an event that will never "
                           "come: no timer is armed and the vehicle is idle")
            if simulated:  # the clock jumps: no need to poll, but never past the limit
                until = min(deadline if deadline is not None else limit, limit)
            else:
                until = min(deadline if deadline is not None else now + poll, now + poll,
                            limit)
            for event in vehicle.receive(until + origin):
                t = vehicle.now() - origin
                if event.seq <= last_seq:
                    player.note_ignored(event.event, t, f"seq {event.seq} after {last_seq}: "
                                        "duplicate or out of order")
                    continue
                last_seq = event.seq
                try:
                    player.handle_event(event.event, t, event.data)
                finally:
                    drain()
            try:
                player.settle(min(vehicle.now() - origin, limit))
            finally:
                drain()
    except Exception as exc:  # the vehicle, its adapter, the player or an observer: stop
        try:                  # safely, then say
            now = max(now, vehicle.now() - origin)
        except Exception:  # noqa: BLE001 - the clock itself failed: keep the last reading
            pass
        return end("error", now, rounds, f"{type(exc).__name__}: {exc}")
    return end("timeout", vehicle.now() - origin, max_rounds, "round limit reached")


def _ended(player: Player, vehicle: Vehicle, now: float, rounds: int, disabled: list[str],
           confirm: float) -> Outcome:
    outcome = Outcome(player.status, now, rounds)
    if player.zeno is not None:  # the player stopped a loop that spun at one instant
        outcome = Outcome("zeno", now, rounds, player.zeno, switched_off=sorted(set(disabled)))
    outcome.confirmed = _confirm(vehicle, sorted(set(disabled)), confirm)
    return outcome


def _confirm(vehicle: Vehicle, names: list[str], timeout: float) -> str:
    """Ask the vehicle (if its adapter can) to confirm that everything is off, bounded."""
    check = getattr(vehicle, "confirm_off", None)
    if check is None:
        return "not confirmed: this link cannot say"
    try:
        return str(check(names, timeout))
    except Exception as exc:  # noqa: BLE001 - a report, not a reason to fail the exit path
        return f"not confirmed: {type(exc).__name__}: {exc}"
