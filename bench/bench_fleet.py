"""Benchmark: proving a fleet (mcl/analysis/fleet_verification.py), time and memory.

Two fleets, each proved by every route (explicit product, compositional, auto):

* ``missions/mcm.mcl``, paper 003's mission (issue 24), when it exists (target: 5 s, 1 GiB);
* the two-vehicle guide fleet of the tests (tests/mcl/analysis/fleet_missions.py): a surface
  vehicle that sends ``release`` then a fix every 2 s for a minute over a lossy channel, and
  a vehicle that dives on the release, follows the fixes and surfaces when they stop;
* two dam-sized missions composed: ``missions/dam_inspection.mcl``'s body in two vehicles,
  the first sending ``release`` when it has reached the wall, the second waiting for it
  (5 min) before its own inspection — the product is too large for the memory budget, so
  ``auto`` takes the compositional route (the explicit route, given 1 GiB, is cut and says
  undecided; it never exhausts memory).

Seconds are the median of ``--runs`` after a warm-up (numba's compilation is not
counted); memory is the peak of Python's and numpy's allocations (tracemalloc) in one run.

    .venv/bin/python bench/bench_fleet.py [--runs 3] [--max-bytes BYTES]
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time
import tracemalloc
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from diagnostics import Source
from mcl.analysis.fleet_verification import FleetVerdict, verify_fleet
from mcl.fleet import CompiledFleet, compile_fleet_file, compile_fleet_source
from tests.mcl.analysis.fleet_missions import fleet


def dam_pair() -> CompiledFleet:
    """Two dam inspections: ``a`` sends release once at the wall, ``b`` waits for it (5 min)
    before its own inspection."""
    text = (REPO / "missions" / "dam_inspection.mcl").read_text()
    a = text.replace("AchieveHeadDist(h, d);",
                     "AchieveHeadDist(h, d);\n        Send(guide, release);")
    b = text.replace("StartLogs(enable);",
                     "StartLogs(enable);\n    Receive(guide, release, timeout = 5 min);")
    fleet_text = ("FLEET dams {\n    CHANNEL guide FROM a TO b ACOUSTIC DELAY 1 s .. 3 s LOSSY "
                  f"MESSAGES release;\n    VEHICLE a {{\n{a}\n}}\n    VEHICLE b {{\n{b}\n}}\n}}\n")
    return compile_fleet_source(Source("dams.mcl", fleet_text))


def measure(f: CompiledFleet, method: str, runs: int, max_bytes: int) -> tuple[float, float, FleetVerdict]:
    verdict = verify_fleet(f, method, max_bytes=max_bytes)  # warm-up
    times = []
    for _ in range(runs):
        start = time.perf_counter()
        verify_fleet(f, method, max_bytes=max_bytes)
        times.append(time.perf_counter() - start)
    tracemalloc.start()
    verify_fleet(f, method, max_bytes=max_bytes)
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    return statistics.median(times), peak / 2**20, verdict


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=3)
    ap.add_argument("--max-bytes", type=int, default=1 << 30)
    args = ap.parse_args()
    print(f"{'fleet':<12} {'method':<14} {'markings':>10} {'seconds':>8} {'peak MiB':>9}  "
          "verdict")
    fleets = [("guide (2)", fleet()), ("dam x 2", dam_pair())]
    mcm = REPO / "missions" / "mcm.mcl"  # paper 003's mission (issue 24), once it exists
    if mcm.exists():
        fleets.insert(1, ("mcm", compile_fleet_file(str(mcm))))
    for name, f in fleets:
        for method in ("explicit", "compositional", "auto"):
            seconds, mib, v = measure(f, method, args.runs, args.max_bytes)
            verdict = "proved" if v.ok else "FAILS" if v.failed else "undecided"
            print(f"{name:<12} {method:<14} {v.markings:>10,} {seconds:>8.3f} {mib:>9.1f}  "
                  f"{verdict}{' (' + v.note + ')' if v.note else ''}")


if __name__ == "__main__":
    main()
