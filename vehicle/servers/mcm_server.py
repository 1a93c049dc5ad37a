"""Paper 003's two vehicles, of one simulated world, served over Zenoh in one process.

    mcl vehicle --world mcm --zenoh tcp/0.0.0.0:7447,tcp/0.0.0.0:7448 [--seed N] [--speed 10]

The ASV and the UUV share one world (vehicle/control/mcm_stack.py: the ASV's sonar sees the
UUV's true position, the UUV's camera the mine), so they cannot be two ``mcl vehicle``
processes: :class:`McmServer` is one :class:`vehicle.servers.zenoh_server.VehicleServer` per
vehicle, each on its own endpoint and under its own name (an ordinary Zenoh vehicle to its
player, with the modem of paper 003: the ASV answers what its ``fix`` and ``release`` say, the
UUV hears what its player was delivered), ticking both stacks on ONE clock. The clock starts
once every vehicle's player has begun its mission (its first status), so that both missions
start at 0 as in the fleet's one-process run (the ASV's sonar pings from the start: a world
that ran before the ASV's mission began would give it a reacquisition where it stands). The world and stacks are those of ``mcl run missions/mcm.mcl --seed N``
(mission/mcm_vehicles.py's, same seed, faults and fusion method).
"""

from __future__ import annotations

import threading
import time
from collections.abc import Sequence
from contextlib import ExitStack
from typing import Any

from aal.messages import Declaration
from aal.zenoh import close_session
from aal.zenoh_security import Security
from behaviours.capabilities import declaration_text
from vehicle.control.asv_stack import AsvStack
from vehicle.control.mcm_stack import DT, McmStack, mcm_world
from vehicle.control.uuv_stack import UuvStack, navigator
from vehicle.servers.zenoh_server import CLOCK_PERIOD, MAX_SLEEP, TELEMETRY_PERIOD, VehicleServer

NAMES = ("asv", "uuv")  # the vehicles of missions/mcm.mcl, in the order of --zenoh
SAFE = {"asv": None, "uuv": "Ascend"}  # what each does when its player is lost


class McmServer:
    """The ASV and the UUV of one world, each a Zenoh vehicle on its own endpoint.
    :meth:`run` blocks until ``stop`` is set."""

    def __init__(self, endpoints: Sequence[str], names: Sequence[str] = NAMES,
                 speed: float = 10.0, seed: int = 1, faults: Sequence[tuple[str, Any]] = (),
                 method: str = "repropagate", stop: threading.Event | None = None,
                 player_timeout: float = 3.0, wait_for_player: bool = True,
                 ready: threading.Event | None = None,
                 security: dict[str, Security | None] | None = None,
                 scouting: bool = False) -> None:
        if len(endpoints) != len(NAMES) or len(names) != len(NAMES):
            raise ValueError("paper 003's world has two vehicles: give two endpoints "
                             "(the ASV's, then the UUV's)")
        world = mcm_world(seed, list(faults))
        stacks: dict[str, McmStack] = {"asv": AsvStack(world, seed),
                                       "uuv": UuvStack(world, seed, navigator(method))}
        self.stop = stop or threading.Event()
        self.ready = ready or threading.Event()
        self.speed, self.wait_for_player = float(speed), wait_for_player
        self.servers: list[VehicleServer] = []
        for role, endpoint, name in zip(NAMES, endpoints, names, strict=True):
            stack = stacks[role]
            said = Declaration(f"sim {role} (paper 003, mcl vehicle --world mcm)",
                               "behaviours/mcm.py", declaration_text(stack.classes))
            self.servers.append(VehicleServer(
                endpoint, name, speed, seed, (), self.stop, player_timeout,
                wait_for_player=wait_for_player, ready=threading.Event(),
                security=(security or {}).get(name), scouting=scouting, stack=stack,
                declaration=said, safe=SAFE[role], dt=DT))

    def run(self) -> None:
        """Open every vehicle's session, then tick the world until ``stop``."""
        with ExitStack() as sessions:
            pubs = []
            for server in self.servers:
                session = server.open()
                sessions.callback(close_session, session)
                pub, entities = server.declare(session)
                sessions.callback(undeclare, entities)
                pubs.append(pub)
            self.ready.set()
            self.loop(pubs)

    def loop(self, pubs: list[dict[str, Any]]) -> None:
        """Wait until every player's mission has begun (the clock paused at 0, their first
        actions taken), then tick both stacks together."""
        pairs = list(zip(self.servers, pubs, strict=True))
        next_telemetry = 0.0
        while self.wait_for_player and not all(s.mission_begun() for s in self.servers):
            if self.stop.is_set():
                return
            for server, pub in pairs:
                server.apply_actions()
                server.publish_clock(pub, False)
                if time.monotonic() >= next_telemetry:
                    server.publish_telemetry(pub)
            if time.monotonic() >= next_telemetry:
                next_telemetry = time.monotonic() + TELEMETRY_PERIOD
            time.sleep(CLOCK_PERIOD)
        clock = self.servers[0].stack
        wall0, t0 = time.monotonic(), clock.t
        next_clock = 0.0
        while not self.stop.is_set():
            for server, _ in pairs:
                server.apply_actions()
                server.check_player()
            now = time.monotonic()
            if clock.t + DT <= t0 + (now - wall0) * self.speed:  # a tick is due: both tick
                for server, pub in pairs:
                    server.tick(pub)
            else:
                due_at = wall0 + (clock.t + DT - t0) / self.speed
                time.sleep(min(MAX_SLEEP, max(0.0, due_at - now)))
            now = time.monotonic()
            for server, pub in pairs:
                if now >= next_clock:
                    server.publish_clock(pub, True)
                if now >= next_telemetry:
                    server.publish_telemetry(pub)
            if now >= next_clock:
                next_clock = now + CLOCK_PERIOD
            if now >= next_telemetry:
                next_telemetry = now + TELEMETRY_PERIOD


def undeclare(entities: list[Any]) -> None:
    """Undeclare a vehicle's subscribers, queryables and token, last first."""
    for e in reversed(entities):
        try:
            e.undeclare()
        except Exception:  # already gone with its session
            pass
