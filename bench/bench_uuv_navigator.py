"""Benchmark: the UUV's navigator of paper 003 §4 (vehicle/perception/uuv_navigator.py) with
its three ways of fusing a late sonar fix — naive, re-propagation, Larsen's correction.

* Cost per fix for each method against the paper's 100 ms step (§4.3: "a constant delay of 20
  samples ... the recalculation can be performed within the 100 ms sampling time"): the CPU
  time of ``fix()`` (``time.process_time``, so that other jobs on the machine do not inflate
  it), median and 99th percentile, at delays of 20 and 50 steps; a 10 Hz step (``predict``
  with compass and depth) beside it.
* Navigation error against ground truth (the horizontal distance between the estimate and the
  true position, RMS and median) for the three methods at loss 0, 0.3 and 0.5, on a simulated
  straight-line approach (tests/vehicle/perception/uuv_approach.py: released 32 m from the
  target, fixes every 2 s from 6 s on, 1.5-2.5 s late; the camera within 3 m). The error is
  taken over the sonar-guided leg (from the first fix to the camera's first sight, as in §2),
  pooled over the seeds. The simulated UUV has ``--model-error`` (default 10 %) more surge
  drag and inertia than the navigator's identified model, so that the filter's prediction is
  not the truth's (the current states absorb the difference). Beside the figures, the distance the UUV travels in one delay, by which the
  paper's argument expects the late-aware filters to beat the naive one.
* A picture: the median error over the seeds against time for the three methods at each loss,
  written to docs/uuv_navigator_error.svg (shown in the README).

    python bench/bench_uuv_navigator.py [--seeds 40] [--model-error 0.1] [--svg FILE]
"""

from __future__ import annotations

import argparse
import math
import platform
import sys
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent))

import numpy as np

from tests.vehicle.perception.uuv_approach import (Approach, Run, errors, guess, navigate,
                                                    simulate)
from vehicle.perception.uuv_model import PSI, U, UuvModel, X, Y
from vehicle.perception.uuv_navigator import METHODS, UuvNavigator

LOSSES = (0.0, 0.3, 0.5)
STEP_MS = 100.0  # the paper's control loop and filter step
COLOURS = {"naive": "#d62728", "repropagate": "#1f77b4", "larsen": "#2ca02c"}
DASHES = {"naive": "", "repropagate": "", "larsen": ' stroke-dasharray="5 4"'}  # on repropagate


def cost_per_fix(method: str, late_steps: int, fixes: int = 200) -> tuple[float, float]:
    """Median and 99th percentile CPU ms of one fix() that arrives late_steps steps after its
    ping, the filter having run at 10 Hz with compass and depth in between."""
    a = Approach()
    nav = UuvNavigator(method, x0=guess(a), gate=None, history=late_steps * 0.1 + 1.0)
    rng = np.random.default_rng(0)
    times, t = [], 0.0
    for _ in range(late_steps + 2):
        t += 0.1
        nav.predict(t, (25.0, 0.0, 0.0), -0.3, 2.0)
    for _ in range(fixes):
        for _ in range(20):  # a fix every 2 s
            t += 0.1
            nav.predict(t, (25.0, 0.0, 0.0), -0.3 + 0.01 * rng.standard_normal(), 2.0)
        # a fix 0.5 m from where the filter had the UUV at the ping, from an ASV 8 m off
        x = nav.steps[-1 - late_steps].x
        dx, dy = 8.0 + 0.5 * rng.standard_normal(), 0.5 * rng.standard_normal()
        asv = (float(x[X]) - 8.0, float(x[Y]))
        c0 = time.process_time()
        nav.fix(t - late_steps * 0.1, math.hypot(dx, dy, 2.0), math.atan2(dy, dx), asv, t)
        times.append((time.process_time() - c0) * 1000.0)
    return float(np.median(times)), float(np.percentile(times, 99))


