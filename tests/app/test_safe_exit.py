"""Every exit of ``mcl run`` is a safe exit (issue 12): a signal, the time limit, a stuck
mission, a closed standard output, an error of the vehicle — each ends with every behaviour
on disabled, the vehicle's side seeing them off, a last log record saying how and why the run
ended, and a documented exit status. The vehicle says what it can do, and a mission that
needs more is refused before the first action. Mission time counts from the mission's start.

The signals are real signals sent to real ``mcl run`` subprocesses once their log shows the
mission running, on each kind of vehicle: simulated, scripted, Zenoh and MAVLink (vehicles in
their own processes on free loopback ports). No wall-clock limit is asserted: waits are
bounded generously and only fail a test that hangs.
"""

from __future__ import annotations

import json
import os
import re
import signal
import subprocess
import time
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import pytest

from mcl.api import compile_file
from petri.execution.player import Player, Record
from petri.execution.runner import MissionClock, run
from aal.messages import ActionMessage
from vehicle_adapters.inprocess import InProcess
from vehicle.scripted import ScriptedVehicle, parse_script

from tests.support import BIN, FAST_TASKS, MISSIONS, REPO, end, free_endpoint, free_udp_port, stop, write

DAM = str(MISSIONS / "dam_inspection.mcl")
EVERY = str(MISSIONS / "every_construct.mcl")
PIPELINE = str(MISSIONS / "pipeline_inspection.mcl")
DAM_TOML = str(MISSIONS / "vehicles" / "dam.toml")
WAIT = 120.0  # s: the longest any wait here may take before the test fails (a hang)


# -- helpers ----------------------------------------------------------------------------------
def env(tmp_path: Path) -> dict[str, str]:
    e = dict(os.environ, PYTHONDONTWRITEBYTECODE="1", MCL_STATE_DIR=str(tmp_path / "state"))
    e.pop("MCL_MAVLINK_KEY", None)
    return e


@contextmanager
def mcl_run(tmp_path: Path, *args: str) -> Iterator[tuple[subprocess.Popen[bytes], Path]]:
    """``mcl run ARGS --log tmp/run.jsonl``, its output in files (no pipe to fill up)."""
    log = tmp_path / "run.jsonl"
    out = open(tmp_path / "run.out", "wb")  # noqa: SIM115 - closed below
    images = ["--no-images"] if "--vehicle" not in args else []  # simulated: no mosaic
    proc = subprocess.Popen([str(BIN / "mcl"), "run", *args, *images, "--log", str(log)],
                            cwd=REPO,
                            env=env(tmp_path), stdin=subprocess.DEVNULL, stdout=out,
                            stderr=subprocess.STDOUT)
    try:
        yield proc, log
    finally:
        end(proc)  # type: ignore[arg-type]  # bytes or text: the same stop
        out.close()


def records(log: Path) -> list[dict[str, Any]]:
    return [json.loads(line) for line in log.read_text("utf-8").splitlines() if line.strip()]


def wait_until_running(proc: subprocess.Popen[bytes], log: Path, enables: int = 2) -> None:
    """Until the log shows the mission running with ``enables`` behaviours enabled."""
    deadline = time.monotonic() + WAIT
    while time.monotonic() < deadline:
        assert proc.poll() is None, f"mcl run ended early: {output(log)}"
        if log.exists():
            recs = [json.loads(line) for line in log.read_text("utf-8").splitlines()
                    if line.endswith("}")]
            running = any(r.get("status") == "running" for r in recs)
            on = [r for r in recs if r["kind"] == "action" and r["action"] == "enable"]
            if running and len(on) >= enables:
                return
        time.sleep(0.05)
    pytest.fail(f"the mission did not start within {WAIT:g} s: {output(log)}")


def output(log: Path) -> str:
    path = log.parent / "run.out"
    return path.read_text("utf-8", "replace")[-3000:] if path.exists() else ""


def finish(proc: subprocess.Popen[bytes], log: Path) -> int:
    try:
        return proc.wait(timeout=WAIT)
    except subprocess.TimeoutExpired:
        end(proc)  # type: ignore[arg-type]
        pytest.fail(f"mcl run did not end within {WAIT:g} s: {output(log)}")


