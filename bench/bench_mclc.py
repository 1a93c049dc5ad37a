"""Benchmark: ``mclc`` against its peer, a bare ``python -c pass``, in the same run (issue 27,
deliverable 2: mclc as quick as a linter; not a test).

Every case is a whole process as a user runs it (the ``mclc`` console script beside this
Python), the cases taken in turn round after round (so a change of the machine's load falls on
all alike), with the median of each over the rounds of: the CPU time (user + sys, of the
process and its threads: what the process costs, however busy the machine), the wall time,
and the largest peak resident memory. Each line gives its CPU time as a multiple of the bare
Python's, and ``met`` or ``SHORT`` against its target:

* the dam mission (missions/dam_inspection.mcl, verified), within 5x a bare Python's CPU both
  *warm* (unchanged since its last call: its report kept, app/kept_reports.py) and *cold*
  (edited before each call, a parameter changed: the grammars and the task library from the
  cache, the mission parsed and verified again: what a user who edits and checks pays);
  for comparison,
  the same with the cache off (MCL_CACHE_DIR='': the grammars and the task library rebuilt,
  the mission verified), and compiled only (``--no-verify``);
* a 1,000-task sequence with 333 latches (bench_scale.latched_sequence): <= 1 s, <= 300 MB,
  unchanged (its report kept from the call before) and edited before each call (a comment of
  its own: parsed, compiled and verified again);
* a 10,000-waypoint lawnmower survey (bench_scale.lawnmower): <= 10 s.

The cache (mcl/cache.py) is a folder of the benchmark's own, filled by a first call of each
case, as a user's first call fills theirs. The targets in seconds are held against the CPU time: mclc runs on one core, so on an idle
machine its wall time is its CPU time, and on a busy one the wall time measures the others.
The project's packages are byte-compiled first, as ``make`` does at install (where
PYTHONDONTWRITEBYTECODE is set, a module edited since would be compiled on every call).

    .venv/bin/python bench/bench_mclc.py [--runs N] [--only NAME ...] [--venv DIR]

``--venv DIR`` measures another installation: DIR's ``mclc`` against DIR's bare Python (a
non-editable ``pip install .``, whose bare Python starts faster than an editable one's, as
its site-packages loads no import hook: the ratio is stricter there). The packages are then
not byte-compiled here (pip compiled its copy).
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path

HERE = Path(__file__).resolve().parent
REPO = HERE.parent
sys.path.insert(0, str(HERE))
from bench_scale import latched_sequence, lawnmower

PYTHON = sys.executable
MCLC = str(Path(sys.executable).parent / "mclc")
PACKAGES = ("app", "mission", "mcl", "petri", "mosaic", "vehicle_adapters", "vehicle",
            "behaviours", "aal", "diagnostics")


@dataclass
class Case:
    name: str
    argv: list[str]
    cpu_ratio: float | None = None  # target: CPU time within this multiple of the peer's
    seconds: float | None = None  # target: wall time
    megabytes: float | None = None  # target: peak memory
    env: dict[str, str] = field(default_factory=dict)
    edit: Path | None = None  # a copy of the mission rewritten before each run
    original: Path | None = None  # what it is a copy of (default: the dam mission)
    runs: list[tuple[float, float, float, int]] = field(default_factory=list)

    def median(self, i: int) -> float:
        return statistics.median(r[i] for r in self.runs)


def run(case: Case) -> None:
    """One run of the case: (CPU seconds, wall seconds, peak MB, exit status) appended."""
    if case.edit is not None:
        stamp = f"{time.time_ns() % 10**9:09d}"  # a value no call has seen before
        if case.original is None:  # the dam: a new distance to the wall
            text = (REPO / "missions" / "dam_inspection.mcl").read_text("utf-8")
            case.edit.write_text(text.replace("= 1.5 m;", f"= 1.{stamp} m;", 1), "utf-8")
        else:  # a comment of its own at its end: parsed and verified again
            case.edit.write_text(case.original.read_text("utf-8") + f"// call {stamp}\n",
                                 "utf-8")
    start = time.perf_counter()
    proc = subprocess.Popen(case.argv, cwd=REPO, stdout=subprocess.DEVNULL,
                            stderr=subprocess.DEVNULL, env={**os.environ, **case.env})
    _, status, usage = os.wait4(proc.pid, 0)
    wall = time.perf_counter() - start
    case.runs.append((usage.ru_utime + usage.ru_stime, wall, usage.ru_maxrss / 1024,
                      os.waitstatus_to_exitcode(status)))


def verdict(value: float, target: float | None, what: str) -> str:
    if target is None:
        return ""
    return f"  {what} {target:g}: {'met' if value <= target else 'SHORT'}"


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=7, help="rounds (median of; at least 5)")
    parser.add_argument("--only", nargs="*", help="case names (default: all)")
    parser.add_argument("--venv", type=Path, help="measure this installation's mclc and "
                        "Python (default: this Python's)")
    args = parser.parse_args()
    runs = max(5, args.runs)
    python, mclc = PYTHON, MCLC
    if args.venv is not None:
        python, mclc = str(args.venv / "bin" / "python"), str(args.venv / "bin" / "mclc")
    else:
        subprocess.run([PYTHON, "-m", "compileall", "-q", *PACKAGES], cwd=REPO, check=True,
                       stdout=subprocess.DEVNULL)
    with tempfile.TemporaryDirectory() as tmp:
        work = Path(tmp)
        latched = work / "latched_1000.mcl"
        latched.write_text(latched_sequence(), "utf-8")
        lawn = work / "lawnmower_10000.mcl"
        lawn.write_text(lawnmower(), "utf-8")
        dam = str(REPO / "missions" / "dam_inspection.mcl")
        # a cache folder of the benchmark's own (a user's first call fills theirs alike):
        # the figures depend neither on what the user's holds nor on other programs using it
        os.environ["MCL_CACHE_DIR"] = str(work / "cache")
        peer = Case("python -c pass (the peer)", [python, "-c", "pass"])
        cases = [
            peer,
            Case("mclc dam mission", [mclc, dam], cpu_ratio=5.0),
            Case("mclc dam, edited each call", [mclc, str(work / "dam_edited.mcl")],
                 cpu_ratio=5.0, edit=work / "dam_edited.mcl"),
            Case("mclc dam, cache off", [mclc, dam], env={"MCL_CACHE_DIR": ""}),
            Case("mclc dam --no-verify", [mclc, dam, "--no-verify"]),
            Case("mclc 1,000 tasks, 333 latches", [mclc, str(latched)], seconds=1.0,
                 megabytes=300.0),
            Case("mclc 1,000 tasks, edited", [mclc, str(work / "latched_edited.mcl")],
                 seconds=1.0, megabytes=300.0, edit=work / "latched_edited.mcl",
                 original=latched),
            Case("mclc 10,000-waypoint lawnmower", [mclc, str(lawn)], seconds=10.0),
        ]
        if args.only:
            cases = [peer] + [c for c in cases[1:]
                              if any(o.lower() in c.name.lower() for o in args.only)]
        for case in cases[1:]:  # a first run fills the cache, as any user's first call does,
            run(case)  # and a second keeps its report (app/kept_reports.py)
            run(case)
            case.runs.clear()
        for _ in range(runs):
            for case in cases:
                run(case)
    print(f"whole processes, the cases in turn, median of {runs} rounds; CPU = user + sys "
          f"(the ratio: against the peer's); {os.cpu_count()} cores, load "
          f"{os.getloadavg()[0]:.1f}; {mclc}\n")
    floor = peer.median(0)
    for case in cases:
        cpu, wall, peak = case.median(0), case.median(1), max(r[2] for r in case.runs)
        ratio = cpu / floor
        line = (f"{case.name:<32} CPU {cpu:6.3f} s ({ratio:5.1f}x)  wall {wall:6.3f} s  "
                f"{peak:5.0f} MB  exit {case.runs[-1][3]}")
        line += verdict(ratio, case.cpu_ratio, "CPU x <=")
        line += verdict(cpu, case.seconds, "CPU s <=")
        line += verdict(peak, case.megabytes, "MB <=")
        print(line, flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
