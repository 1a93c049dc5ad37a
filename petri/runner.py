"""The loop that runs a player against a vehicle: it owns time.

Each round: settle the player (immediate firings, due timers), then wait for the vehicle's
events until the next timer falls due — in simulated time the clock jumps there; in wall time
the wait is real but bounded. The run ends when the mission ends, when nothing can happen any
more (no timer armed and the vehicle idle: the mission would wait forever), or when a bound on
mission time or rounds is reached.
"""

from __future__ import annotations

from dataclasses import dataclass

from vehicle_adapters.aal import ActionMessage, Vehicle

from .player import Player, Record

MAX_ROUNDS = 10_000_000


@dataclass
class Outcome:
    status: str  # "ok" | "fail" | "stuck" | "timeout"
    time: float
    rounds: int
    reason: str = ""


def run(player: Player, vehicle: Vehicle, mission: str, max_time: float = 86_400.0,
        max_rounds: int = MAX_ROUNDS, poll: float = 0.05) -> Outcome:
    """Run to the end. ``poll``: the longest single wait (wall-time vehicles)."""
    seq = iter(range(1 << 62))

    def forward(record: Record) -> None:
        if record.kind == "action":
            d = record.data
            vehicle.send(ActionMessage(next(seq), record.t, mission, d["task"], d["action"],
                                       d["behaviour"], d["params"]))

    player.observers.insert(0, forward)
    start = vehicle.now()
    player.start(start)
    last_seq = -1
    for rounds in range(1, max_rounds + 1):
        if player.finished:
            return Outcome(player.status, vehicle.now() - start, rounds)
        now = vehicle.now()
        if now - start > max_time:
            return Outcome("timeout", now - start, rounds,
                           f"mission time limit of {max_time:g} s reached")
        deadline = player.next_deadline()
        if deadline is None and vehicle.idle():
            return Outcome("stuck", now - start, rounds, "waiting for an event that will "
                           "never come: no timer is armed and the vehicle is idle")
        if getattr(vehicle, "simulated", False):  # the clock jumps: no need to poll
            until = deadline if deadline is not None else start + max_time + 1
        else:
            until = min(deadline if deadline is not None else now + poll, now + poll)
        for event in vehicle.receive(until):
            if event.seq <= last_seq:
                player._emit(vehicle.now(), "ignored", {
                    "event": event.event, "reason": f"seq {event.seq} after {last_seq}: "
                    "duplicate or out of order"})
                continue
            last_seq = event.seq
            player.handle_event(event.event, vehicle.now(), event.data)
        player.settle(vehicle.now())
    return Outcome("timeout", vehicle.now() - start, max_rounds, "round limit reached")