def left_on(recs: list[dict[str, Any]]) -> set[str]:
    """What the logged actions leave on."""
    on: set[str] = set()
    for r in recs:
        if r["kind"] == "action":
            (on.add if r["action"] == "enable" else on.discard)(r["behaviour"]) \
                if r["action"] in ("enable", "disable") else None
    return on


def check_safe_end(log: Path, how: str, code: int, confirmed: bool = True) -> dict[str, Any]:
    """The log ends with an end record saying ``how``, nothing is left on, and the vehicle
    confirmed it; returns the end record."""
    recs = records(log)
    last = recs[-1]
    assert last["kind"] == "end", f"no end record: {recs[-3:]}"
    assert last["how"] == how and last["exit"] == code, last
    assert last["why"], last
    enabled = {r["behaviour"] for r in recs if r["kind"] == "action" and r["action"] == "enable"}
    assert enabled, "nothing was ever on: the test proves nothing"
    assert left_on(recs) == set(), f"left on: {left_on(recs)}"
    if confirmed:
        assert last["confirmed"].startswith("confirmed"), last["confirmed"]
    times = [r["t"] for r in recs[1:]]
    assert times == sorted(times) and times[0] == 0.0, "mission time starts at 0, never back"
    return last


# -- real signals, simulated and scripted vehicles ---------------------------------------------
@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM, signal.SIGHUP])
def test_a_signal_on_the_simulated_vehicle_aborts_and_switches_off(tmp_path: Path,
                                                                   sig: int) -> None:
    with mcl_run(tmp_path, EVERY) as (proc, log):
        wait_until_running(proc, log, enables=3)
        proc.send_signal(sig)
        code = finish(proc, log)
    assert code == 128 + sig, output(log)
    last = check_safe_end(log, "signal", 128 + sig)
    assert signal.Signals(sig).name in last["why"]
    text = output(log)
    assert "Traceback" not in text and "KeyboardInterrupt" not in text, text
    assert "ended STOPPED" in text


def test_sigterm_on_a_scripted_vehicle_aborts_and_switches_off(tmp_path: Path) -> None:
    # the dam's scripted vehicle, surfacing (the ON STOP) in 2 s of wall-clock time, not 25
    shipped = Path(DAM_TOML).read_text("utf-8")
    quick = shipped.replace('after = 25.0, event = "surfaced"', 'after = 2.0, event = "surfaced"')
    assert quick != shipped
    script = write(tmp_path, quick, "dam.toml")
    with mcl_run(tmp_path, DAM, "--vehicle", f"script:{script}", "--realtime") as (proc, log):
        wait_until_running(proc, log, enables=2)  # StartLogs, GoTo: 40 s before GoTo.reached
        proc.send_signal(signal.SIGTERM)
        code = finish(proc, log)
    assert code == 143, output(log)
    last = check_safe_end(log, "signal", 143)
    assert set(last["switched_off"]) >= {"StartLogs", "GoTo"}, last


# -- the time limit, a stuck mission, a closed standard output --------------------------------
def test_max_time_aborts_through_the_net_at_the_limit(tmp_path: Path) -> None:
    # a loop nothing bounds: not verified (terminates fails, issue 21), run with --no-verify
    mission = write(tmp_path, "MISSION { StartLogs(enable); WHILE { GoTo((0, 0, 1, 0 deg)) } "
                              "DO { Wait(1 s) }; StartLogs(disable) }")
    with mcl_run(tmp_path, str(mission), "--max-time", "9.5", "--no-verify") as (proc, log):
        code = finish(proc, log)
    assert code == 4, output(log)
    last = check_safe_end(log, "time limit", 4)
    assert last["t"] == 9.5 and set(last["switched_off"]) == {"GoTo", "StartLogs"}, last


def test_the_limit_does_not_overshoot_to_the_next_timer(tmp_path: Path) -> None:
    mission = write(tmp_path, "MISSION { StartLogs(enable); Wait(7280 s); StartLogs(disable) }")
    script = write(tmp_path, "", "empty.toml")
    with mcl_run(tmp_path, str(mission), "--vehicle", f"script:{script}",
                 "--max-time", "4000") as (proc, log):
        code = finish(proc, log)
    assert code == 4, output(log)
    last = check_safe_end(log, "time limit", 4)
    assert max(r["t"] for r in records(log)[1:]) == 4000.0, last


