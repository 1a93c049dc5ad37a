"""The simulated runs that several test files compare against, each made once per test run.

A mission on :class:`IctineuStack` in process (the player, the in-process adapter, simulated
time), with its records, its stack at the end and its run log: :func:`run_mission`. The dam
mission's cases (:data:`CASES`: the good survey, the same again, faults, short runs) are made
through the ``once`` fixture (tests/conftest.py): ``dam_runs(once)["dam"]`` is the same run
for tests/vehicle/control/test_stack*.py, the Zenoh and the MAVLink adapters' tests, whichever
worker asks first. A run takes 5-10 s of CPU: made once, not once per file.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

from mcl.api import compile_file
from petri.execution.player import Player, Record
from petri.execution.runlog import RunLog, net_digest
from petri.execution.runner import Outcome, run
from tests.once import Once
from tests.support import MISSIONS
from vehicle.control.stack import IctineuStack, StackConfig
from vehicle_adapters.inprocess import InProcess

DAM = MISSIONS / "dam_inspection.mcl"


@dataclass
class Run:
    outcome: Outcome
    records: list[Record]
    stack: IctineuStack
    log: Path

    def causes(self) -> list[tuple[float, str]]:
        """What fired the transitions that did not fire immediately: events and timers."""
        return [(r.t, r.data["cause"]) for r in self.records
                if r.kind == "fire" and r.data["cause"] != "immediate"]

    def events(self) -> list[str]:
        return [r.data["event"] for r in self.records if r.kind == "event"]


def run_mission(path: Path, log: Path, seed: int = 1, faults: list[tuple[str, float]] | None = None,
                max_time: float = 86_400.0) -> Run:
    compiled = compile_file(str(path), require_values=True)
    name = compiled.mission.name or path.stem
    stack = IctineuStack(StackConfig(seed=seed, faults=faults or []))
    player = Player(compiled.net)
    records: list[Record] = []
    player.observers.append(records.append)
    header = {"mission": name, "net": net_digest(compiled.net), "seed": seed}
    with RunLog(log, header) as runlog, InProcess(stack) as vehicle:
        player.observers.append(runlog)
        outcome = run(player, vehicle, name, max_time=max_time)
    return Run(outcome, records, stack, log)


# The dam mission's cases: run_mission's keywords.
CASES: dict[str, dict[str, Any]] = {
    "dam": {},
    "dam again": {},
    "leak@600": {"faults": [("leak", 600.0)]},
    "overtemperature@300": {"faults": [("overtemperature", 300.0)]},
    "overpressure@300": {"faults": [("overpressure", 300.0)]},
    "seed 2, 60 s": {"seed": 2, "max_time": 60.0},
    "seed 1, 60 s": {"seed": 1, "max_time": 60.0},
}


class DamRuns(dict[str, Run]):
    """The dam mission's runs by case, each made on first use (once per test run)."""

    def __init__(self, once: Once) -> None:
        super().__init__()
        self.once = once

    def __missing__(self, case: str) -> Run:
        kw = CASES[case]

        def make(folder: Path) -> Run:
            return run_mission(DAM, folder / f"{case.replace(' ', '_')}.jsonl", **kw)

        result = self.once(f"dam run {case}", make)
        self[case] = result
        return result


# The dam mission on 3 m of the wall (make demo's short survey), as ``mcl run`` options: the same
# tasks, the camera on and off, the recovery, in about 200 s of mission time instead of 1200.
SHORT_SURVEY = ["--param", "path=[(0, 1), (0, 4), (0.75, 4), (0.75, 1), (1.5, 1), (1.5, 4), "
                "(2.25, 4), (2.25, 1), (3, 1), (3, 4)]",
                "--param", "recoveryPos=(-5, 1.5, 0.5, 0 deg)"]
