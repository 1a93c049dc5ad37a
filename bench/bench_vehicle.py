"""Benchmark: the simulated vehicle stack on the dam mission — speed and accuracy.

What is measured, in process (the compiled dam mission, the player, the in-process adapter,
IctineuStack), in simulated time:

* speed: simulated seconds per wall second for the whole mission (the ``petri.execution.runner.run``
  call only; compiling is not counted), median of ``--runs`` runs:

  - ``full``: every sensor and estimator at its rate (DVL 2 Hz, heading 10 Hz, depth 5 Hz,
    USBL 1 Hz into the navigator EKF; the MSIS at 20 beams/s into the wall detector and the
    wall tracker EKF; the camera; the housings) — what ``mcl run`` runs;
  - ``no wall perception``: the same with the sonar switched off (no beams simulated) and no
    wall detector or tracker; AchieveHeadDist is fed the true wall distance and heading
    instead, so the mission still runs the same way. The ratio of the two says what the
    wall perception costs;

* accuracy, from the full run's survey summary against the simulation's ground truth:
  navigator horizontal RMS error, wall distance and wall-relative heading RMS errors during
  the survey, path length, wall area imaged, share of it seen in two or more images; next to
  paper 002's field trial (§7: a 191 m path over 40 m² of wall in about 29 min, images
  overlapping by more than 50 %) and the targets (>= 100x real time, < 0.5 m, < 0.10 m,
  < 2 deg).

    python bench/bench_vehicle.py [--runs 3] [--seed 1]
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
REPO = HERE.parent
sys.path.insert(0, str(REPO))

import behaviours as bh
from mcl.api import Compiled, compile_file
from petri.execution.player import Player
from petri.execution.runner import Outcome, run
from vehicle.world.robot import wrap_angle
from vehicle.control.stack import IctineuStack, StackConfig
from vehicle_adapters.inprocess import InProcess

DAM = REPO / "missions" / "dam_inspection.mcl"

PAPER = {"path_length_m": "191 m", "wall_area_imaged_m2": "40 m²",
         "share_seen_twice": "> 50 %", "mission_time": "about 29 min"}
TARGET_SPEED = 100.0  # x real time
TARGETS = {"navigator_rms_m": 0.5, "wall_distance_rms_m": 0.10, "wall_heading_rms_deg": 2.0}


class NoWallPerception(IctineuStack):
    """The stack without the MSIS, the wall detector and the wall tracker: the behaviours get
    the true distance to the wall and heading relative to it instead."""

    def __init__(self, config: StackConfig | None = None):
        super().__init__(config)
        self.sensors.remove(self.sensors.sonar)  # the others keep their random streams

    def perception(self) -> bh.Perception:
        p = super().perception()
        truth = self.robot.state
        nx, ny = self.env.wall_normal(self.env.wall_foot(truth.x, truth.y))
        normal = math.atan2(ny, nx)
        return bh.Perception(p.t, p.x, p.y, p.z, p.psi, p.u, p.v, p.w, p.r,
                             wall_distance=self.env.distance_to_wall(truth.x, truth.y),
                             wall_heading=wrap_angle(truth.psi - normal), wall_normal=normal,
                             leak=p.leak, temperature=p.temperature, pressure=p.pressure)


def one_run(compiled: Compiled, stack: IctineuStack) -> tuple[Outcome, float]:
    player = Player(compiled.net)
    name = compiled.mission.name or DAM.stem
    started = time.perf_counter()
    outcome = run(player, InProcess(stack), name)
    return outcome, time.perf_counter() - started


def measure(compiled: Compiled, make: Any, runs: int, seed: int
            ) -> tuple[list[float], Outcome, IctineuStack]:
    speeds = []
    outcome: Outcome | None = None
    stack: IctineuStack | None = None
    for _ in range(runs):
        stack = make(StackConfig(seed=seed))
        outcome, wall = one_run(compiled, stack)
        if outcome.status != "ok":
            print(f"  warning: the mission ended {outcome.status}: {outcome.reason}")
        speeds.append(outcome.time / wall)
        print(f"  {outcome.time:7.1f} s simulated in {wall:6.2f} s: {speeds[-1]:6.0f}x real time",
              flush=True)
    assert outcome is not None and stack is not None
    return speeds, outcome, stack


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--runs", type=int, default=3, help="runs per configuration (median)")
    ap.add_argument("--seed", type=int, default=1, help="seed of the simulated vehicle")
    args = ap.parse_args(argv)
    compiled = compile_file(str(DAM), require_values=True)

    print(f"dam mission, seed {args.seed}, {args.runs} runs per configuration")
    print("full (every estimator at its sensor rate):")
    full, outcome, stack = measure(compiled, IctineuStack, args.runs, args.seed)
    print("no wall perception (sonar, wall detector and tracker off; true wall fed in):")
    bare, bare_outcome, _ = measure(compiled, NoWallPerception, args.runs, args.seed)

    f, b = statistics.median(full), statistics.median(bare)
    print("\nspeed (simulated s per wall s, median)")
    print(f"  full                 {f:8.0f}x   target >= {TARGET_SPEED:.0f}x  "
          f"{'ok' if f >= TARGET_SPEED else 'MISSED'}")
    print(f"  no wall perception   {b:8.0f}x   (mission {bare_outcome.status}, "
          f"{bare_outcome.time:.0f} s)")
    print(f"  ratio                {b / f:8.2f}    the sonar and wall tracking take "
          f"{100 * (1 - f / b):.0f} % of the full run's time")

    s = stack.survey.summary()
    print(f"\naccuracy and coverage (full run, mission {outcome.status} after "
          f"{outcome.time / 60:.1f} min)")
    rows = [
        ("mission time", f"{outcome.time / 60:.1f} min", PAPER["mission_time"], ""),
        ("path length", f"{s['path_length_m']} m", PAPER["path_length_m"], "> 100 m (order)"),
        ("wall area imaged", f"{s['wall_area_imaged_m2']} m²", PAPER["wall_area_imaged_m2"],
         "> 40 m²"),
        ("share seen twice", f"{100 * s['share_seen_twice']:.0f} %",
         PAPER["share_seen_twice"], "> 50 %"),
        ("images", f"{s['images']}", "1,998", ""),
        ("navigator RMS (horiz.)", f"{s['navigator_rms_m']} m", "—",
         f"< {TARGETS['navigator_rms_m']} m"),
        ("wall distance RMS", f"{s['wall_distance_rms_m']} m", "—",
         f"< {TARGETS['wall_distance_rms_m']} m"),
        ("wall heading RMS", f"{s['wall_heading_rms_deg']} deg", "—",
         f"< {TARGETS['wall_heading_rms_deg']} deg"),
        ("USBL fixes (rejected)", f"{s['usbl_fixes']} ({s['usbl_rejected']})", "—", ""),
    ]
    print(f"  {'figure':<24}{'measured':>14}   {'field trial':<14}{'target':<16}")
    for name, measured, paper, target in rows:
        print(f"  {name:<24}{measured:>14}   {paper:<14}{target:<16}")
    missed = [k for k, limit in TARGETS.items() if not s[k] < limit]
    if f < TARGET_SPEED:
        missed.append("speed")
    print("\ntargets: " + ("all met" if not missed else "MISSED: " + ", ".join(missed)))
    return 0


if __name__ == "__main__":
    sys.exit(main())
