"""mission/run.py: ``run_mission`` runs a compiled mission on a vehicle and returns what
happened; the run log it writes says the same (header, end record), a refusal before the start
writes nothing, a refusal once connected and a bug of ours are logged, a stop asked for is a
safe exit with the status it asks for."""

from __future__ import annotations

import json
import signal
from pathlib import Path
from typing import Any

import pytest

from aal.messages import Declaration
from behaviours import capabilities
from diagnostics import MclError
from mcl.api import Compiled, compile_file
from mission.exits import Exit
from mission.run import NotVerified, RunResult, Stop, run_mission
from mission.vehicle import Vehicle
from petri.execution.player import Record
from petri.execution.replay import check
from petri.execution.runlog import read_log, verify
from tests.support import MISSIONS, write
from vehicle.scripted import ScriptedVehicle, load_script
from vehicle_adapters.inprocess import InProcess

DAM = MISSIONS / "dam_inspection.mcl"
DAM_OK = MISSIONS / "vehicles" / "dam.toml"


def dam() -> Compiled:
    return compile_file(str(DAM), require_values=True)


def scripted(path: Path = DAM_OK, only: list[str] | None = None) -> InProcess:
    """The dam's scripted vehicle, declaring the Ictineu's behaviours (or ``only`` those)."""
    return InProcess(ScriptedVehicle(load_script(str(path))),
                     declaration=capabilities.ictineu("scripted", only))


def records(path: Path) -> list[dict[str, Any]]:
    return [json.loads(line) for line in path.read_text("utf-8").splitlines()]


def test_a_run_returns_what_its_end_record_says(tmp_path: Path) -> None:
    log = tmp_path / "run.jsonl"
    seen: list[Record] = []
    result = run_mission(dam(), scripted(), log=log, header={"vehicle": "scripted"},
                         observers=[seen.append])
    # the dam's scripted vehicle: every task does what it is asked, 1775 s on the wall
    assert isinstance(result, RunResult) and result.ok
    assert (result.mission, result.status, result.how, result.exit) == (
        "dam_inspection", "ok", "ok", Exit.OK)
    assert result.time == pytest.approx(1775.0) and result.firings == 41
    assert result.log == log and result.vehicle_clock is None
    recs = records(log)
    head, last = recs[0], recs[-1]
    assert (head["mission"], head["file"], head["vehicle"]) == ("dam_inspection", str(DAM),
                                                                "scripted")
    assert head["max_time"] == result.limit and result.limit_from.startswith("default:")
    assert (last["kind"], last["how"], last["why"], last["exit"]) == (
        "end", "ok", result.why, 0)
    assert last["t"] == result.time and last["switched_off"] == list(result.switched_off)
    # the observers saw every record the log holds between the header and the end record
    assert [r.kind for r in seen] == [r["kind"] for r in recs[1:-1]]
    verify(read_log(str(log)), str(log))
    assert check(dam().net, read_log(str(log)), {}).ok


def test_without_a_log_nothing_is_written_and_the_result_is_the_same(tmp_path: Path,
                                                                     monkeypatch: Any) -> None:
    monkeypatch.chdir(tmp_path)
    logged = run_mission(dam(), scripted(), log=tmp_path / "a" / "run.jsonl")
    bare = run_mission(dam(), scripted())
    assert bare.log is None and list(tmp_path.iterdir()) == [tmp_path / "a"]
    assert (bare.status, bare.time, bare.firings, bare.why) == (
        logged.status, logged.time, logged.firings, logged.why)


def test_a_vehicle_that_lacks_a_behaviour_is_refused_before_anything_is_written(
        tmp_path: Path) -> None:
    log = tmp_path / "run.jsonl"
    vehicle = scripted(only=["GoTo", "StartLogs", "Alarms", "Surface", "StartCamera",
                             "AchieveHeadDist"])  # no WallInspection
    with pytest.raises(MclError) as refused:
        run_mission(dam(), vehicle, log=log)
    assert "WallInspection" in refused.value.format() and "dam_inspection.mcl:39:" in \
        refused.value.format()
    assert not log.exists()


class Remote(InProcess):
    """An in-process vehicle whose declaration is only known once connected (as over a
    link), and then lacks what the dam mission needs."""

    def __init__(self) -> None:
        super().__init__(ScriptedVehicle(load_script(str(DAM_OK))))
        self.connected = False

    def __enter__(self) -> Remote:
        self.connected = True
        return self

    def declaration(self) -> Declaration | None:
        if not self.connected:
            return None
        return capabilities.ictineu("remote", ["GoTo", "StartLogs", "Alarms", "Surface"])


def test_a_refusal_once_connected_is_logged_with_exit_2(tmp_path: Path) -> None:
    log = tmp_path / "run.jsonl"
    with pytest.raises(MclError):
        run_mission(dam(), Remote(), log=log)
    last = records(log)[-1]
    assert (last["kind"], last["how"], last["exit"]) == ("end", "refused", Exit.INVALID)
    assert "needs behaviour" in last["why"] and "vehicle remote" in last["why"]
    assert [r["kind"] for r in records(log)] == ["header", "end"]  # nothing was sent