def cost_per_step(steps: int = 2000) -> float:
    """Median CPU ms of one 10 Hz step: prediction, compass and depth."""
    nav = UuvNavigator("repropagate", x0=guess(Approach()))
    times = []
    for k in range(steps):
        c0 = time.process_time()
        nav.predict(0.1 * k, (25.0, 0.0, 0.0), -0.3, 2.0)
        times.append((time.process_time() - c0) * 1000.0)
    return float(np.median(times))


def sonar_leg(run: Run) -> list[int]:
    """The steps from the first fix's arrival to the camera's first sight."""
    first = next(i for i, tick in enumerate(run.ticks) if tick.fixes)
    seen = next((i for i, tick in enumerate(run.ticks) if tick.visual is not None), len(run.ticks))
    return list(range(first, seen))


def truth_model(error: float) -> UuvModel:
    """The simulated UUV: the navigator's model with ``error`` more surge drag and inertia."""
    m = UuvModel()
    return UuvModel(alpha_u=m.alpha_u * (1 + error), beta_u=m.beta_u * (1 + error),
                    beta_uu=m.beta_uu * (1 + error))


def errors_at(loss: float, seeds: int, truth: UuvModel
              ) -> tuple[dict[str, list[float]], dict[str, list[float]],
                         dict[str, list[list[float]]], list[float]]:
    """Per method: the pooled sonar-leg errors, their along-track parts (positive: the estimate
    ahead of the vehicle) and each run's error series; the distances travelled in one delay
    (speed x delay at each arrival)."""
    pooled: dict[str, list[float]] = {m: [] for m in METHODS}
    along: dict[str, list[float]] = {m: [] for m in METHODS}
    series: dict[str, list[list[float]]] = {m: [] for m in METHODS}
    travelled: list[float] = []
    a = Approach(loss=loss)
    for seed in range(seeds):
        run = simulate(a, seed, model=truth)
        leg = sonar_leg(run)
        for tick in run.ticks:
            for m in tick.fixes:
                travelled.append(float(tick.truth[U]) * (m.t_now - m.t_ping))
        for method in METHODS:
            xs, _ = navigate(run, UuvNavigator(method, x0=guess(a)))
            e = errors(run, xs)
            horizontal = np.hypot(e[:, X], e[:, Y])
            pooled[method].extend(float(h) for h in horizontal[leg])
            psi = np.array([run.ticks[i].truth[PSI] for i in leg])
            along[method].extend(float(v) for v in
                                 e[leg, X] * np.cos(psi) + e[leg, Y] * np.sin(psi))
            series[method].append([float(h) for h in horizontal])
    return pooled, along, series, travelled


def median_series(runs: list[list[float]]) -> list[float]:
    """The median over the runs at each step, while at least half of them are still going."""
    out = []
    for k in range(max(len(r) for r in runs)):
        values = [r[k] for r in runs if len(r) > k]
        if 2 * len(values) < len(runs):
            break
        out.append(float(np.median(values)))
    return out


