"""Faults injected into the simulated vehicle stack (vehicle/control/stack.py) on the dam mission:
a leak, an overtemperature, an overpressure each run the mission's CATCH to the surface; a fault
changes nothing before it happens; nothing is left enabled at the end; and the same through the
real ``mcl run --inject``. The runs: tests/dam_runs.py (made once per test run, shared with
test_stack.py and test_stack_determinism.py). Nothing here depends on wall-clock time.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from pathlib import Path

import pytest

from petri.execution.runlog import read_log
from tests.dam_runs import DamRuns, Run
from tests.support import cli
from tests.vehicle.control.test_stack import SVG, no_traceback
from vehicle.control.stack import DT


@pytest.fixture(scope="module")
def runs(dam_runs: DamRuns) -> DamRuns:
    """The dam mission, once per case (lazily: each test asks only for what it needs), made
    once per test run (tests/dam_runs.py). This file's own runs are made first: meanwhile
    another worker may be making the good survey ("dam") that this file compares them with."""
    for case in ("leak@600", "overtemperature@300", "overpressure@300"):
        dam_runs[case]  # noqa: B018 (made now, kept in dam_runs)
    return dam_runs


@pytest.mark.slow
def test_no_behaviour_is_left_active_at_the_end(runs: dict[str, Run]) -> None:
    for case in ("dam", "leak@600"):
        stack = runs[case].stack
        assert {n: b.active for n, b in stack.behaviours.items()} == {
            n: False for n in stack.behaviours}, case
        assert not stack.sensors.camera.on, case


@pytest.mark.slow
def test_a_fault_changes_nothing_before_it_happens(runs: dict[str, Run]) -> None:
    # every sensor draws from its own stream: the housing's fault leaves the rest unchanged
    ok, leak = runs["dam"].stack.survey.truth, runs["leak@600"].stack.survey.truth
    before = [p for p in ok if p[0] <= 599.0]
    assert before == leak[:len(before)]


# --- faults ---------------------------------------------------------------------------------
@pytest.mark.slow
def test_a_leak_at_600_s_runs_the_catch_and_surfaces(runs: dict[str, Run]) -> None:
    r = runs["leak@600"]
    assert r.outcome.status == "ok", r.outcome  # the CATCH ... DO handles it
    causes = r.causes()
    assert [c for _, c in causes] == ["GoTo.reached", "AchieveHeadDist.achieved", "Alarms.leak",
                                      "Surface.surfaced"]
    leak_t = causes[2][0]
    assert 600.0 <= leak_t <= 600.0 + 1.0 + 2 * DT  # the housing monitor reads at 1 Hz
    assert causes[3][0] - leak_t < 300.0  # within the Surface task's 5 min
    assert r.stack.robot.state.z < 0.5  # true depth
    # the survey was cut short: no WallInspection.done, no recovery GoTo
    assert "WallInspection.done" not in r.events()
    actions = [(rec.data["action"], rec.data["behaviour"]) for rec in r.records
               if rec.kind == "action" and rec.t >= leak_t]
    assert ("disable", "WallInspection") in actions and ("enable", "Surface") in actions
    assert actions.index(("disable", "WallInspection")) < actions.index(("enable", "Surface"))


@pytest.mark.slow
@pytest.mark.parametrize("fault, alarm_after", [("overtemperature", 60.0),
                                                ("overpressure", 50.0)])
def test_overtemperature_and_overpressure_run_the_catch_too(runs: dict[str, Run], fault: str,
                                                            alarm_after: float) -> None:
    # from 20 deg C at 0.5 deg C/s over 50 deg C; from 1.0 bar at 0.01 bar/s over 1.5 bar
    r = runs[f"{fault}@300"]
    assert r.outcome.status == "ok", r.outcome
    causes = r.causes()
    assert [c for _, c in causes] == ["GoTo.reached", "AchieveHeadDist.achieved",
                                      f"Alarms.{fault}", "Surface.surfaced"]
    assert causes[2][0] == pytest.approx(300.0 + alarm_after, abs=3.0)
    assert r.stack.robot.state.z < 0.5
    assert not any(b.active for b in r.stack.behaviours.values())


@pytest.mark.slow
def test_mcl_run_with_a_leak_exits_0_reports_the_survey_and_replays(tmp_path: Path) -> None:
    log = tmp_path / "dam_leak.jsonl"
    # 100 s: 76 s into the survey (the in-process runs above take the leak at 600 s)
    result = cli("mcl", "run", "missions/dam_inspection.mcl", "--inject", "leak@100",
                 "--log", str(log), "--quiet", "--no-images")  # the mosaic: test_mosaic.py
    assert result.returncode == 0, result.stdout + result.stderr
    no_traceback(result)
    out = result.stdout
    assert "mission dam_inspection ended OK" in out
    assert f"run log: {log}" in out
    assert "path " in out and " m; wall imaged " in out and "in two or more" in out
    assert "navigator error " in out and "wall tracker error " in out
    plot = log.with_suffix(".svg")
    assert f"trajectory plot: {plot}" in out
    assert "→" not in out  # --quiet: no timeline
    assert plot.exists()
    assert ET.parse(plot).getroot().findall(f"{SVG}polyline")
    assert [r.get("event") for r in read_log(log) if r.get("kind") == "event"] == [
        "GoTo.reached", "AchieveHeadDist.achieved", "Alarms.leak", "Surface.surfaced"]
    replay = cli("mcl", "replay", str(log), "missions/dam_inspection.mcl")
    assert replay.returncode == 0, replay.stdout + replay.stderr
    assert "conforms" in replay.stdout
