"""mission/handled.py: a run lists every event a CATCH handled (what, when, the CATCH's line,
how its DO ended) in its result, its end record and ``mcl run``'s summary; the core library's
``Fail()`` lets a handler make the mission fail (issue 21: a handled leak ended "OK" with no
word of the leak)."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

from behaviours import capabilities
from mcl.analysis.verification import verify_mission
from mcl.api import compile_file
from mission.exits import Exit
from mission.handled import Handled
from mission.run import Stop, run_mission
from tests.support import MISSIONS, cli, write
from vehicle.scripted import ScriptedVehicle, load_script
from vehicle_adapters.inprocess import InProcess

DAM = MISSIONS / "dam_inspection.mcl"
DAM_LEAK = MISSIONS / "vehicles" / "dam_leak.toml"
DAM_OK = MISSIONS / "vehicles" / "dam.toml"

# A TRY whose handler surfaces and then, with Fail(), makes the mission fail (the TRY is the
# mission's last block, so its status is the mission's); its CATCH block is on line 5.
SURFACE_AND_FAIL = """MISSION leak_fails {
    TRY {
        GoTo((-1, 0, 1, 0)); Wait(20 min)
    } CATCH {
        Alarms()
    } DO {
        Surface(); Fail()
    }
}
"""
LEAK_AT_30 = """[behaviours.GoTo]
on_enable = { after = 10.0, event = "reached" }
[behaviours.Surface]
on_enable = { after = 5.0, event = "surfaced" }
[[at]]
time = 30.0
event = "Alarms.leak"
"""


def scripted(path: Path) -> InProcess:
    return InProcess(ScriptedVehicle(load_script(str(path))),
                     declaration=capabilities.ictineu("scripted"))


def end_record(log: Path) -> dict[str, Any]:
    last: dict[str, Any] = json.loads(log.read_text("utf-8").splitlines()[-1])
    assert last["kind"] == "end"
    return last


def test_a_handled_leak_is_listed_in_the_result_and_the_end_record(tmp_path: Path) -> None:
    log = tmp_path / "leak.jsonl"
    result = run_mission(compile_file(str(DAM), require_values=True), scripted(DAM_LEAK),
                         log=log)
    assert result.status == "ok" and result.exit == Exit.OK  # handled as the mission says
    catch_line = DAM.read_text("utf-8").splitlines()[result.handled[0].line - 1]
    assert "Alarms()" in catch_line  # the CATCH block of the outer TRY
    assert result.handled == (Handled("Alarms.leak", 600.0, result.handled[0].line, "ok"),)
    assert end_record(log)["handled"] == [{"event": "Alarms.leak", "t": 600.0,
                                           "line": result.handled[0].line, "ended": "ok"}]


def test_a_run_without_alarm_handles_nothing(tmp_path: Path) -> None:
    log = tmp_path / "ok.jsonl"
    result = run_mission(compile_file(str(DAM), require_values=True), scripted(DAM_OK),
                         log=log)
    assert result.status == "ok" and result.handled == ()
    assert end_record(log)["handled"] == []


def test_fail_lets_a_handler_make_the_mission_fail(tmp_path: Path) -> None:
    mission = compile_file(str(write(tmp_path, SURFACE_AND_FAIL)), require_values=True)
    assert verify_mission(mission, "auto").ok  # Fail() is a task like any other
    log = tmp_path / "fail.jsonl"
    result = run_mission(mission, scripted(write(tmp_path, LEAK_AT_30, "leak.toml")), log=log)
    assert (result.status, result.exit) == ("fail", Exit.FAILED)
    assert result.time == 35.0  # surfaced 5 s after the leak, then failed at once
    assert result.handled == (Handled("Alarms.leak", 30.0, 5, "fail"),)
    assert end_record(log)["handled"][0]["ended"] == "fail"


def test_a_timer_caught_and_a_handler_cut_by_a_stop_are_told(tmp_path: Path) -> None:
    # The CATCH is a timer; the operator stops the mission while its DO (a Wait) runs.
    text = ("MISSION timed {\n    TRY { Wait(1 h) }\n    CATCH { Timeout(10 s) }\n"
            "    DO { Wait(1 min) }\n}\n")
    mission = compile_file(str(write(tmp_path, text)), require_values=True)
    asked: list[float] = []

    def stop() -> Stop | None:
        return Stop("operator") if asked else None

    def seen(record: Any) -> None:  # the stop comes once the handler runs
        if record.kind == "fire" and ".catch_" in record.data["transition"]:
            asked.append(record.t)

    result = run_mission(mission, scripted(DAM_OK), stop=stop, observers=[seen])
    assert result.status == "stopped"
    (handled,) = result.handled
    assert handled.event.startswith("timer of Timeout@3:")
    assert (handled.t, handled.line, handled.ended) == (10.0, 3, "aborted")


def test_mcl_run_says_what_was_handled(tmp_path: Path) -> None:
    result = cli("mcl", "run", str(DAM), "--vehicle", f"script:{DAM_LEAK}", "--quiet",
                 "--log", str(tmp_path / "leak.jsonl"))
    assert result.returncode == 0, result.stderr
    assert "handled: Alarms.leak at 600.0 s (CATCH at line 49) -> DO ended ok" in result.stdout
