"""The mission status an operator sees (petri/execution/status.py), on the dam mission in process."""

from __future__ import annotations

from typing import Any

import pytest

from mcl.api import compile_file
from petri.execution.player import Player, Record
from petri.execution.runner import run
from petri.execution.status import MissionStatus, task_calls
from vehicle.control.stack import IctineuStack, StackConfig, parse_fault
from vehicle_adapters.inprocess import InProcess

from tests.support import MISSIONS

DAM = str(MISSIONS / "dam_inspection.mcl")


def run_dam(*faults: str) -> tuple[list[dict[str, Any]], list[Record], Player]:
    compiled = compile_file(DAM, require_values=True)
    player = Player(compiled.net)
    published: list[dict[str, Any]] = []
    records: list[Record] = []
    player.observers += [records.append,
                         MissionStatus(player, "dam_inspection", "r1", published.append)]
    stack = IctineuStack(StackConfig(seed=1, faults=[parse_fault(f) for f in faults]))
    with InProcess(stack) as vehicle:
        run(player, vehicle, "dam_inspection")
    return published, records, player


def test_task_calls_are_the_missions_in_source_order() -> None:
    player = Player(compile_file(DAM, require_values=True).net)
    calls = task_calls(player)
    # the last is the stop handler's (ON STOP { Surface() }): a call of the mission like any
    assert calls[0] == "StartLogs@32:5" and calls[-2:] == ["StartLogs@53:5", "Surface@56:5"]
    lines = [int(c.rpartition("@")[2].split(":")[0]) for c in calls]
    assert lines == sorted(lines) and len(calls) == len(set(calls)) == 15


@pytest.fixture(scope="module")
def watched() -> tuple[list[dict[str, Any]], list[Record], Player, list[dict[str, Any]]]:
    """The dam mission (seed 1) run once, watched by two operators' statuses: one published
    at each change, as run_dam's; one also every minute of mission time with the vehicle's
    progress. A status only reads the player and the vehicle: one run serves the two tests
    below, each reading its own (the run took 7 s of CPU each time)."""
    compiled = compile_file(DAM, require_values=True)
    player = Player(compiled.net)
    published: list[dict[str, Any]] = []
    ticked: list[dict[str, Any]] = []
    records: list[Record] = []
    player.observers += [records.append,
                         MissionStatus(player, "dam_inspection", "r1", published.append)]
    stack = IctineuStack(StackConfig(seed=1))
    with InProcess(stack) as vehicle:
        status = MissionStatus(player, "dam_inspection", "r1", ticked.append,
                               progress=vehicle.progress, every=60.0)
        player.observers.append(status)
        run(player, vehicle, "dam_inspection", rounds=[status.tick])
    return published, records, player, ticked


@pytest.mark.slow
def test_the_status_follows_the_survey_to_its_end(
        watched: tuple[list[dict[str, Any]], list[Record], Player, list[dict[str, Any]]]
        ) -> None:
    published, records, player, _ = watched
    first, last = published[0], published[-1]
    assert first["status"] == "running" and first["done"] == 0 and first["t"] == 0
    assert last["status"] == "ok" and last["running"] == [] and last["behaviours"] == []
    assert last["last_event"]["event"] == "GoTo.reached"
    assert last["fired"] == player.fired and last["run"] == "r1"
    # done = the task calls that fired a transition, against the records
    fired = {r.data["transition"].split(".")[0] for r in records if r.kind == "fire"}
    # never started: the two DO blocks' Surface() and the stop handler's
    assert last["done"] == len(fired & set(task_calls(player))) == last["total"] - 3
    # the survey was seen running, with the wall-keeping behaviour on, and time only grows
    surveying = [s for s in published
                 if any(r["task"] == "WallInspect@39:13" for r in s["running"])]
    assert surveying and all("AchieveHeadDist" in s["behaviours"] for s in surveying)
    times = [s["t"] for s in published]
    assert times == sorted(times) and 1000 < last["t"] < 1400
    assert [s["done"] for s in published] == sorted(s["done"] for s in published)


@pytest.mark.slow
def test_a_leak_shows_the_catch_running_and_the_surfacing() -> None:
    published, _, _ = run_dam("leak@600")
    running = {r["task"] for s in published for r in s["running"]}
    assert "Surface@51:9" in running  # Alarms' DO block ran
    assert published[-1]["status"] == "ok"  # the TRY's DO ended ok, so did the mission
    assert published[-1]["done"] < published[-1]["total"]


def run_timer_mission(tmp_path: Any) -> list[dict[str, Any]]:
    """A mission whose first call is a timer alone: ``Timeout(5 min)`` runs beside a
    ``Wait(2 min)`` that ends the PARALLEL ... OR first; no action, no event in between."""
    from vehicle.scripted import ScriptedVehicle, parse_script

    path = tmp_path / "timer.mcl"
    path.write_text("MISSION {\n    PARALLEL { Wait(2 min) } OR { Timeout(5 min) }\n}\n",
                    encoding="utf-8")
    player = Player(compile_file(str(path), require_values=True).net)
    published: list[dict[str, Any]] = []
    status = MissionStatus(player, "timer", "r1", published.append, every=30.0)
    player.observers.append(status)
    with InProcess(ScriptedVehicle(parse_script({}))) as vehicle:
        run(player, vehicle, "timer", rounds=[status.tick])
    return published


def test_a_timer_shows_while_it_runs_with_its_time_left(tmp_path: Any) -> None:
    # the case of issue 25: Timeout(5 min) left out of the running tasks until it was aborted
    published = run_timer_mission(tmp_path)
    seen = [r for s in published for r in s["running"] if r["task"].startswith("Timeout@")]
    assert seen, [s["running"] for s in published]
    first = seen[0]
    assert first["bound"] == 300.0 and first["left"] == pytest.approx(300.0, abs=0.1)
    wait = [r for s in published for r in s["running"] if r["task"].startswith("Wait@")]
    assert wait and wait[0]["bound"] == 120.0
    # the scripted vehicle's clock jumps from timer to timer: 2 min later Wait ended and the
    # OR aborted the Timeout, its time left then 3 min
    assert seen[-1]["left"] == pytest.approx(180.0, abs=0.1)
    assert published[-1]["status"] == "ok" and published[-1]["running"] == []


@pytest.mark.slow
def test_the_survey_reports_its_waypoint_and_distance_to_go(
        watched: tuple[list[dict[str, Any]], list[Record], Player, list[dict[str, Any]]]
        ) -> None:
    published = watched[3]  # the status with the vehicle's progress, every minute
    survey = [r["progress"] for s in published for r in s["running"]
              if r["task"] == "WallInspect@39:13" and "progress" in r]
    assert len(survey) >= 10  # one a minute of a survey of about 20 min
    assert all(p["of"] == 82 for p in survey)
    waypoints = [p["waypoint"] for p in survey]
    to_go = [p["to_go"] for p in survey]
    assert waypoints == sorted(waypoints) and waypoints[0] < 10 < 70 < waypoints[-1]
    assert to_go == sorted(to_go, reverse=True) and to_go[0] > 100 > 20 > to_go[-1]
