"""The top view of missions/mcm.mcl run on paper 003's simulated pair (docs/mcm_tracks.svg).

    python bench/mcm_tracks.py [OUT.svg] [--seed N] [--loss P] [--inject FAULT ...]

Runs the fleet in this process (mission.run_fleet on mission.mcm_vehicles, as ``mcl run
missions/mcm.mcl`` does) and draws both tracks, the fixes (heard or not) and the mine
(vehicle/control/mcm_picture.py).
"""

from __future__ import annotations

import argparse
import tempfile
from pathlib import Path

from mcl.fleet import compile_fleet_file
from mission.fleet import run_fleet
from mission.mcm_vehicles import mcm_vehicles
from vehicle.control.asv_stack import AsvStack
from vehicle.control.mcm_picture import top_view
from vehicle.control.uuv_stack import UuvStack

REPO = Path(__file__).resolve().parents[1]


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("out", nargs="?", default=str(REPO / "docs" / "mcm_tracks.svg"))
    p.add_argument("--seed", type=int, default=3)
    p.add_argument("--loss", type=float, default=0.3)
    p.add_argument("--inject", action="append", default=[])
    args = p.parse_args()
    fleet = compile_fleet_file(str(REPO / "missions" / "mcm.mcl"), require_values=True)
    vehicles = mcm_vehicles(args.seed, args.inject)
    with tempfile.TemporaryDirectory() as logs:
        result = run_fleet(fleet, vehicles, loss=args.loss, seed=args.seed, log_dir=logs)
    asv, uuv = vehicles["asv"].modem, vehicles["uuv"].modem
    assert isinstance(asv, AsvStack) and isinstance(uuv, UuvStack)
    ends = ", ".join(f"{n} {r.status}" for n, r in result.runs.items())
    faults = f", --inject {' '.join(args.inject)}" if args.inject else ""
    title = (f"mcl run missions/mcm.mcl --seed {args.seed} --loss {args.loss:g}{faults}: "
             f"{ends}")
    Path(args.out).write_text(top_view(asv, uuv, title), "utf-8")
    print(f"{args.out}: {ends}")


if __name__ == "__main__":
    main()
