"""Benchmark: the two seabed trackers' speed, next to the papers' figures.

* Wirth's Condensation cable tracker (vehicle/perception/cable_tracker.py, paper 004): frames per second
  with the parameters of Table 5.1 (500 particles, filter size 11 px, sample point distance
  20 px) and with the thesis's "high-speed" setting (300 particles, filter size 5 px), against
  Table 5.3 (17.29 ... 17.59 ms a frame, 56.9 ... 59.7 frames/s on a 1.5 GHz Pentium M; the
  high-speed setting about 7 ms, over 140 frames/s). The thesis's cost scales with particles x
  sample points x filter taps, which depend on the image's size only through the border length.
* Foresti's pipeline tracker (vehicle/perception/pipeline_tracker.py, paper 000): Canny, Hough, domains,
  grouping and the EKF per frame, against the paper's 4 frames/s at 256 x 256 on two 400 MHz
  Pentium II (§VII).

Images are rendered beforehand by the downward camera over the default scene along the line
(160 x 120 as in the simulator, and 320 x 240 / 256 x 256); only the tracker's step is timed.
Times are CPU time of this process (``time.process_time``), median over the frames, so that a
loaded machine (other jobs on the same cores) does not inflate them; the wall-clock median is
printed beside. Also printed: the renderer's cost per frame (not counted above).

    python bench/bench_trackers.py [--frames 120]
"""

from __future__ import annotations

import argparse
import math
import platform
import statistics
import sys
import time
from collections.abc import Callable
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent))

import numpy as np

from vehicle.perception.cable_tracker import TABLE_5_1, CableTracker
from vehicle.sensors.downward_camera import DownwardCamera
from vehicle.perception.pipeline_tracker import PipelineTracker, PipeModel
from vehicle.world.seabed import default_scene

TABLE_5_3_MS = (17.29, 16.47, 16.92, 17.51, 16.84, 17.59)  # S1..S6, ms a frame


def frames_along(kind: str, cam: DownwardCamera, altitude: float, n: int
                 ) -> list[np.ndarray]:
    bed = default_scene()
    line = bed.line(kind)
    assert line is not None
    rng = np.random.default_rng(1)
    out = []
    for k in range(n):
        s = 1.0 + 0.1 * k
        x, y = line.point(s)
        h = line.direction(s) + 0.05 * math.sin(k / 7)
        out.append(cam.render(bed, (x + 0.1, y, bed.floor_depth - altitude, h), 0.0, rng))
    return out


def timed(step: Callable[[np.ndarray], object], images: list[np.ndarray]
          ) -> tuple[float, float, int]:
    cpu, wall, hits = [], [], 0
    for image in images:
        c0, w0 = time.process_time(), time.perf_counter()
        hits += bool(step(image))
        cpu.append(time.process_time() - c0)
        wall.append(time.perf_counter() - w0)
    return 1000 * statistics.median(cpu), 1000 * statistics.median(wall), hits


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--frames", type=int, default=120)
    args = ap.parse_args()
    print(f"bench_trackers: {platform.processor() or platform.machine()}, "
          f"Python {platform.python_version()}, {args.frames} frames each; "
          "ms = median CPU time a frame (wall median in brackets)")
    print(f"  Wirth, Table 5.3 (Pentium M 1.5 GHz): {min(TABLE_5_3_MS)}-{max(TABLE_5_3_MS)} ms, "
          f"{1000 / max(TABLE_5_3_MS):.1f}-{1000 / min(TABLE_5_3_MS):.1f} frames/s; "
          "high-speed setting ~7 ms, > 140 frames/s")
    for size in ((160, 120), (320, 240)):
        cam = DownwardCamera(width=size[0], height=size[1])
        images = frames_along("cable", cam, 1.5, args.frames)
        t0 = time.process_time()
        frames_along("cable", cam, 1.5, 10)
        render = 100 * (time.process_time() - t0)
        for label, particles, variances in (
                ("Table 5.1, 500 particles", 500, {}),
                ("high-speed: 300 particles, filter 5 px", 300, {"filter_size": 5})):
            tracker = CableTracker(*size, particles=particles,
                                   variances={**TABLE_5_1, **variances}, seed=2)
            tracker.start_at(0.0, 0.0, 12.0 * size[0] / 160, 0.0)
            cpu, wall, hits = timed(tracker.step, images)
            print(f"  cable {size[0]}x{size[1]} {label}: {cpu:.2f} ms ({wall:.2f}), "
                  f"{1000 / cpu:.0f} frames/s; cable seen in {hits}/{len(images)} frames; "
                  f"rendering {render:.1f} ms a frame")
    print("  Foresti, §VII (2 x Pentium II 400 MHz): 4 frames/s at 256x256")
    for size in ((160, 120), (256, 256)):
        cam = DownwardCamera(width=size[0], height=size[1])
        images = frames_along("pipeline", cam, 2.0, args.frames)
        line = default_scene().line("pipeline")
        assert line is not None
        model = PipeModel(line.diameter, cam.focal, *size)
        tracker = PipelineTracker.start(model, 2.0 - line.diameter / 2, math.pi / 2 - cam.tilt)

        def step(image: np.ndarray, tracker: PipelineTracker = tracker) -> bool:
            tracker.predict(0.25, 0.4, 0.0)
            return tracker.step(image)

        cpu, wall, hits = timed(step, images)
        print(f"  pipeline {size[0]}x{size[1]}: {cpu:.2f} ms ({wall:.2f}), "
              f"{1000 / cpu:.0f} frames/s; pipe measured in {hits}/{len(images)} frames")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
