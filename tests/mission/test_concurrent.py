"""Several missions at once in one process (issue 20): two missions on two simulated vehicles,
one thread each, end exactly as each ends alone — the same status, time and firings, and the
same run log record for record — and examples/two_vehicles.py does it from a script."""

from __future__ import annotations

import json
import subprocess
import sys
import threading
from pathlib import Path
from typing import Any

import pytest

from mcl.api import compile_file
from mission import RunResult, run_mission, simulated_vehicle
from tests.support import MISSIONS, REPO, budget, subprocess_env

FLEET = [(MISSIONS / "every_construct.mcl", 1), (MISSIONS / "pipeline_inspection.mcl", 2)]


def run_one(mission: Path, seed: int, log: Path) -> RunResult:
    compiled = compile_file(str(mission), require_values=True)
    return run_mission(compiled, simulated_vehicle(seed=seed), log=log)


def lines(log: Path) -> list[dict[str, Any]]:
    return [json.loads(line) for line in log.read_text("utf-8").splitlines()]


@pytest.mark.slow
def test_two_missions_in_two_threads_end_as_each_alone(tmp_path: Path) -> None:
    alone = [run_one(m, seed, tmp_path / f"alone-{m.stem}.jsonl") for m, seed in FLEET]
    together: list[RunResult | BaseException | None] = [None] * len(FLEET)

    def worker(i: int) -> None:
        mission, seed = FLEET[i]
        try:
            together[i] = run_one(mission, seed, tmp_path / f"together-{mission.stem}.jsonl")
        except BaseException as exc:  # noqa: BLE001 - reported by the assertion below
            together[i] = exc

    threads = [threading.Thread(target=worker, args=(i,)) for i in range(len(FLEET))]
    for t in threads:
        t.start()
    for t in threads:
        t.join(timeout=budget(60))
    assert not any(t.is_alive() for t in threads), "a run did not end"
    for one, both in zip(alone, together):
        assert isinstance(both, RunResult), both
        assert one.status == "ok", one  # both missions end OK on their simulated vehicle
        assert (both.mission, both.status, both.time, both.firings, both.exit, both.why) == (
            one.mission, one.status, one.time, one.firings, one.exit, one.why)
        assert one.log is not None and both.log is not None
        a, b = lines(one.log), lines(both.log)
        assert len(a) == len(b) > 20
        # the same records, digests included (a run log carries mission time only)
        assert a == b
    # two different runs, not one run seen twice
    assert alone[0].mission != alone[1].mission


@pytest.mark.slow
def test_the_example_runs_two_vehicles_side_by_side(tmp_path: Path) -> None:
    done = subprocess.run([sys.executable, str(REPO / "examples" / "two_vehicles.py"),
                           str(tmp_path)], capture_output=True, text=True, cwd=REPO,
                          env=subprocess_env(), timeout=budget(60))
    assert done.returncode == 0, done.stdout + done.stderr
    said = done.stdout.splitlines()
    assert [line.split(":")[0] for line in said] == ["every_construct", "pipeline_inspection"]
    assert all(" ended OK after " in line and "exit 0" in line for line in said), said
    for mission, seed in FLEET:
        log = tmp_path / f"{mission.stem}-seed{seed}.jsonl"
        assert lines(log)[-1]["kind"] == "end" and lines(log)[-1]["how"] == "ok"