def svg(panels: list[tuple[float, dict[str, list[float]]]], dt: float) -> str:
    """Three panels (one per loss), the median error of each method against time."""
    w, h, left, top, bottom = 300, 220, 44, 28, 34
    width = left + len(panels) * (w + 16)
    height = top + h + bottom + 22
    peak = max(max(s) for _, series in panels for s in series.values())
    ymax = math.ceil(min(peak, 8.0))
    tmax = max(len(s) for _, series in panels for s in series.values()) * dt
    out = [f'<svg xmlns="http://www.w3.org/2000/svg" width="{width}" height="{height}" '
           f'font-family="sans-serif" font-size="11">',
           f'<rect width="{width}" height="{height}" fill="white"/>']
    for p, (loss, series) in enumerate(panels):
        x0 = left + p * (w + 16)

        def px(t: float, e: float, x0: float = x0) -> str:
            return f"{x0 + t / tmax * w:.1f},{top + h - min(e, ymax) / ymax * h:.1f}"

        out.append(f'<rect x="{x0}" y="{top}" width="{w}" height="{h}" fill="none" '
                   f'stroke="#888"/>')
        out.append(f'<text x="{x0 + w / 2}" y="{top - 10}" text-anchor="middle">loss {loss:g}'
                   '</text>')
        for e in range(0, ymax + 1, 1 if ymax <= 4 else 2):
            y = top + h - e / ymax * h
            out.append(f'<line x1="{x0}" y1="{y:.1f}" x2="{x0 + w}" y2="{y:.1f}" '
                       f'stroke="#eee"/>')
            if p == 0:
                out.append(f'<text x="{x0 - 6}" y="{y + 4:.1f}" text-anchor="end">{e}</text>')
        for t in range(0, int(tmax) + 1, 10):
            out.append(f'<text x="{x0 + t / tmax * w:.1f}" y="{top + h + 14}" '
                       f'text-anchor="middle">{t}</text>')
        for method, s in series.items():
            points = " ".join(px(k * dt, e) for k, e in enumerate(s))
            out.append(f'<polyline points="{points}" fill="none" stroke="{COLOURS[method]}" '
                       f'stroke-width="1.5"{DASHES[method]}/>')
    out.append(f'<text x="{left - 34}" y="{top + h / 2}" transform="rotate(-90 {left - 34} '
               f'{top + h / 2})" text-anchor="middle">position error, m (median)</text>')
    out.append(f'<text x="{width / 2}" y="{top + h + 30}" text-anchor="middle">time since '
               'release, s</text>')
    for i, method in enumerate(METHODS):
        x = left + 10 + i * 120
        out.append(f'<line x1="{x}" y1="{height - 8}" x2="{x + 20}" y2="{height - 8}" '
                   f'stroke="{COLOURS[method]}" stroke-width="2"{DASHES[method]}/>')
        out.append(f'<text x="{x + 24}" y="{height - 4}">{method}</text>')
    out.append("</svg>")
    return "\n".join(out) + "\n"


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--seeds", type=int, default=40, help="approaches per loss (default 40)")
    ap.add_argument("--model-error", type=float, default=0.1,
                    help="how much more surge drag and inertia the simulated UUV has than the "
                    "navigator's model (default 0.1)")
    ap.add_argument("--svg", type=Path, default=HERE.parent / "docs" / "uuv_navigator_error.svg",
                    help="where to write the error-over-time picture")
    args = ap.parse_args()
    if args.seeds < 1:
        print("bench_uuv_navigator: --seeds must be at least 1", file=sys.stderr)
        return 2
    print(f"bench_uuv_navigator: {platform.processor() or platform.machine()}, "
          f"Python {platform.python_version()}")
    print(f"  one 10 Hz step (predict + compass + depth): {cost_per_step():.3f} ms CPU")
    for late in (20, 50):
        for method in METHODS:
            med, p99 = cost_per_fix(method, late)
            print(f"  fix {late} steps late, {method:>11}: {med:.3f} ms CPU median, "
                  f"{p99:.3f} ms 99th pct ({100.0 * p99 / STEP_MS:.1f} % of the 100 ms step)")
    panels = []
    for loss in LOSSES:
        pooled, along, series, travelled = errors_at(loss, args.seeds, truth_model(args.model_error))
        print(f"  loss {loss:g}, {args.seeds} approaches: one delay = "
              f"{np.median(travelled):.2f} m travelled (median)")
        for method in METHODS:
            e = np.array(pooled[method])
            print(f"    {method:>11}: RMS {math.sqrt(float(np.mean(e ** 2))):.2f} m, "
                  f"median {float(np.median(e)):.2f} m, 95th pct {np.percentile(e, 95):.2f} m; "
                  f"along-track median {float(np.median(along[method])):+.2f} m")
        panels.append((loss, {m: median_series(series[m]) for m in METHODS}))
    args.svg.write_text(svg(panels, Approach().dt))
    print(f"  written {args.svg}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