def test_a_stuck_mission_is_aborted_with_its_latch_off(tmp_path: Path) -> None:
    # a watcher with no timeout: not verified (terminates fails, issue 21), run with --no-verify
    mission = write(tmp_path, "MISSION { Alarms() }")
    script = write(tmp_path, "", "empty.toml")
    with mcl_run(tmp_path, str(mission), "--vehicle", f"script:{script}",
                 "--no-verify") as (proc, log):
        code = finish(proc, log)
    assert code == 4, output(log)
    last = check_safe_end(log, "stuck", 4)
    assert last["switched_off"] == ["Alarms"]


@pytest.mark.slow
def test_a_closed_stdout_does_not_stop_the_mission(tmp_path: Path) -> None:
    # the simulated vehicle at wall-clock speed, a line every second: `| head -1` closes the
    # pipe after the first, and the run goes on to its limit, safely
    mission = write(tmp_path, "MISSION { PARALLEL { WHILE { Wait(1 s) } DO { StartLogs(enable);"
                              " Wait(1 s); StartLogs(disable) } } OR { Wait(30 s) } }")
    log = tmp_path / "run.jsonl"
    err_path = tmp_path / "run.err"
    with open(err_path, "wb") as err_file:
        proc = subprocess.Popen([str(BIN / "mcl"), "run", str(mission), "--realtime",
                                 "--max-time", "7.5", "--log", str(log)], cwd=REPO,
                                env=env(tmp_path), stdin=subprocess.DEVNULL,
                                stdout=subprocess.PIPE, stderr=err_file)
        try:
            assert proc.stdout is not None
            first = proc.stdout.readline()  # as `| head -1` does
            assert b"enable StartLogs" in first, first
            proc.stdout.close()
            code = proc.wait(timeout=WAIT)
        finally:
            stop(proc)  # type: ignore[arg-type]
    err = err_path.read_text()
    assert code == 4, err  # the limit, as asked: not exit 3, not a broken pipe
    assert "Traceback" not in err and "BrokenPipe" not in err, err
    last = check_safe_end(log, "time limit", 4)
    assert "standard output was closed" in last["why"] and last["t"] == 7.5, last
    assert last["switched_off"] == ["StartLogs"], last


# -- an error of the vehicle ------------------------------------------------------------------
class Failing(InProcess):
    """A vehicle whose link breaks after a few actions."""

    def __init__(self, after: int):
        super().__init__(ScriptedVehicle(parse_script({})))
        self.after, self.tried = after, []  # type: ignore[var-annotated]

    def send(self, action: ActionMessage) -> None:
        self.tried.append((action.kind, action.behaviour))
        if len(self.tried) > self.after:
            raise ConnectionError("link broke")
        super().send(action)


def test_an_exception_of_the_vehicle_aborts_and_tries_every_disable(tmp_path: Path) -> None:
    mission = write(tmp_path, "MISSION { StartLogs(enable); StartCamera(enable); "
                              "GoTo((0, 0, 1, 0 deg)); StartLogs(disable) }")
    compiled = compile_file(str(mission), require_values=True)
    player = Player(compiled.net)
    vehicle = Failing(after=2)
    outcome = run(player, vehicle, "m", max_time=100)
    assert outcome.status == "error" and "link broke" in outcome.reason
    assert player.finished and not player.behaviours_on
    disabled = {b for kind, b in vehicle.tried if kind == "disable"}
    assert disabled >= {"StartLogs", "StartCamera", "GoTo"}, vehicle.tried


