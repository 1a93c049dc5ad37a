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


@pytest.mark.slow
def test_the_status_follows_the_survey_to_its_end() -> None:
    published, records, player = run_dam()
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
