"""Each block's state at each instant of a run (mission/blocks.py), read off the firings.

The dam mission on its scripted vehicles (missions/vehicles/): GoTo takes 40 s,
AchieveHeadDist 15 s, WallInspection 1680 s, Surface 25 s; dam_leak.toml raises
``Alarms.leak`` at 600 s. The expected states are written below, from the mission's text,
before they are asserted.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest

from mcl.api import Compiled, compile_file
from mission import run_mission
from mission.vehicle import Vehicle
from mission.blocks import MISSION_KEY, STATES, BlockStates, key_of
from petri.execution.player import Record
from tests.support import MISSIONS, write
from vehicle.scripted import ScriptedVehicle, load_script
from vehicle_adapters.inprocess import InProcess

DAM = MISSIONS / "dam_inspection.mcl"
SCRIPTS = MISSIONS / "vehicles"


def run(compiled: Compiled, script: Path, log: Path, *observers: Any) -> list[dict[str, Any]]:
    """The scripted run's log records (header first)."""
    run_mission(compiled, InProcess(ScriptedVehicle(load_script(str(script)))), log=log,
                observers=observers, verify=False)
    return [json.loads(line) for line in log.read_text("ascii").splitlines()]


@pytest.fixture(scope="module")
def dam() -> Compiled:
    return compile_file(str(DAM), require_values=True)


def by_line(compiled: Compiled, states: dict[Any, str]) -> dict[int, str]:
    """Each task call's state, by its line (every call of the dam is on a line of its own)."""
    return {c.span.line: states.get(key_of(c), "waiting") for c in compiled.mission.calls()}


def test_the_dam_run_block_by_block(dam: Compiled, tmp_path: Path) -> None:
    states = BlockStates(dam.net).read(run(dam, SCRIPTS / "dam.toml", tmp_path / "r.jsonl"))
    # t = 20: StartLogs(enable) 32 ok; GoTo 34 and Alarms 49 running; the rest waiting
    at = by_line(dam, states.at(20))
    assert at == {32: "ok", 34: "running", 35: "waiting", 36: "waiting", 38: "waiting",
                  39: "waiting", 40: "waiting", 42: "waiting", 44: "waiting", 46: "waiting",
                  47: "waiting", 49: "running", 51: "waiting", 53: "waiting", 56: "waiting"}
    # t = 100: GoTo ended 40, AchieveHeadDist 55; the survey and its CATCH run
    at = by_line(dam, states.at(100))
    assert {k: at[k] for k in (34, 35, 36, 38, 39, 40, 42, 49)} == {
        34: "ok", 35: "ok", 36: "ok", 38: "ok", 39: "running", 40: "waiting",
        42: "running", 49: "running"}
    # the end (1775 s): every call of the body ok, the two watchers aborted by their TRY's
    # end, the handlers never ran
    end = states.at(1e9)
    at = by_line(dam, end)
    assert {line for line, s in at.items() if s == "ok"} == {32, 34, 35, 36, 38, 39, 40, 46,
                                                              47, 53}
    assert {line for line, s in at.items() if s == "aborted"} == {42, 49}
    assert {line for line, s in at.items() if s == "waiting"} == {44, 51, 56}
    assert end[MISSION_KEY] == "ok" and states.at(1774.0)[MISSION_KEY] == "running"
    assert set(end.values()) <= set(STATES)


def test_a_leak_aborts_the_survey_and_the_catch_surfaces(dam: Compiled, tmp_path: Path) -> None:
    states = BlockStates(dam.net).read(run(dam, SCRIPTS / "dam_leak.toml", tmp_path / "r.jsonl"))
    # t = 599: surveying; t = 610: the leak (600) ended Alarms fail and aborted the inner TRY,
    # the outer DO's Surface runs; t = 700: it surfaced (625), the mission ended ok
    assert by_line(dam, states.at(599))[39] == "running"
    at = by_line(dam, states.at(610))
    assert (at[39], at[42], at[49], at[51], at[46]) == (
        "aborted", "aborted", "fail", "running", "waiting")
    at = by_line(dam, states.at(700))
    assert (at[51], at[47], at[53]) == ("ok", "waiting", "ok")
    inner_try = next(b for b in dam.mission.body.items[1].try_.items  # type: ignore[union-attr]
                     if type(b).__name__ == "TryCatchDo")
    assert states.at(700)[key_of(inner_try)] == "aborted"
    assert states.at(700)[MISSION_KEY] == "ok"


def test_live_and_from_the_log_agree(dam: Compiled, tmp_path: Path) -> None:
    """As a player observer (the player's own clock, offset) it keeps the same changes as
    when it reads the run's log."""
    live = BlockStates(dam.net)
    records = run(dam, SCRIPTS / "dam_leak.toml", tmp_path / "r.jsonl", live)
    logged = BlockStates(dam.net).read(records)
    assert len(live.changes) == len(logged.changes) > 20
    for a, b in zip(live.changes, logged.changes):
        assert (a.block, a.state) == (b.block, b.state) and a.t == pytest.approx(b.t, abs=1e-3)
    shifted = BlockStates(dam.net)
    for r in records[1:]:
        shifted(Record(r["t"] + 1000.0, r["kind"], r))
    assert [(c.t, c.state) for c in shifted.changes] == [(c.t, c.state) for c in logged.changes]


def test_a_loop_shows_its_last_round(tmp_path: Path) -> None:
    """A WHILE's body runs once per round: its state is that of the round under way."""
    source = write(tmp_path, "MISSION {\n    WHILE { A() } DO {\n        B()\n    }\n}\n")
    compiled = compile_file(str(source), [str(MISSIONS.parent / "mcl" / "tasks" /
                                              "generic.tasks")])
    states = BlockStates(compiled.net)
    fires = {t.name: i for i, t in enumerate(compiled.net.transitions)}
    work = next(c for c in compiled.mission.calls() if c.name == "B")
    starts = [i for name, i in fires.items() if name.startswith("B@") and ".start" in name]
    oks = [i for name, i in fires.items() if name.startswith("B@") and ".ok" in name]
    assert starts and oks, sorted(fires)
    states.fired(starts[0], 1.0)
    states.fired(oks[0], 2.0)
    states.fired(starts[0], 3.0)
    assert states.at(2.5)[key_of(work)] == "ok"
    assert states.at(3.0)[key_of(work)] == "running"
    assert key_of(work) not in states.at(0.5)


class Feed:
    """A status feed (as the Zenoh adapter is one): keeps what the player publishes."""

    run = "run-1"

    def __init__(self) -> None:
        self.published: list[dict[str, Any]] = []

    def publish_status(self, status: dict[str, Any]) -> None:
        self.published.append(status)


def test_the_published_status_carries_each_blocks_state(dam: Compiled, tmp_path: Path) -> None:
    """What ``mcl view --zenoh`` reads: each status names the state of every block started so
    far, as the log's firings so far give it."""
    feed = Feed()
    vehicle = Vehicle(InProcess(ScriptedVehicle(load_script(str(SCRIPTS / "dam_leak.toml")))),
                      status=feed)
    run_mission(dam, vehicle, log=tmp_path / "r.jsonl", verify=False)
    fires = [json.loads(line) for line in (tmp_path / "r.jsonl").read_text().splitlines()
             if '"kind":"fire"' in line]
    assert len(feed.published) > 10
    for status in feed.published:  # as the firings so far give them
        expected = BlockStates(dam.net).read(fires[:status["fired"]]).now()
        assert status["blocks"] == expected, status
    assert feed.published[-1]["blocks"]["task@49:9"] == "fail"