# -- the scripted vehicle's answers: staleness judged at delivery ------------------------------
def test_an_answer_of_a_disabled_behaviour_never_reaches_its_next_enable() -> None:
    stack = ScriptedVehicle(parse_script({"behaviours": {"GoTo": {"on_enable": [
        {"after": 5.0, "event": "reached"}, {"after": 5.0, "event": "failed"}]}}}))
    go = ActionMessage(0, 0.0, "m", "t", "enable", "GoTo", {})
    stack.on_action(go, 0.0)
    first = stack.due(5.0)
    assert [e.event for e in first] == ["GoTo.reached"]
    stack.on_action(ActionMessage(1, 5.0, "m", "t", "disable", "GoTo", {}), 5.0)
    stack.on_action(ActionMessage(2, 5.0, "m", "t", "enable", "GoTo", {}), 5.0)
    assert stack.due(5.0) == []  # the old "failed" is stale
    assert [e.event for e in stack.due(10.0)] == ["GoTo.reached"]


# -- what the vehicle can do ------------------------------------------------------------------
def test_the_pipeline_mission_is_refused_on_a_vehicle_without_its_behaviours(
        tmp_path: Path) -> None:
    # the dam's scripted vehicle declares the Ictineu library only (no KeepAltitude,
    # FollowPipeline, SearchLine): refused before anything runs, each call named
    with mcl_run(tmp_path, PIPELINE, "--vehicle", f"script:{DAM_TOML}") as (proc, log):
        code = finish(proc, log)
    text = output(log)
    assert code == 2, text
    assert re.search(r"pipeline_inspection\.mcl:\d+:\d+: error: KeepAltitude needs behaviour "
                     r"KeepAltitude, which vehicle script:\S*dam\.toml does not have", text), text
    assert "FollowPipe needs behaviour" in text and "Traceback" not in text, text
    assert not log.exists(), "refused before the first action: no run at all"


def test_a_behaviour_the_simulator_lacks_is_refused_at_its_call(tmp_path: Path) -> None:
    library = write(tmp_path, "behaviour Sonar events ping;\n"
                              "task Ping() {\n    start: enable Sonar;\n    ok: Sonar.ping;\n"
                              "    timeout: 1 min -> fail;\n    stop: disable Sonar;\n}\n",
                    "sonar.tasks")
    mission = write(tmp_path, "MISSION {\n    Wait(1 s);\n    Ping()\n}\n")
    with mcl_run(tmp_path, str(mission), "--tasks", str(library)) as (proc, log):
        code = finish(proc, log)
    text = output(log)
    assert code == 2, text
    assert f"{mission}:3:5: error: Ping needs behaviour Sonar, which vehicle sim (the " \
           "simulated Ictineu) does not have" in text, text
    assert not log.exists()


def test_the_pipeline_mission_runs_on_a_vehicle_that_declares_it(tmp_path: Path) -> None:
    script = write(tmp_path, f'tasks = ["ictineu", "{MISSIONS / "seabed.tasks"}"]\n'
                             '[behaviours.GoTo]\non_enable = { after = 5, event = "reached" }\n',
                   "seabed.toml")
    with mcl_run(tmp_path, PIPELINE, "--vehicle", f"script:{script}", "--max-time", "600",
                 "--no-verify") as (proc, log):
        code = finish(proc, log)
    # accepted; the pipe follower never answers, and since issue 21 a Timeout(followFor) of
    # 20 min races the follow loop (so that every run ends): not stuck, the 600 s limit ends it
    assert code == 4, output(log)
    last = check_safe_end(log, "time limit", 4)
    assert "KeepAltitude" in last["switched_off"], last


@pytest.mark.slow
@pytest.mark.parametrize("toml, where, what", [
    ('# a\n[behaviours.GoTo]\non_enable = { after = 5.0, event = "reachd" }\n', ":3:36:",
     "behaviour GoTo has no event 'reachd'"),
    ('[behaviours.Goto]\non_enable = { after = 5.0, event = "reached" }\n', ":1:1:",
     "behaviour 'Goto' is not declared"),
    ('[[at]]\ntime = 3\nevent = "Alarms.leek"\n', ":3:9:", "Alarms has no event 'leek'"),
    ('[[at]]\ntime = 3\nevent = "Sonar.ping"\n', ":3:9:", "behaviour 'Sonar' is not declared"),
])
def test_a_script_naming_an_unknown_behaviour_or_event_is_an_error(
        tmp_path: Path, toml: str, where: str, what: str) -> None:
    script = write(tmp_path, toml, "v.toml")
    with mcl_run(tmp_path, DAM, "--vehicle", f"script:{script}") as (proc, log):
        code = finish(proc, log)
    text = output(log)
    assert code == 2, text
    assert f"{script}{where} error: " in text and what in text and "hint:" in text, text


