"""Benchmark: the timed model (petri/verification/timed.py) against the untimed reachability graph.

For each mission it prints, measured in this one run: the untimed graph's markings and arcs
(:func:`petri.verification.reachability.explore`) and the timed model's markings and state classes
(:func:`petri.verification.timed.explore_timed`), each with the external stop (``Mission.abort`` at any
time, as the verifier explores the net) and without it (the main model), and the median
seconds of each (median of ``--runs``, after a warm-up run so that numba's compilation is
not counted).

    .venv/bin/python bench/bench_timed.py [--runs 5] [MISSION.mcl ...]
"""

from __future__ import annotations

import argparse
import copy
import statistics
import sys
import time
from collections.abc import Callable
from functools import partial
from pathlib import Path
from typing import Any

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from mcl.api import compile_file
from petri.verification.reachability import explore
from petri.semantics import MISSION_ABORT
from petri.verification.timed import explore_timed

DEFAULT = [REPO / "missions" / "dam_inspection.mcl"]


def median_seconds(run: Callable[[], Any], runs: int) -> tuple[float, Any]:
    result = run()  # warm-up
    times = []
    for _ in range(runs):
        start = time.perf_counter()
        result = run()
        times.append(time.perf_counter() - start)
    return statistics.median(times), result


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("missions", nargs="*", type=Path, default=DEFAULT)
    ap.add_argument("--runs", type=int, default=5)
    args = ap.parse_args(argv)
    print(f"{'mission':<22} {'model':<26} {'markings':>9} {'arcs/classes':>13} {'seconds':>9}")
    print("-" * 83)
    for path in args.missions:
        net = compile_file(str(path)).net
        no_stop = copy.copy(net)
        no_stop.transitions = [t for t in net.transitions if t.event != MISSION_ABORT]
        rows: list[tuple[str, Callable[[], Any]]] = [
            ("untimed (with the stop)", partial(explore, net)),
            ("untimed (without the stop)", partial(explore, no_stop)),
            ("timed (without the stop)", partial(explore_timed, net)),
            ("timed (with the stop)", partial(explore_timed, net, stop=True))]
        for label, run in rows:
            seconds, space = median_seconds(run, args.runs)
            size = space.classes if hasattr(space, "classes") else space.n_arcs
            done = "" if space.complete else " (limit)"
            print(f"{path.stem:<22} {label:<26} {space.n_markings:>9} {size:>13} "
                  f"{seconds:>9.4f}{done}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
