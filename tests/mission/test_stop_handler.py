"""A stop the mission chooses (issue 21): MCL's ``ON STOP`` handler runs on every stop from
outside — a signal, the time limit, an uncaught ``Link.lost`` — for at most its proved bound,
and a second stop halts it; the end record says it ran and how it ended.

Issue 21 quoted: "Ctrl-C at 102 s into the dam mission switches the five behaviours off and
ends; the vehicle is left at depth by the wall." Reproduced here on the simulated Ictineu
(run_mission, simulated time) and with a real SIGINT to a real ``mcl run --realtime``."""

from __future__ import annotations

import json
import signal
import subprocess
import time
from pathlib import Path
from typing import Any

import pytest

from behaviours import capabilities
from mcl.api import compile_file
from mission.exits import Exit
from mission.run import Stop, run_mission
from mission.simulated import simulated_vehicle
from petri.execution.replay import check
from petri.execution.runlog import read_log, verify
from tests.support import BIN, MISSIONS, REPO, budget, end, subprocess_env, write
from vehicle.scripted import ScriptedVehicle, load_script
from vehicle_adapters.inprocess import InProcess

DAM = MISSIONS / "dam_inspection.mcl"


def records(path: Path) -> list[dict[str, Any]]:
    return [json.loads(line) for line in path.read_text("utf-8").splitlines()]


def depth(vehicle: Any) -> float:
    return float(vehicle.stack.robot.state.z)


def replays(mission: Path, log: Path) -> bool:
    verify(read_log(str(log)), str(log))
    return check(compile_file(str(mission), require_values=True).net,
                 read_log(str(log)), {}).ok


def at_mission_time(vehicle: Any, seconds: float, asked: Stop) -> Any:
    """A stop request once the simulated vehicle's clock reads ``seconds``."""
    return lambda: asked if vehicle.adapter.now() >= seconds else None


# -- the dam mission, stopped at 102 s, surfaces ------------------------------------------------
def test_a_stop_at_102_s_into_the_dam_mission_brings_the_vehicle_up(tmp_path: Path) -> None:
    vehicle = simulated_vehicle(seed=2)
    log = tmp_path / "dam.jsonl"
    deepest: list[float] = []
    result = run_mission(compile_file(str(DAM), require_values=True), vehicle, log=log,
                         stop=at_mission_time(vehicle, 102.0,
                                              Stop("SIGINT received", signal.SIGINT)),
                         observers=[lambda r: deepest.append(depth(vehicle))])
    assert (result.status, result.how, result.exit) == ("stopped", "signal", 130)
    assert max(deepest) > 0.8, "the vehicle was never at depth: the test proves nothing"
    assert result.stop_handler is not None and result.stop_handler["how"] == "ended ok"
    start = result.stop_handler["start"]
    assert start == pytest.approx(102.0, abs=1.0) and result.time > start
    assert depth(vehicle) <= 0.2 + 0.05, f"left at {depth(vehicle):.2f} m"
    # the body's abort switched off what it had on; the handler's Surface ended by itself
    assert {"StartLogs", "StartCamera", "WallInspection"} <= set(result.switched_off)
    last = records(log)[-1]
    assert last["stop_handler"] == result.stop_handler and last["exit"] == 130
    surfaced = [r for r in records(log) if r.get("event") == "Surface.surfaced"]
    assert surfaced and surfaced[-1]["t"] >= start
    assert replays(DAM, log)


def test_the_time_limit_runs_the_handler_within_its_proved_bound(tmp_path: Path) -> None:
    vehicle = simulated_vehicle(seed=3)
    log = tmp_path / "limit.jsonl"
    result = run_mission(compile_file(str(DAM), require_values=True), vehicle, log=log,
                         max_time=60.0)
    assert (result.status, result.how, result.exit) == ("timeout", "time limit",
                                                        Exit.UNDECIDED)
    handler = result.stop_handler
    assert handler is not None and handler["how"] == "ended ok", handler
    assert handler["start"] == 60.0 and handler["bound"] == 300.0  # Surface's own timeout
    assert 60.0 < result.time <= 60.0 + handler["bound"]
    assert depth(vehicle) <= 0.25
    assert replays(DAM, log)


# -- a second stop, a handler past its bound, a mission without a handler ---------------------
def scripted(tmp_path: Path, toml: str) -> InProcess:
    path = write(tmp_path, toml, "vehicle.toml")
    return InProcess(ScriptedVehicle(load_script(str(path))),
                     declaration=capabilities.ictineu("scripted"))


SLOW_SURFACE = ('[behaviours.GoTo]\non_enable = { after = 5.0, event = "reached" }\n'
                '[behaviours.Surface]\non_enable = { after = 40.0, event = "surfaced" }\n')