def test_default_max_time_is_stated_and_derived_from_the_mission(tmp_path: Path) -> None:
    from mission import limits as safe_exit  # the time bound: mission/limits.py

    helped = subprocess.run([str(BIN / "mcl"), "run", "--help"], capture_output=True,
                            text=True, timeout=60, cwd=REPO)
    flat = " ".join(helped.stdout.split())
    assert "7200 s" in flat and "timeouts" in flat, helped.stdout
    dam = compile_file(DAM, require_values=True)
    bound = safe_exit.mission_bound(dam)
    assert bound is not None and 1800 < bound < 86_400  # GoTo 10 min, WallInspect 60 min...
    assert safe_exit.max_time(dam, None)[0] == pytest.approx(bound * 1.1 + 60)
    loop = write(tmp_path, "MISSION { WHILE { GoTo((0, 0, 1, 0 deg)) } DO { Wait(1 s) } }")
    unbounded = compile_file(str(loop), require_values=True)  # a WHILE loop
    assert safe_exit.mission_bound(unbounded) is None
    assert safe_exit.max_time(unbounded, None)[0] == 7200.0
    assert safe_exit.max_time(unbounded, 30.0) == (30.0, "--max-time")
    bounded = write(tmp_path, "MISSION { PARALLEL { WHILE { GoTo((0, 0, 1, 0 deg)) } DO "
                              "{ Wait(1 s) } } OR { Wait(5 min) }; Wait(2 s) }", "b.mcl")
    assert safe_exit.mission_bound(compile_file(str(bounded), require_values=True)) == 302


def test_the_simulated_stack_has_exactly_the_declared_behaviours() -> None:
    from mission.capabilities import declared_behaviours
    from mission.capabilities import parameters_taken as _parameters
    from vehicle.control.stack import IctineuStack
    from behaviours.capabilities import simulated

    library = declared_behaviours(simulated("sim"))
    assert set(library.behaviours) == set(IctineuStack().behaviours)
    assert library.behaviours["GoTo"].events == ("reached", "failed")
    assert _parameters(library)["GoTo"] == {"x", "y", "z", "yaw", "tolerance"}


# -- one clock: mission time from the mission's start ------------------------------------------
def test_mission_time_starts_at_0_whatever_the_vehicle_clock_reads(tmp_path: Path) -> None:
    compiled = compile_file(DAM, require_values=True)
    from vehicle.scripted import load_script

    player = Player(compiled.net)
    seen: list[Record] = []
    player.observers.append(seen.append)
    clock = MissionClock()
    vehicle = InProcess(ScriptedVehicle(load_script(DAM_TOML)), start=1415.9)
    outcome = run(player, vehicle, "dam", clock=clock)
    assert outcome.status == "ok"
    assert clock.origin == 1415.9 and seen[0].t == 0.0
    assert outcome.time == pytest.approx(seen[-1].t) and outcome.time < 2000
    assert clock.vehicle(outcome.time) == pytest.approx(1415.9 + outcome.time)


def test_the_monitor_shows_the_vehicle_clock_beside_mission_time() -> None:
    from app.monitor import vehicle_time_beside as _beside

    assert _beside({"t": 10.0, "clock": 1425.9}, 12.0) == " (vehicle 1427.9 s)"
    assert _beside({"t": 10.0, "clock": 10.0}, 12.0) == ""


