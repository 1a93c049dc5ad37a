"""Benchmark: paper 003's mission (missions/mcm.mcl) over many seeds, against ground truth.

For each loss of the acoustic link (0, 0.3 and 0.5) and each delayed-fusion method of the
UUV's navigator (naive, re-propagation, Larsen's), the mission runs in one process on the
simulated pair (mission.mcm_vehicles) for every seed, as ``mcl run missions/mcm.mcl --seed N
--loss P`` does. Figures:

* success: the share of runs in which the UUV landed with the mine in its snapshot (within
  the camera's footprint of the mine); ascended: the share that ascended (their safe end);
* miss: the UUV's median and 95th-percentile horizontal distance from the mine at its end,
  over the successful runs (it lands about 1 m short of the mine, facing it);
* navigator error: the distance between the UUV's estimate and its true position in {T},
  every tick from the first fix on: the median over the runs of each run's RMS, and of each
  run's largest.

The paper gives no error table: these figures are against simulated ground truth.

    python bench/bench_mcm.py [--seeds 100] [--losses 0,0.3,0.5]
                              [--methods naive,repropagate,larsen] [--inject FAULT]
"""

from __future__ import annotations

import argparse
import math
import statistics
import sys
import time
from pathlib import Path
from typing import Any

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent))

from mcl.fleet import compile_fleet_file
from mission.fleet import run_fleet
from mission.mcm_vehicles import mcm_vehicles
from vehicle.control.uuv_stack import UuvStack

MISSION = HERE.parent / "missions" / "mcm.mcl"


def one(fleet: Any, seed: int, loss: float, method: str, faults: list[str]
        ) -> dict[str, Any]:
    """One run's outcome and figures."""
    vehicles = mcm_vehicles(seed, faults, method=method)
    run_fleet(fleet, vehicles, loss=loss, seed=seed, verify=False)
    uuv = vehicles["uuv"].modem
    assert isinstance(uuv, UuvStack)
    last = next((f"{b}.{e}" for _, b, e in reversed(uuv.raised)), "")
    s, (tx, ty, _) = uuv.body.state, uuv.world.scene.target
    errors = uuv.navigation_errors()
    return {"landed": last == "Snapshot.taken", "ascended": last == "Ascend.surfaced",
            "miss": math.hypot(s.x - tx, s.y - ty), "errors": errors}


def row(runs: list[dict[str, Any]]) -> str:
    landed = [r for r in runs if r["landed"]]
    misses = sorted(r["miss"] for r in landed)
    rms = [math.sqrt(sum(e * e for e in r["errors"]) / len(r["errors"]))
           for r in runs if r["errors"]]
    worst = [max(r["errors"]) for r in runs if r["errors"]]
    p95 = misses[min(len(misses) - 1, int(0.95 * len(misses)))] if misses else math.nan
    return (f"{100 * len(landed) / len(runs):6.0f} % "
            f"{100 * sum(r['ascended'] for r in runs) / len(runs):8.0f} % "
            f"{statistics.median(misses) if misses else math.nan:8.2f} {p95:7.2f} "
            f"{statistics.median(rms) if rms else math.nan:9.2f} "
            f"{statistics.median(worst) if worst else math.nan:9.2f}")


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--seeds", type=int, default=100)
    p.add_argument("--losses", default="0,0.3,0.5")
    p.add_argument("--methods", default="naive,repropagate,larsen")
    p.add_argument("--inject", action="append", default=[])
    args = p.parse_args()
    fleet = compile_fleet_file(str(MISSION), require_values=True)
    faults = f" --inject {' '.join(args.inject)}" if args.inject else ""
    print(f"missions/mcm.mcl, seeds 1..{args.seeds}{faults} (figures against simulated "
          "ground truth)")
    print("  loss  method        success ascended   miss m  p95 m  nav RMS m  nav max m")
    start = time.perf_counter()
    for loss in (float(v) for v in args.losses.split(",")):
        for method in args.methods.split(","):
            runs = [one(fleet, seed, loss, method, args.inject)
                    for seed in range(1, args.seeds + 1)]
            print(f"  {loss:4.1f}  {method:<12} {row(runs)}", flush=True)
    print(f"  ({time.perf_counter() - start:.0f} s)")


if __name__ == "__main__":
    main()
