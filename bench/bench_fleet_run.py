"""Benchmark: a fleet in one process (mission/fleet.py), player rounds per second with two and
eight vehicles on one simulated clock.

The fleet: vehicle v0 sends ``go`` every 2 s on one LOSSY acoustic channel to all the others;
each of them waits for it (timeout 10 s), then waits 0.5 s, again and again, for the mission
time given. Measured, for 2 and 8 vehicles, on two kinds of vehicle:

* ``scripted``: a vehicle that does nothing by itself (vehicle/scripted.py): what the players,
  the channel and the shared clock's turns cost;
* ``ictineu``: the simulated Ictineu (10 Hz stack: dynamics, sensors, navigator) under each
  player: what a fleet of simulated vehicles runs at.

Figures: runner rounds (every vehicle's, summed) per wall second, firings per second, and
simulated seconds per wall second (how much faster than real time the fleet runs).

    python bench/bench_fleet_run.py [--minutes 10] [--ictineu-seconds 60]
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent))

from diagnostics import Source
from mcl.fleet import CompiledFleet, compile_fleet_source
from mission.fleet import run_fleet
from mission.simulated import simulated_vehicle
from mission.vehicle import Vehicle
from vehicle.scripted import ScriptedVehicle, parse_script
from vehicle_adapters.inprocess import InProcess


def fleet_text(vehicles: int, seconds: float) -> str:
    """A fleet of ``vehicles``: v0 guides the others for ``seconds`` of mission time."""
    others = [f"v{i}" for i in range(1, vehicles)]
    follower = ("MISSION follow { PARALLEL { WHILE { Receive(orders, go, timeout = 10 s) } "
                f"DO {{ Wait(0.5 s) }} }} OR {{ Wait({seconds:g} s) }} }}")
    return "\n".join([
        "FLEET bench {",
        f"    CHANNEL orders FROM v0 TO {', '.join(others)} ACOUSTIC DELAY 1 s .. 3 s "
        "EVERY 2 s LOSSY MESSAGES go;",
        "    VEHICLE v0 { MISSION lead { PARALLEL { WHILE { Wait(2 s) } DO { Send(orders, go) "
        f"}} }} OR {{ Wait({seconds:g} s) }} }} }}",
        *[f"    VEHICLE {name} {{ {follower} }}" for name in others],
        "}",
    ])


class Rounds:
    """Counts the runner's rounds (it tells every observer with a ``tick`` each round)."""

    def __init__(self) -> None:
        self.count = 0

    def __call__(self, record: Any) -> None:
        return None

    def tick(self, t: float) -> None:
        self.count += 1


def measure(fleet: CompiledFleet, kind: str) -> dict[str, float]:
    """One run of ``fleet`` on vehicles of ``kind``: its figures."""
    if kind == "scripted":
        vehicles = {n: Vehicle(InProcess(ScriptedVehicle(parse_script({}))))
                    for n in fleet.vehicles}
    else:
        vehicles = {n: simulated_vehicle(seed=i + 1) for i, n in enumerate(fleet.vehicles)}
    counters = {n: Rounds() for n in fleet.vehicles}
    with tempfile.TemporaryDirectory() as folder:
        start = time.perf_counter()
        result = run_fleet(fleet, vehicles, loss=0.2, seed=1, log_dir=folder, verify=False,
                           observers={n: [c] for n, c in counters.items()})
        wall = time.perf_counter() - start
    rounds = sum(c.count for c in counters.values())
    firings = sum(r.firings for r in result.runs.values())
    assert all(r.status == "ok" for r in result.runs.values()), result.runs
    return {"wall": wall, "rounds": rounds, "rounds_s": rounds / wall,
            "firings_s": firings / wall, "speed": result.time / wall,
            "delivered": result.channels["orders"]["delivered"]}


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--minutes", type=float, default=10.0,
                   help="mission time of the scripted fleets (default 10 min)")
    p.add_argument("--ictineu-seconds", type=float, default=60.0,
                   help="mission time of the fleets of simulated Ictineus (default 60 s)")
    args = p.parse_args(argv)
    print("fleet in one process: runner rounds per wall second (every vehicle's, summed)")
    print(f"{'vehicles':>8} {'kind':<9} {'mission s':>9} {'wall s':>7} {'rounds':>8} "
          f"{'rounds/s':>9} {'firings/s':>9} {'x real time':>11} {'delivered':>9}")
    for kind, seconds in (("scripted", args.minutes * 60), ("ictineu", args.ictineu_seconds)):
        for n in (2, 8):
            fleet = compile_fleet_source(Source(f"bench{n}.mcl", fleet_text(n, seconds)),
                                         require_values=True)
            f = measure(fleet, kind)
            print(f"{n:>8} {kind:<9} {seconds:>9g} {f['wall']:>7.2f} {f['rounds']:>8.0f} "
                  f"{f['rounds_s']:>9.0f} {f['firings_s']:>9.0f} {f['speed']:>11.0f} "
                  f"{f['delivered']:>9.0f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