# -- remote vehicles: Zenoh and MAVLink in their own processes ---------------------------------
@contextmanager
def vehicle(args: list[str], tmp_path: Path) -> Iterator[tuple[subprocess.Popen[str], Path]]:
    """A vehicle process, its stdout in a file; yields once it says it is ready."""
    out_path = tmp_path / "vehicle.out"
    out = open(out_path, "w")  # noqa: SIM115 - closed below
    proc = subprocess.Popen([str(BIN / "mcl"), "vehicle", *args], cwd=REPO, env=env(tmp_path),
                            stdin=subprocess.DEVNULL, stdout=out, stderr=subprocess.STDOUT,
                            text=True)
    try:
        deadline = time.monotonic() + WAIT
        while "ready" not in out_path.read_text() and time.monotonic() < deadline:
            assert proc.poll() is None, out_path.read_text()
            time.sleep(0.05)
        assert "ready" in out_path.read_text(), out_path.read_text()
        yield proc, out_path
    finally:
        end(proc)
        out.close()


def vehicle_saw_all_off(proc: subprocess.Popen[str], out_path: Path) -> None:
    """Stop the vehicle; its exit report says no behaviour of the mission was on."""
    proc.send_signal(signal.SIGTERM)
    proc.wait(timeout=WAIT)
    text = out_path.read_text()
    line = next((x for x in text.splitlines() if "behaviours on at exit:" in x), None)
    assert line is not None, text
    on = line.split("behaviours on at exit:")[1].split("(")[0].strip()
    assert on == "none", text


@pytest.mark.slow
@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM])
def test_a_signal_over_zenoh_switches_the_vehicle_off(tmp_path: Path, sig: int) -> None:
    pytest.importorskip("zenoh")
    endpoint = free_endpoint()
    with vehicle(["--zenoh", endpoint, "--speed", "20", "--player-timeout", "600"],
                 tmp_path) as (vproc, vout):
        with mcl_run(tmp_path, DAM, "--vehicle", f"zenoh:{endpoint}") as (proc, log):
            wait_until_running(proc, log, enables=2)
            proc.send_signal(sig)
            code = finish(proc, log)
        assert code == 128 + sig, output(log)
        last = check_safe_end(log, "signal", 128 + sig)
        assert "telemetry" in last["confirmed"]
        vehicle_saw_all_off(vproc, vout)


@pytest.mark.slow
def test_max_time_over_zenoh_switches_the_vehicle_off(tmp_path: Path) -> None:
    pytest.importorskip("zenoh")
    endpoint = free_endpoint()
    with vehicle(["--zenoh", endpoint, "--speed", "50", "--player-timeout", "600"],
                 tmp_path) as (vproc, vout):
        with mcl_run(tmp_path, DAM, "--vehicle", f"zenoh:{endpoint}",
                     "--max-time", "120") as (proc, log):
            code = finish(proc, log)
        assert code == 4, output(log)
        last = check_safe_end(log, "time limit", 4)
        assert 120 <= last["t"] < 200, last  # wall-time link: within a poll of the limit
        assert records(log)[1]["t"] == 0.0
        # a second mission on the same vehicle: its clock reads 120 s and more, the mission's 0
        second = tmp_path / "second"
        second.mkdir()
        with mcl_run(second, DAM, "--vehicle", f"zenoh:{endpoint}",
                     "--max-time", "30") as (proc, log2):
            code = finish(proc, log2)
        assert code == 4, output(log2)
        again = check_safe_end(log2, "time limit", 4)
        assert again["vehicle_t"] - again["t"] >= 120, again  # the vehicle's clock beside
        text = output(log2)
        # mission time (30 s, then the ON STOP handler's surfacing), not the vehicle's 150 s+
        after = re.search(r"ended STOPPED AT THE TIME LIMIT after ([0-9.]+) s", text)
        assert after is not None and 30.0 <= float(after[1]) < 120.0, text
        assert "stop handler (ON STOP) ended ok" in text, text
        assert "(vehicle clock " in text and "[vehicle " in text, text
        vehicle_saw_all_off(vproc, vout)


@pytest.mark.slow
@pytest.mark.parametrize("sig", [signal.SIGTERM, signal.SIGHUP])
def test_a_signal_over_mavlink_switches_the_vehicle_off(tmp_path: Path, sig: int) -> None:
    port = free_udp_port()
    with vehicle(["--mavlink", f"udpout:127.0.0.1:{port}", "--speed", "20",
                  "--gcs-timeout", "600", "--pilot-timeout", "600"], tmp_path) as (vproc, vout):
        with mcl_run(tmp_path, DAM, "--vehicle", f"mavlink:udpin:127.0.0.1:{port}") \
                as (proc, log):
            wait_until_running(proc, log, enables=2)
            proc.send_signal(sig)
            code = finish(proc, log)
        assert code == 128 + sig, output(log)
        last = check_safe_end(log, "signal", 128 + sig)
        assert "acknowledged" in last["confirmed"], last
        vehicle_saw_all_off(vproc, vout)


