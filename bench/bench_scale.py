"""Benchmark: cost grows with the mission, not its square (issue 11; not a test).

Each case is the whole ``mclc`` process as a user runs it (default ``--method auto``), median
of 3 runs, with the peak resident memory of each run (``os.wait4``), against a target:

* a 1,000-task sequence with 333 latching ``StartCamera(enable)`` and a final disable:
  <= 1 s and <= 300 MB;
* a 10,000-waypoint lawnmower survey (10,000 ``GoTo`` with the camera switched on before and
  off after): <= 10 s;
* the dam mission (missions/dam_inspection.mcl): <= 0.2 s, with ``python -c pass`` measured in
  the same run as the floor;
* Kanban-PT-00005 from ../shared/mcc (skipped, saying why, when absent) against its peer, a
  plain single-core breadth-first search in C (bench/peers/bfs.c, built here with ``cc -O2``;
  skipped, saying why, without a compiler), the two run in alternation so that the load of a
  shared machine hits both alike: at most the C time (wall clock), within 2x its memory.

Each line says ``met`` or ``SHORT``. Then, in this process, the size of each mission's net
(places, transitions, arcs), the markings of its explicit reachability graph where that is
affordable, and the bytes per marking of the two explicit engines (dense rows: one byte per
place; marked-place sets: a few machine words per token), for the method chooser's cost model.

    .venv/bin/python bench/bench_scale.py [--runs N] [--only NAME ...]
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import tarfile
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))
sys.path.insert(0, str(Path(__file__).resolve().parent))

from peers import c_explorer
from petri.formats.pnml import read_pnml

MCC = REPO.parent / "shared" / "mcc"
PYTHON = sys.executable
MCLC = [PYTHON, "-m", "app.mclc"]


def latched_sequence(n: int = 1000, every: int = 3) -> str:
    """n task calls: StartCamera(enable) every ``every`` calls (333 of 1,000), GoTo between,
    StartCamera(disable) last."""
    items = ["StartCamera(enable)" if i % every == 0 else f"GoTo(({i}, 0, 2, 0 deg))"
             for i in range(n - 1)]
    items.append("StartCamera(disable)")
    return "MISSION latched_%d {\n    %s\n}\n" % (n, ";\n    ".join(items))


def lawnmower(n: int = 10_000, leg: float = 50.0, spacing: float = 2.0) -> str:
    """A lawnmower survey of n waypoints (legs of ``leg`` m, ``spacing`` m apart) with the
    camera on around it."""
    points = []
    for i in range(n):
        lane, end = divmod(i, 2)
        y = leg * (end if lane % 2 == 0 else 1 - end)
        points.append(f"GoTo(({lane * spacing:g}, {y:g}, 5, 0 deg))")
    items = ["StartCamera(enable)", *points, "StartCamera(disable)"]
    return "MISSION lawnmower_%d {\n    %s\n}\n" % (n, ";\n    ".join(items))


@dataclass
class Case:
    name: str
    argv: list[str]
    seconds: float | None = None  # target
    megabytes: float | None = None
    path: Path | None = None


def run(argv: list[str]) -> tuple[float, float, int, float]:
    """(seconds, peak RSS in MB, exit status, CPU seconds) of one process."""
    start = time.perf_counter()
    proc = subprocess.Popen(argv, cwd=REPO, stdout=subprocess.DEVNULL,
                            stderr=subprocess.PIPE)
    _, status, usage = os.wait4(proc.pid, 0)
    seconds = time.perf_counter() - start
    proc.returncode = os.waitstatus_to_exitcode(status)
    if proc.stderr is not None:
        proc.stderr.close()
    return (seconds, usage.ru_maxrss / 1024, proc.returncode,
            usage.ru_utime + usage.ru_stime)


def measure(case: Case, runs: int) -> tuple[float, float, int, float]:
    results = [run(case.argv) for _ in range(runs)]
    return (statistics.median(r[0] for r in results), max(r[1] for r in results),
            results[-1][2], statistics.median(r[3] for r in results))


def verdict(value: float, target: float | None) -> str:
    if target is None:
        return ""
    return "met" if value <= target else "SHORT"


def sizes(case: Case) -> str:
    """Net size and reachability figures, computed in this process."""
    if case.path is None or case.path.suffix != ".mcl":
        return ""
    sys.path.insert(0, str(REPO))
    from mcl.api import compile_file
    from petri.verification.explore_bits import explore_bits

    start = time.perf_counter()
    net = compile_file(str(case.path)).net
    compiled = time.perf_counter() - start
    text = (f"{len(net.places):,} places, {len(net.transitions):,} transitions, "
            f"{net.arc_count():,} arcs (compiled in {compiled:.2f} s)")
    start = time.perf_counter()
    result = explore_bits(net, 2_000_000, dense=False)
    if result is None:
        return text + "; not 1-safe"
    markings = result[0]
    tokens = max(len(m) for m in markings)  # type: ignore[union-attr]
    dense = -(-len(net.places) // 8) * 8
    sparse = 56 + 8 * tokens + 100  # tuple header + items, index entry, parent and arcs
    return (text + f"; {len(markings):,} markings ({time.perf_counter() - start:.2f} s,"  # type: ignore[arg-type]
            f" at most {tokens} tokens): {dense:,} B/marking as dense rows, "
            f"~{sparse} B/marking as marked-place sets")


def against_c(work: Path, runs: int) -> None:
    """Kanban-PT-00005: the whole ``mclc`` process against the C peer, alternating."""
    kanban = MCC / "models" / "Kanban-PT-00005.tgz"
    if not kanban.is_file():
        print(f"\nKanban-PT-00005: skipped: {kanban} is absent")
        return
    with tarfile.open(kanban) as archive:
        archive.extractall(work, filter="data")
    pnml = work / "Kanban-PT-00005" / "model.pnml"
    binary, why = c_explorer.build(work)
    if binary is None:
        print(f"\nKanban-PT-00005 against C: skipped: {why}")
        return
    dump = work / "kanban.txt"
    c_explorer.write_dump(read_pnml(pnml), dump)
    ours: list[tuple[float, float, int, float]] = []
    peer: list[tuple[float, float, int, float]] = []
    for _ in range(runs):  # in alternation: a burst of load hits both alike
        ours.append(run([*MCLC, str(pnml)]))
        peer.append(run([str(binary), str(dump)]))
    print(f"\nKanban-PT-00005 (2,546,432 markings), whole process, median of {runs} runs in "
          f"alternation, load {os.getloadavg()[0]:.1f} on {os.cpu_count()} cores:")
    for name, results in (("mclc (--method auto)", ours), ("C BFS (cc -O2, 1 core)", peer)):
        print(f"  {name:<24} {statistics.median(r[0] for r in results):7.2f} s "
              f"(CPU {statistics.median(r[3] for r in results):6.2f} s) "
              f"{max(r[1] for r in results):7.0f} MB  exit {results[-1][2]}")
    time_ratio = (statistics.median(r[0] for r in ours)
                  / statistics.median(r[0] for r in peer))
    cpu_ratio = (statistics.median(r[3] for r in ours)
                 / statistics.median(r[3] for r in peer))
    memory_ratio = max(r[1] for r in ours) / max(r[1] for r in peer)
    print(f"  ours / C: time {time_ratio:.2f}x (target <= 1: {verdict(time_ratio, 1.0)}), "
          f"CPU {cpu_ratio:.2f}x, memory {memory_ratio:.2f}x "
          f"(target <= 2: {verdict(memory_ratio, 2.0)})", flush=True)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=3)
    parser.add_argument("--only", nargs="*", help="case names (default: all)")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        work = Path(tmp)
        latched = work / "latched_1000.mcl"
        latched.write_text(latched_sequence(), "utf-8")
        lawn = work / "lawnmower_10000.mcl"
        lawn.write_text(lawnmower(), "utf-8")
        dam = REPO / "missions" / "dam_inspection.mcl"
        cases = [
            Case("python -c pass (floor)", [PYTHON, "-c", "pass"]),
            Case("dam mission", [*MCLC, str(dam)], 0.2, None, dam),
            Case("1,000 tasks, 333 latches", [*MCLC, str(latched)], 1.0, 300.0, latched),
            Case("10,000-waypoint lawnmower", [*MCLC, str(lawn)], 10.0, None, lawn),
        ]
        if args.only:
            cases = [c for c in cases if any(o.lower() in c.name.lower() for o in args.only)]
        print(f"whole mclc process (--method auto), median of {args.runs} runs (wall clock, "
              f"and CPU time: on a shared machine the wall clock includes waiting for a core), "
              f"peak RSS of the largest run; {os.cpu_count()} cores, load "
              f"{os.getloadavg()[0]:.1f}\n")
        for case in cases:
            seconds, megabytes, status, cpu = measure(case, args.runs)
            parts = [f"{case.name:<28} {seconds:7.2f} s (CPU {cpu:6.2f} s) {megabytes:7.0f} MB"
                     f"  exit {status}"]
            if case.seconds is not None:
                parts.append(f"time <= {case.seconds:g} s: {verdict(seconds, case.seconds)}")
            if case.megabytes is not None:
                parts.append(f"memory <= {case.megabytes:g} MB: "
                             f"{verdict(megabytes, case.megabytes)}")
            print("  ".join(parts), flush=True)
        if not args.only or any(o.lower() in "kanban-pt-00005" for o in args.only):
            against_c(work, args.runs)
        print("\nsizes (for the method chooser's cost model):")
        for case in cases:
            if case.path is not None and case.path.suffix == ".mcl":
                print(f"  {case.name}: {sizes(case)}", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