class Broken(InProcess):
    def __enter__(self) -> Broken:
        raise RuntimeError("a bug")


def test_a_bug_of_ours_is_logged_with_exit_3_and_raised(tmp_path: Path) -> None:
    log = tmp_path / "run.jsonl"
    with pytest.raises(RuntimeError, match="a bug"):
        run_mission(dam(), Broken(ScriptedVehicle(load_script(str(DAM_OK)))), log=log)
    last = records(log)[-1]
    assert (last["how"], last["exit"]) == ("error", Exit.INTERNAL)
    assert last["why"] == "internal error: RuntimeError: a bug"


def test_an_unverified_mission_is_refused_unless_told(tmp_path: Path) -> None:
    latch_left_on = compile_file(str(write(tmp_path, "MISSION { StartLogs(enable) }")),
                                 require_values=True)
    with pytest.raises(NotVerified) as refused:
        run_mission(latch_left_on, scripted(), log=tmp_path / "no.jsonl")
    assert refused.value.failed and not (tmp_path / "no.jsonl").exists()
    ran = run_mission(latch_left_on, scripted(), verify=False)
    assert ran.status == "ok" and ran.firings > 0


@pytest.mark.parametrize("asked, how, code", [
    ("the operator asked", "signal", Exit.UNDECIDED),
    (Stop("SIGTERM received", signal.SIGTERM), "signal", 128 + signal.SIGTERM),
])
def test_a_stop_aborts_the_run_with_the_status_it_asks_for(tmp_path: Path, asked: Any,
                                                           how: str, code: int) -> None:
    log = tmp_path / "run.jsonl"
    on: set[str] = set()

    def seen(record: Record) -> None:
        if record.kind == "action" and record.data["action"] == "enable":
            on.add(record.data["behaviour"])

    def stop() -> Any:  # once the survey is under way
        return asked if "WallInspection" in on else None

    result = run_mission(dam(), scripted(), log=log, stop=stop, observers=[seen])
    assert (result.status, result.how, result.exit) == ("stopped", how, code)
    reason = asked if isinstance(asked, str) else asked.reason
    assert result.reason == reason and "WallInspection" in result.switched_off  # by the abort
    last = records(log)[-1]
    assert (last["how"], last["exit"], last["switched_off"]) == (
        how, code, list(result.switched_off))


def test_the_time_limit_and_the_end_note(tmp_path: Path) -> None:
    result = run_mission(dam(), scripted(), log=tmp_path / "run.jsonl", max_time=100.0,
                         end_note=lambda: "a note of the caller")
    assert (result.status, result.how, result.exit) == ("timeout", "time limit",
                                                        Exit.UNDECIDED)
    # the limit stops the mission at 100 s; its ON STOP { Surface() } then runs (25 s here)
    assert result.stop_handler == {"how": "ended ok", "start": 100.0, "end": 125.0,
                                   "bound": 300.0}
    assert result.time == 125.0 and (result.limit, result.limit_from) == (100.0, "--max-time")
    assert result.why == "mission time limit of 100 s reached; a note of the caller"


def test_a_bare_adapter_or_a_vehicle_run_alike() -> None:
    bare = run_mission(dam(), scripted())
    wrapped = run_mission(dam(), Vehicle(scripted(), declares=None))  # no capability check
    assert (bare.status, bare.firings) == (wrapped.status, wrapped.firings) == ("ok", 41)


def test_a_loop_that_spins_at_one_instant_ends_zeno_in_the_log(tmp_path: Path) -> None:
    # Issue 21: on a vehicle that answers at once this loop never lets mission time move; the
    # player stops it through the abort past the stated bound, and the end record says so.
    mission = write(tmp_path, "MISSION spin { WHILE { GoTo((-1, 0, 1, 0)) } DO { Surface() } }")
    script = write(tmp_path, '[behaviours.GoTo]\non_enable = { after = 0.0, event = "reached" }'
                   '\n[behaviours.Surface]\non_enable = { after = 0.0, event = "surfaced" }\n',
                   "now.toml")
    log = tmp_path / "spin.jsonl"
    # the loop is not bounded by a timeout, so it does not verify (terminates): run it anyway,
    # as `mcl run --no-verify` would, to test the player's own bound
    result = run_mission(compile_file(str(mission), require_values=True), scripted(script),
                         log=log, max_firings_per_instant=200, verify=False)
    assert (result.status, result.how, result.exit) == ("zeno", "zeno", Exit.UNDECIDED)
    assert result.time == 0.0 and 200 <= result.firings <= 220
    end = records(log)[-1]
    assert end["kind"] == "end" and end["how"] == "zeno" and end["exit"] == 4
    assert "more than 200 firings at 0 s" in end["why"]
    assert len(records(log)) < 2000  # not the 154 MB of the issue
