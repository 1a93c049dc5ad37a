"""Benchmark: ``mcl run missions/dam_inspection.mcl`` with its images and mosaic, whole process.

Issue 27's target: the dam mission on the simulated Ictineu, default options (its 1,329 camera
images rendered and written, the photomosaic built and measured against ground truth), in at
most 15 s of wall time on a 2-core machine. Each run is a whole ``mcl run`` process; this
prints the median of ``--runs`` runs of:

* wall time (s), and the CPU time of the process and its children (user + sys: what the load
  of the machine changes least);
* the peer in the same run: the same mission with ``--no-images`` (the simulation alone, the
  floor of any run with images), and the ratio;
* with ``--compare TREE`` (a checkout of another commit, e.g. ``git archive REV | tar -x -C
  TREE``), that tree's runs too, interleaved with these (the machine's load falls on both),
  and the median of the differences round by round (this machine's speed drifts by 10 % and
  more within minutes: a round's two runs see the same moment);
* the mosaic's figures against ground truth of every run, which must not change;
* the machine: its cores and load average before and after.

    python bench/bench_dam_run.py [--runs 3] [--compare TREE]
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
REPO = HERE.parent
DAM = REPO / "missions" / "dam_inspection.mcl"
TARGET_S = 15.0
FIGURES = ("registration_error_px", "alignment_error_mm", "alignment_error_without_prior_mm",
           "mosaic_error_mm", "control_points", "area_seen_m2", "pairs_registered")


def children_cpu() -> float:
    ru = resource.getrusage(resource.RUSAGE_CHILDREN)
    return ru.ru_utime + ru.ru_stime


def one_run(tree: Path, out: Path, images: bool) -> dict[str, object]:
    """One whole ``mcl run`` of the dam mission from ``tree``: wall, CPU, figures."""
    log = out / "run.jsonl"
    env = dict(os.environ, PYTHONPATH=str(tree))
    cmd = [sys.executable, "-m", "app.mcl", "run", str(DAM), "--quiet", "--log", str(log)]
    cmd += [] if images else ["--no-images"]
    cpu, start = children_cpu(), time.perf_counter()
    proc = subprocess.run(cmd, cwd=tree, env=env, capture_output=True, text=True, timeout=1800)
    wall, cpu = time.perf_counter() - start, children_cpu() - cpu
    if proc.returncode != 0:
        raise SystemExit(f"mcl run failed ({proc.returncode}): {proc.stderr[-2000:]}")
    figures: dict[str, object] = {}
    mosaic = out / "run.mosaic.json"
    if images and mosaic.exists():
        doc = json.loads(mosaic.read_text("utf-8"))
        figures = {k: doc.get(k) for k in FIGURES}
    return {"wall": wall, "cpu": cpu, "figures": figures}


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--runs", type=int, default=3)
    ap.add_argument("--compare", type=Path, metavar="TREE",
                    help="another checkout to run, interleaved (e.g. the commit before)")
    args = ap.parse_args()
    trees = {"this tree": REPO}
    if args.compare is not None:
        trees["compared"] = args.compare.resolve()
    load_before = os.getloadavg()
    runs: dict[tuple[str, bool], list[dict[str, object]]] = {}
    with tempfile.TemporaryDirectory(prefix="bench-dam-") as tmp:
        for i in range(max(1, args.runs)):
            for name, tree in trees.items():
                for images in (True, False):
                    out = Path(tmp) / f"{name.replace(' ', '_')}-{i}-{images}"
                    out.mkdir()
                    got = one_run(tree, out, images)
                    runs.setdefault((name, images), []).append(got)
                    print(f"  {name:<9} {'with images' if images else '--no-images':<12} run "
                          f"{i + 1}: {got['wall']:.1f} s wall, {got['cpu']:.1f} s CPU",
                          flush=True)
    load_after = os.getloadavg()
    print(f"\nmcl run {DAM.relative_to(REPO)} (simulated Ictineu, default options), "
          f"median of {args.runs}; {os.cpu_count()} cores, load average "
          f"{load_before[0]:.1f} before, {load_after[0]:.1f} after")
    print(f"{'':<34} {'wall s':>8} {'CPU s':>8} {'wall / sim':>11}")
    for name in trees:
        sim = statistics.median(float(r["wall"]) for r in runs[(name, False)])  # type: ignore[arg-type]
        for images in (True, False):
            rs = runs[(name, images)]
            wall = statistics.median(float(r["wall"]) for r in rs)  # type: ignore[arg-type]
            cpu = statistics.median(float(r["cpu"]) for r in rs)  # type: ignore[arg-type]
            label = f"{name}: {'images and mosaic' if images else 'simulation alone (peer)'}"
            note = ""
            if images:
                note = f"  target <= {TARGET_S:g} s: {'met' if wall <= TARGET_S else 'SHORT'}"
            print(f"{label:<34} {wall:8.1f} {cpu:8.1f} {wall / sim:10.2f}x{note}")
    if len(trees) > 1:  # each round against the compared tree's of the same round
        for images in (True, False):
            pairs = list(zip(runs[("this tree", images)], runs[("compared", images)]))
            wall = statistics.median(float(a["wall"]) - float(b["wall"])  # type: ignore[arg-type]
                                     for a, b in pairs)
            cpu = statistics.median(float(a["cpu"]) - float(b["cpu"])  # type: ignore[arg-type]
                                    for a, b in pairs)
            print(f"{'this tree - compared, ' + ('images' if images else 'alone'):<34} "
                  f"{wall:+8.1f} {cpu:+8.1f}  (median of the rounds' differences: a "
                  "machine whose speed drifts moves both of a round)")
    figures = {json.dumps(r["figures"], sort_keys=True) for (_, images), rs in runs.items()
               if images for r in rs}
    print(f"mosaic figures: {'the same in every run' if len(figures) == 1 else 'DIFFER'}: "
          + " | ".join(sorted(figures)))
    return 0 if len(figures) == 1 else 1


if __name__ == "__main__":
    sys.exit(main())
