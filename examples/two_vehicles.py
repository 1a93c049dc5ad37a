"""Two missions on two simulated vehicles, side by side in one process: one call each.

    .venv/bin/python examples/two_vehicles.py [FOLDER]

Each mission is compiled and run by :func:`mission.run_mission` in a thread of its own, on a
simulated Ictineu of its own (:func:`mission.simulated_vehicle`, each with its seed); each run
writes its log into FOLDER (default ``out/runs``) and returns a :class:`mission.RunResult`.
Nothing is shared between the two runs, so each ends exactly as it would alone
(tests/mission/test_concurrent.py checks it). The exit status is the worse of the two
(docs/EXIT.md).
"""

from __future__ import annotations

import sys
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

from mcl.api import compile_file
from mission import RunResult, run_mission, simulated_vehicle

MISSIONS = Path(__file__).resolve().parent.parent / "missions"
FLEET = [  # (mission, the seed of its vehicle)
    (MISSIONS / "every_construct.mcl", 1),
    (MISSIONS / "pipeline_inspection.mcl", 2),
]


def run_one(mission: Path, seed: int, folder: Path) -> RunResult:
    """One mission on a simulated vehicle of its own: compile, run, return the result."""
    compiled = compile_file(str(mission), require_values=True)
    return run_mission(compiled, simulated_vehicle(seed=seed),
                       log=folder / f"{mission.stem}-seed{seed}.jsonl")


def main(argv: list[str]) -> int:
    folder = Path(argv[0]) if argv else Path("out/runs")
    with ThreadPoolExecutor(max_workers=len(FLEET)) as pool:
        runs = [pool.submit(run_one, mission, seed, folder) for mission, seed in FLEET]
        results = [r.result() for r in runs]
    for r in results:
        print(f"{r.mission}: ended {r.status.upper()} after {r.time:.1f} s of mission time "
              f"({r.firings} firings), exit {r.exit}, run log {r.log}")
    return max(r.exit for r in results)


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
