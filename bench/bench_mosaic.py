"""Benchmark: the photomosaic of the dam mission (paper 002 §6) against ground truth.

Runs the dam mission in process on the simulated Ictineu with the camera rendering the wall
(vehicle/sensors/camera.py: 320 x 240 pixels; images and their navigation data written to
out/bench/mosaic/dam.images), then builds the mosaic (mosaic/build.py) ``--runs`` times and
reports, next to the targets:

* pairwise registration error (pixels, median and max over the registered pairs);
* global alignment error of the image positions against the truth (mm, RMS and max), with
  the navigation prior and without it (images only, the first image held);
* the navigation data's own error at the images (what the prior starts from);
* the mosaic's error against the ground-truth texture at control points (mm);
* images per second and the build time (median of the runs, wall clock and CPU; the machine's
  load average beside them); targets: alignment RMS under 20 mm, the dam mission's mosaic in
  under 60 s.

    python bench/bench_mosaic.py [--runs 1] [--seed 1] [--reuse]

``--reuse`` skips the mission when its images are already there.
"""

from __future__ import annotations

import argparse
import os
import shutil
import statistics
import sys
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
REPO = HERE.parent
sys.path.insert(0, str(REPO))

from mcl.api import compile_file
from mosaic import build
from mosaic.hook import attach
from petri.execution.player import Player
from petri.execution.runner import run
from vehicle.control.stack import IctineuStack, StackConfig
from vehicle_adapters.inprocess import InProcess

DAM = REPO / "missions" / "dam_inspection.mcl"
OUT = REPO / "out" / "bench" / "mosaic"
TARGET_RMS_MM = 20.0
TARGET_SECONDS = 60.0


def mission(seed: int, log: Path) -> None:
    compiled = compile_file(str(DAM), require_values=True)
    stack = IctineuStack(StackConfig(seed=seed))
    folder = log.with_suffix(".images")
    shutil.rmtree(folder, ignore_errors=True)
    attach(stack, log)
    started = time.perf_counter()
    outcome = run(Player(compiled.net), InProcess(stack), compiled.mission.name or DAM.stem)
    wall = time.perf_counter() - started
    print(f"dam mission: {outcome.status}, {outcome.time:.0f} s simulated in {wall:.1f} s with "
          f"{stack.images.count} images rendered and written ({folder})", flush=True)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--runs", type=int, default=1)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--reuse", action="store_true")
    args = ap.parse_args()
    OUT.mkdir(parents=True, exist_ok=True)
    log = OUT / "dam.jsonl"
    if not (args.reuse and (log.with_suffix(".images") / "index.csv").exists()):
        mission(args.seed, log)
    times, cpus = [], []
    result = None
    for _ in range(max(1, args.runs)):
        started, cpu = time.perf_counter(), time.process_time()
        result = build.build(log.with_suffix(".images"), measure=False)
        times.append(time.perf_counter() - started)
        cpus.append(time.process_time() - cpu)
    assert result is not None
    # the comparison without the prior, once, outside the timing
    full = build.build(log.with_suffix(".images"))
    paths = build.write(full, OUT / "dam")
    f = full.figures
    seconds = statistics.median(times)
    n = f["images"]
    print("\n".join(build.summary_lines(full, paths)))
    print()
    reg, al, nav = f["registration_error_px"], f["alignment_error_mm"], f["navigation_error_mm"]
    alone, mos = f["alignment_error_without_prior_mm"], f["mosaic_error_mm"]
    rows = [
        ("images (used / taken)", f"{f['used']} / {n}", "paper: 1,998"),
        ("pairs registered (consecutive + not)", f"{f['consecutive_pairs']} + "
         f"{f['non_consecutive_pairs']} of {f['pairs_tried']}", ""),
        ("registration error, px (median / max)", f"{reg['median']} / {reg['max']}", ""),
        ("navigation data at the images, mm (RMS / max)", f"{nav['rms']} / {nav['max']}",
         "paper: DGPS 2-3 m"),
        ("alignment with prior, mm (RMS / max)", f"{al['rms']} / {al['max']}",
         f"target RMS < {TARGET_RMS_MM:g}: {'met' if al['rms'] < TARGET_RMS_MM else 'SHORT'}"),
        ("alignment without prior, mm (RMS / max)", f"{alone['rms']} / {alone['max']}", ""),
        ("mosaic at control points, mm (RMS / max)", f"{mos['rms']} / {mos['max']} "
         f"({f['control_points']} points)", "paper: 'a few centimeters'"),
        ("build time, s (median of runs)", f"{seconds:.1f} ({n / seconds:.1f} images/s)",
         f"target < {TARGET_SECONDS:g}: {'met' if seconds < TARGET_SECONDS else 'SHORT'}"),
        ("build CPU time, s (median of runs, all threads)", f"{statistics.median(cpus):.1f}",
         f"load average {os.getloadavg()[0]:.1f} on {os.cpu_count()} cores"),
        ("  of which features / registration / alignment / blending",
         " / ".join(f"{result.figures['seconds'][k]:.1f}" for k in
                    ("features", "registration", "alignment", "blending")), ""),
    ]
    for name, value, note in rows:
        print(f"{name:<55} {value:<28} {note}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