def test_a_second_stop_halts_the_handler_and_switches_it_off(tmp_path: Path) -> None:
    # straight down from the vehicle's start (-6, -2, 0.3): reached in 3 s at 1 m deep (GoTo's
    # tolerance 0.5 m), in wall-clock time
    mission = write(tmp_path, "MISSION dive { GoTo((-6, -2, 1.5, 0), timeout = 1 min); "
                              "Wait(10 min) } ON STOP { Surface() }")
    vehicle = scripted(tmp_path, SLOW_SURFACE)
    first, again = Stop("SIGINT received", signal.SIGINT, 1), Stop("SIGINT again", 2, 2)

    asked_at: list[float] = []

    def asked() -> Stop | None:  # at 5 s (GoTo reached), then again at the next round
        if vehicle.now() < 5.0:
            return None
        asked_at.append(vehicle.now())
        return first if len(asked_at) == 1 else again

    log = tmp_path / "halt.jsonl"
    result = run_mission(compile_file(str(mission), require_values=True), vehicle, log=log,
                         stop=asked)
    handler = result.stop_handler
    assert handler is not None and handler["how"] == "halted", handler
    assert "stopped again" in handler["why"] and result.exit == 130
    assert handler["start"] == 5.0 and handler["end"] < 45.0  # before Surface could end
    assert "Surface" in result.switched_off  # the halt switched the handler's task off
    assert records(log)[-1]["stop_handler"] == handler
    assert replays(mission, log)


def test_a_handler_past_its_bound_is_halted_at_the_bound(tmp_path: Path) -> None:
    # verified bound: Surface(timeout = 10 s) bounds the handler to 10 s; the scripted vehicle
    # never answers, so the task's own timeout ends it (fail) at the bound, not later
    mission = write(tmp_path, "MISSION m { Wait(1 min) } ON STOP { Surface(timeout = 10 s) }")
    vehicle = scripted(tmp_path, "")
    log = tmp_path / "bound.jsonl"
    result = run_mission(compile_file(str(mission), require_values=True), vehicle, log=log,
                         max_time=20.0)
    handler = result.stop_handler
    assert handler is not None and handler["bound"] == 10.0
    assert handler["how"] == "ended fail" and result.time == pytest.approx(30.0), handler
    assert replays(mission, log)


def test_a_mission_without_a_handler_ends_at_the_stop(tmp_path: Path) -> None:
    mission = write(tmp_path, "MISSION m { Wait(1 min) }")
    result = run_mission(compile_file(str(mission), require_values=True),
                         scripted(tmp_path, ""), max_time=20.0)
    assert result.stop_handler is None and result.time == 20.0 and result.exit == 4


def test_an_uncaught_link_lost_runs_the_handler_when_the_link_still_carries_actions(
        tmp_path: Path) -> None:
    mission = write(tmp_path, "MISSION m { GoTo((0, 0, 1, 0), timeout = 1 min); Wait(10 min) "
                              "} ON STOP { Surface() }")
    toml = ('[behaviours.GoTo]\non_enable = { after = 5.0, event = "reached" }\n'
            '[behaviours.Surface]\non_enable = { after = 8.0, event = "surfaced" }\n'
            '[[at]]\ntime = 30.0\nevent = "Link.lost"\n')
    log = tmp_path / "lost.jsonl"
    result = run_mission(compile_file(str(mission), require_values=True),
                         scripted(tmp_path, toml), log=log)
    handler = result.stop_handler
    assert handler is not None and handler["how"] == "ended ok", (result, handler)
    assert handler["start"] == 30.0 and result.time == pytest.approx(38.0)
    assert replays(mission, log)


# -- a real SIGINT to a real mcl run, at depth ------------------------------------------------
def test_ctrl_c_at_depth_brings_the_vehicle_to_the_surface(tmp_path: Path) -> None:
    # straight down from the vehicle's start (-6, -2, 0.3): reached in 3 s at 1 m deep (GoTo's
    # tolerance 0.5 m), in wall-clock time
    mission = write(tmp_path, "MISSION dive { GoTo((-6, -2, 1.5, 0), timeout = 1 min); "
                              "Wait(10 min) } ON STOP { Surface() }")
    log, out = tmp_path / "run.jsonl", tmp_path / "run.out"
    with open(out, "wb") as sink:
        proc = subprocess.Popen([str(BIN / "mcl"), "run", str(mission), "--realtime",
                                 "--no-images", "--log", str(log)], cwd=REPO,
                                env=subprocess_env(), stdin=subprocess.DEVNULL, stdout=sink,
                                stderr=subprocess.STDOUT)
        try:
            deadline = time.monotonic() + budget(20)
            while "GoTo.reached" not in out.read_text("utf-8", "replace"):
                assert proc.poll() is None and time.monotonic() < deadline, out.read_text()
                time.sleep(0.2)
            proc.send_signal(signal.SIGINT)
            code = proc.wait(timeout=budget(10))
        finally:
            end(proc)
    text = out.read_text("utf-8")
    assert code == 130, text
    assert "stop handler (ON STOP) ended ok" in text and "Traceback" not in text, text
    recs = records(log)
    reached = next(r for r in recs if r.get("event") == "GoTo.reached")
    surfaced = [r for r in recs if r.get("event") == "Surface.surfaced"]
    assert surfaced and surfaced[-1]["t"] > reached["t"], "it never surfaced"
    last = recs[-1]
    assert (last["how"], last["exit"], last["stop_handler"]["how"]) == ("signal", 130,
                                                                         "ended ok")
    assert replays(mission, log)