def test_link_lost_over_zenoh_ends_with_an_end_record_saying_so(tmp_path: Path) -> None:
    pytest.importorskip("zenoh")
    endpoint = free_endpoint()
    with vehicle(["--zenoh", endpoint, "--speed", "20"], tmp_path) as (vproc, _):
        with mcl_run(tmp_path, DAM, "--vehicle", f"zenoh:{endpoint}") as (proc, log):
            wait_until_running(proc, log, enables=2)
            vproc.kill()  # the vehicle process dies: its socket closes
            vproc.wait(timeout=WAIT)
            code = finish(proc, log)
    assert code == 1, output(log)
    last = check_safe_end(log, "fail", 1, confirmed=False)
    assert "Link.lost" in last["why"], last
    assert last["confirmed"].startswith("not confirmed: the link is lost"), last


def test_a_parameter_the_vehicle_does_not_take_is_refused(tmp_path: Path) -> None:
    library = write(tmp_path, FAST_TASKS, "fast.tasks")
    mission = write(tmp_path, "MISSION {\n    Fast((0, 0, 1, 0 deg))\n}\n")
    with mcl_run(tmp_path, str(mission), "--tasks", str(library)) as (proc, log):
        code = finish(proc, log)
    text = output(log)
    assert code == 2, text
    assert f"{mission}:2:5: error: Fast gives GoTo the parameter(s) speed, which vehicle " \
           "sim (the simulated Ictineu) does not take" in text, text
    assert "x, y, yaw, z" in text or "tolerance, x, y, yaw, z" in text, text


# -- after the end record: a signal cuts the report, the exit status stays (issue 22) --------
def test_a_signal_after_the_run_cuts_its_report_and_keeps_its_status() -> None:
    from app.safe_exit import ReportCut, Stops

    stops = Stops(("SIGTERM",))
    try:
        with stops:
            os.kill(os.getpid(), signal.SIGTERM)  # during the run: a stop request
            assert stops.request() is not None and stops.request().signal == signal.SIGTERM
        with pytest.raises(ReportCut) as cut:  # once the end record is written
            os.kill(os.getpid(), signal.SIGTERM)
            time.sleep(1)  # the handler runs before this ends
        assert cut.value.line() == ("mcl run: SIGTERM received after the run ended: its "
                                    "report was cut short (the run log's end record stands)")
    finally:
        stops.restore()
    assert signal.getsignal(signal.SIGTERM) is signal.SIG_DFL


def test_a_closed_stdout_over_zenoh_switches_the_vehicle_off(tmp_path: Path) -> None:
    # the issue's case: `mcl run ... --vehicle zenoh:... >&-` exited 3 after `enable
    # StartLogs`, and the vehicle kept it on
    pytest.importorskip("zenoh")
    endpoint = free_endpoint()
    log = tmp_path / "run.jsonl"
    with vehicle(["--zenoh", endpoint, "--speed", "20", "--player-timeout", "600"],
                 tmp_path) as (vproc, vout):
        with open(tmp_path / "run.out", "wb") as err:
            proc = subprocess.run([str(BIN / "mcl"), "run", DAM, "--vehicle", f"zenoh:{endpoint}",
                                   "--max-time", "30", "--log", str(log)], cwd=REPO,
                                  env=env(tmp_path), stdin=subprocess.DEVNULL, stderr=err,
                                  preexec_fn=lambda: os.close(1), timeout=WAIT)
        assert proc.returncode == 4, output(log)
        assert "Traceback" not in output(log), output(log)
        last = check_safe_end(log, "time limit", 4)
        assert "standard output was closed" in last["why"], last
        vehicle_saw_all_off(vproc, vout)
