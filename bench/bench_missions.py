"""Benchmark: mclc on missions, whole process, median of runs; pm4py as the peer.

For each mission (the shipped dam mission, generated surveys of 10, 100 and 1,000 task calls,
and PARALLEL fans of 4, 8, 16 and 32 branches) this prints the median wall time of a whole
`mclc` process, the method it chose, and — where the explicit state space fits — the time
pm4py takes to build the reachability graph of the same net (read from our PNML), measured in
the same run. Targets (issue 3): dam mission under 0.3 s, 1,000 tasks under 2 s.

    python bench/bench_missions.py [--runs 3]
"""

from __future__ import annotations

import argparse
import json
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
REPO = HERE.parent
sys.path.insert(0, str(HERE))
from generate import fan, survey

MCLC = str(Path(sys.executable).parent / "mclc")
PEER_TIMEOUT = 60.0


def whole_process(path: Path, runs: int, *extra: str) -> tuple[float, dict]:
    times, report = [], {}
    for _ in range(runs):
        start = time.perf_counter()
        proc = subprocess.run([MCLC, str(path), "--json", *extra], capture_output=True,
                              text=True, timeout=600)
        times.append(time.perf_counter() - start)
        report = json.loads(proc.stdout) if proc.stdout.strip() else {"status": proc.stderr}
    return statistics.median(times), report


def pm4py_time(path: Path, workdir: Path) -> str:
    """pm4py's reachability graph of the same net, in a subprocess with a time limit."""
    pnml = workdir / (path.stem + ".pnml")
    subprocess.run([MCLC, str(path), "--no-verify", "--pnml", str(pnml)], check=True,
                   capture_output=True, timeout=120)
    code = ("import time, warnings, pm4py\n"
            "warnings.simplefilter('ignore')\n"
            "from pm4py.objects.petri_net.utils import reachability_graph as rg\n"
            f"net, im, _ = pm4py.read_pnml({str(pnml)!r})\n"
            "t = time.perf_counter(); ts = rg.construct_reachability_graph(net, im)\n"
            "print(time.perf_counter() - t, len(ts.states))\n")
    try:
        proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                              timeout=PEER_TIMEOUT)
    except subprocess.TimeoutExpired:
        return f"> {PEER_TIMEOUT:.0f} s"
    if proc.returncode != 0:
        return "failed: " + proc.stderr.strip().splitlines()[-1][:60]
    seconds, states = proc.stdout.split()
    return f"{float(seconds):.2f} s ({states} markings)"


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--runs", type=int, default=3)
    parser.add_argument("--no-peer", action="store_true")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        work = Path(tmp)
        missions = [("dam_inspection (paper)", REPO / "missions" / "dam_inspection.mcl")]
        for n in (10, 100, 1000):
            p = work / f"survey_{n}.mcl"
            p.write_text(survey(n))
            missions.append((f"survey, {n} tasks", p))
        for k in (4, 8, 16, 32):
            p = work / f"fan_{k}.mcl"
            p.write_text(fan(k))
            missions.append((f"PARALLEL of {k}", p))
        print(f"{'mission':24} {'mclc (median)':>14}  {'status':9} {'method':11} "
              f"{'markings':>9}  pm4py reachability graph (peer)")
        for label, path in missions:
            seconds, report = whole_process(path, args.runs)
            ver = report.get("verification", {})
            markings = ver.get("reachable_markings", 0)
            method = "explicit" if markings else "structural"
            peer = "—"
            if not args.no_peer and markings and markings <= 200_000:
                peer = pm4py_time(path, work)
            elif not args.no_peer and method == "structural":
                peer = "(too large to enumerate)"
            print(f"{label:24} {seconds:13.2f}s  {report.get('status', '?'):9} {method:11} "
                  f"{markings:>9}  {peer}", flush=True)


if __name__ == "__main__":
    main()
