"""The real ``mcl`` command as a subprocess: ``mcl run`` on a scripted vehicle prints a
timeline and writes a run log; ``mcl replay`` checks the log against the mission; bad input is
answered with exit 2 and a message, never a traceback.

Exit status (app/run.py): run 0 ok, 1 fail, 2 invalid input, 4 time limit or stuck, 5 a
vehicle error, 128 + N signal N (tests/app/test_safe_exit.py); replay 0 conformant,
1 not conformant (a truncated or edited log names its line), 2 invalid input.
"""

from __future__ import annotations

import json
import re
import time
from pathlib import Path

import pytest

from mcl.api import compile_file
from petri.execution.player import Player
from petri.execution.replay import check
from petri.execution.runlog import RunLog, net_digest, read_log
from petri.execution.runner import run
from tests.support import MISSIONS, cli
from vehicle_adapters.inprocess import InProcess
from vehicle.scripted import ScriptedVehicle, load_script

# the dam mission run twice through the real mcl (its module fixture): not in make test-quick
pytestmark = pytest.mark.slow

DAM = str(MISSIONS / "dam_inspection.mcl")
VEHICLES = MISSIONS / "vehicles"
DAM_OK = f"script:{VEHICLES / 'dam.toml'}"
DAM_LEAK = f"script:{VEHICLES / 'dam_leak.toml'}"


def no_traceback(result: object) -> None:
    out = getattr(result, "stdout", "") + getattr(result, "stderr", "")
    assert "Traceback" not in out, out
    assert "internal error" not in out, out


@pytest.fixture(scope="module")
def dam_runs(tmp_path_factory: pytest.TempPathFactory) -> dict[str, tuple[object, Path]]:
    """The dam mission run once on each scripted vehicle (the slow part, shared)."""
    folder = tmp_path_factory.mktemp("runs")
    out = {}
    for name, vehicle in (("ok", DAM_OK), ("leak", DAM_LEAK)):
        log = folder / f"dam_{name}.jsonl"
        started = time.perf_counter()
        result = cli("mcl", "run", DAM, "--vehicle", vehicle, "--log", str(log))
        print(f"\nmcl run dam ({name}): {time.perf_counter() - started:.2f} s of wall time for "
              "the whole subprocess (start-up, compile, verify, run)")
        out[name] = (result, log)
    return out


# -- a good run --------------------------------------------------------------------------
def test_dam_run_exits_0_prints_a_timeline_and_writes_a_log(dam_runs: dict) -> None:
    result, log = dam_runs["ok"]
    assert result.returncode == 0, result.stderr
    no_traceback(result)
    out = result.stdout
    # the timeline: time, task, action or event, in order
    expected = ["→ enable StartLogs", "→ enable GoTo", "→ enable Alarms", "← GoTo.reached",
                "→ disable GoTo", "→ enable AchieveHeadDist", "← AchieveHeadDist.achieved",
                "→ enable StartCamera", "→ enable WallInspection", "← WallInspection.done",
                "→ disable WallInspection", "→ disable StartCamera",
                "→ disable AchieveHeadDist", "← GoTo.reached", "→ disable GoTo",
                "→ disable Alarms", "→ disable StartLogs", "mission ends OK"]
    positions = [out.find(x) for x in expected]
    assert -1 not in positions, [x for x, p in zip(expected, positions) if p < 0]
    # (GoTo.reached occurs twice: find each after the one before)
    at = 0
    for x in expected:
        at = out.index(x, at)
    assert re.search(r"^\s+0\.0 s\s+StartLogs@\d+:\d+\s+→ enable StartLogs", out, re.MULTILINE)
    assert "ended OK" in out and str(log) in out
    assert log.exists() and read_log(log)[0]["kind"] == "header"


def test_dam_log_replays_with_mcl_replay(dam_runs: dict) -> None:
    _, log = dam_runs["ok"]
    result = cli("mcl", "replay", str(log), DAM)
    assert result.returncode == 0, result.stdout + result.stderr
    assert "conforms" in result.stdout


def test_dam_leak_switches_everything_off_before_surfacing(dam_runs: dict) -> None:
    # Alarms.leak at 600 s: the outer CATCH fires; the survey stops (WallInspection), the
    # camera and the wall-keeping latched on inside TRY are switched off, and only then
    # does the vehicle surface.
    result, log = dam_runs["leak"]
    assert result.returncode == 0, result.stderr
    no_traceback(result)
    lines = result.stdout.splitlines()
    order = ["← Alarms.leak", "→ disable WallInspection", "→ disable StartCamera",
             "→ disable AchieveHeadDist", "→ enable Surface"]
    alarm = next(i for i, line in enumerate(lines) if order[0] in line)
    after = lines[alarm:]
    found = [next((i for i, line in enumerate(after) if want in line), -1) for want in order]
    assert -1 not in found, after
    assert found == sorted(found), [after[i] for i in found]
    for i in found:  # all in the same instant
        assert after[i].strip().startswith("600.0 s"), after[i]
    # nothing else is switched on in between
    assert not any("→ enable" in line for line in after[1:found[-1]]), after[:found[-1]]
    assert "mission ends OK" in result.stdout
    replay = cli("mcl", "replay", str(log), DAM)
    assert replay.returncode == 0, replay.stdout + replay.stderr


# -- logs that are not what the run wrote ----------------------------------------------------
def test_a_truncated_log_makes_replay_exit_1_naming_the_line(dam_runs: dict,
                                                             tmp_path: Path) -> None:
    _, log = dam_runs["ok"]
    raw = log.read_bytes()
    lines = raw.split(b"\n")
    keep = len(lines) // 2  # cut in the middle of this line
    cut = tmp_path / "cut.jsonl"
    cut.write_bytes(b"\n".join(lines[:keep]) + b"\n" + lines[keep][:10])
    result = cli("mcl", "replay", str(cut), DAM)
    assert result.returncode == 1
    no_traceback(result)
    assert f"{cut}:{keep + 1}:" in result.stdout + result.stderr


def edit_line(log: Path, out: Path, which: str) -> int:
    """Copy the log with one record edited; return the number of the edited line."""
    records = [json.loads(line) for line in log.read_text().splitlines()]
    if which == "rename":
        i = next(i for i, r in enumerate(records) if r["kind"] == "fire" and
                 r["transition"].startswith("GoTo@"))
        records[i]["transition"] = records[i]["transition"].replace("GoTo@", "Goto@")
    elif which == "params":
        i = next(i for i, r in enumerate(records) if r["kind"] == "action" and
                 r["behaviour"] == "GoTo")
        records[i]["params"]["x"] = 99.0
    elif which == "drop":
        # drop the firing that ends WallInspect: the next firing is then not enabled
        i = next(i for i, r in enumerate(records) if r["kind"] == "fire" and
                 r["transition"].startswith("WallInspect@") and ".ok." in r["transition"])
        del records[i]  # its action (disable WallInspection) now comes unexplained
    elif which == "status":
        i = next(i for i, r in enumerate(records) if r["kind"] == "status" and
                 r["status"] == "ok")
        records[i]["status"] = "fail"
    else:
        raise ValueError(which)
    out.write_text("".join(json.dumps(r, separators=(",", ":")) + "\n" for r in records))
    return i + 1


@pytest.mark.parametrize("which", ["rename", "params", "drop", "status"])
def test_an_edited_log_makes_replay_exit_1_naming_the_line(dam_runs: dict, tmp_path: Path,
                                                           which: str) -> None:
    _, log = dam_runs["ok"]
    edited = tmp_path / "edited.jsonl"
    line = edit_line(log, edited, which)
    result = cli("mcl", "replay", str(edited), DAM)
    assert result.returncode == 1, result.stdout
    no_traceback(result)
    assert f"{edited}:{line}: not conformant" in result.stdout, (line, result.stdout)


def test_a_log_of_another_mission_is_not_conformant(dam_runs: dict, tmp_path: Path) -> None:
    _, log = dam_runs["ok"]
    other = tmp_path / "other.mcl"
    other.write_text(Path(DAM).read_text().replace("PARAM d           = 1.5 m;",
                                                    "PARAM d           = 2 m;"))
    result = cli("mcl", "replay", str(log), str(other))
    assert result.returncode == 1
    assert "different net" in result.stdout


# -- bad input: exit 2, a message, no traceback -------------------------------------------
def write_bad_files(tmp: Path) -> None:
    (tmp / "bad.toml").write_text("[behaviours.GoTo]\non_enable = { after = 5.0, event = \n")
    (tmp / "odd.toml").write_text("[vehicle]\nname = 'x'\n")
    (tmp / "neg.toml").write_text("[behaviours.GoTo]\non_enable = { after = -1, event = 'x' }\n")
    (tmp / "bad.mcl").write_text("MISSION { GoTo(initialPos); }\n")
    (tmp / "header.jsonl").write_text('{"kind":"header","format":"mcl-run-log/1"}\n')


def bad_inputs(tmp: Path) -> dict[str, list[str]]:
    log = str(tmp / "x.jsonl")
    return {
        "missing mission": ["run", str(tmp / "nope.mcl"), "--vehicle", DAM_OK, "--log", log],
        "invalid mission": ["run", str(tmp / "bad.mcl"), "--vehicle", DAM_OK, "--log", log],
        "bad TOML": ["run", DAM, "--vehicle", f"script:{tmp / 'bad.toml'}", "--log", log],
        "unknown section": ["run", DAM, "--vehicle", f"script:{tmp / 'odd.toml'}", "--log", log],
        "negative delay": ["run", DAM, "--vehicle", f"script:{tmp / 'neg.toml'}", "--log", log],
        "missing vehicle file": ["run", DAM, "--vehicle", f"script:{tmp / 'no.toml'}",
                                 "--log", log],
        "script without file": ["run", DAM, "--vehicle", "script:", "--log", log],
        "unknown vehicle kind": ["run", DAM, "--vehicle", "warp:drive", "--log", log],
        "unknown parameter": ["run", DAM, "--vehicle", DAM_OK, "--param", "nope=3",
                              "--log", log],
        "parameter of the wrong kind": ["run", DAM, "--vehicle", DAM_OK, "--param", "d=enable",
                                        "--log", log],
        "not NAME=VALUE": ["run", DAM, "--vehicle", DAM_OK, "--param", "d", "--log", log],
        "Zenoh option on another vehicle": ["run", DAM, "--user", "pilot", "--log", log],
        "MAVLink option on another vehicle": ["run", DAM, "--vehicle", "zenoh:tcp/127.0.0.1:9",
                                              "--require-signing", "--log", log],
        "replay: missing mission": ["replay", str(tmp / "header.jsonl"),
                                    str(tmp / "nope.mcl")],
        "replay: invalid mission": ["replay", str(tmp / "header.jsonl"), str(tmp / "bad.mcl")],
    }


BAD = sorted(bad_inputs(Path("/nonexistent")))


@pytest.mark.parametrize("case", BAD)
def test_bad_input_exits_2_without_a_traceback(case: str, tmp_path: Path) -> None:
    write_bad_files(tmp_path)
    args = bad_inputs(tmp_path)[case]
    result = cli("mcl", *args)
    assert result.returncode == 2, (result.stdout, result.stderr)
    no_traceback(result)
    assert "error" in result.stderr, result.stderr


def test_a_parameter_naming_an_unknown_parameter_exits_2(tmp_path: Path) -> None:
    mission = tmp_path / "w.mcl"
    mission.write_text("PARAM s = 1 s;\nMISSION { Wait(s) }\n")
    (tmp_path / "empty.toml").write_text("")
    result = cli("mcl", "run", str(mission), "--vehicle", f"script:{tmp_path / 'empty.toml'}",
                 "--param", "s=zzz", "--log", str(tmp_path / "w.jsonl"))
    no_traceback(result)
    assert result.returncode == 2, result.stderr


# -- how long the dam run takes inside the process (printed, not asserted) ----------------
@pytest.mark.parametrize("vehicle_file, mission_time", [("dam.toml", 1775.0),
                                                         ("dam_leak.toml", 625.0)])
def test_dam_run_in_process_wall_time(tmp_path: Path, vehicle_file: str,
                                      mission_time: float) -> None:
    started = time.perf_counter()
    compiled = compile_file(DAM)
    compile_time = time.perf_counter() - started
    timings = []
    for _ in range(5):
        vehicle = InProcess(ScriptedVehicle(load_script(str(VEHICLES / vehicle_file))))
        player = Player(compiled.net)
        log_path = tmp_path / "dam.jsonl"
        started = time.perf_counter()
        with RunLog(log_path, {"mission": "dam_inspection",
                               "net": net_digest(compiled.net), "params": {}}) as log:
            player.observers.append(log)
            outcome = run(player, vehicle, "dam_inspection")
        timings.append(time.perf_counter() - started)
        assert outcome.status == "ok" and outcome.time == pytest.approx(mission_time)
        assert check(compiled.net, read_log(log_path), {}).ok
    best = min(timings)
    print(f"\ndam mission on {vehicle_file} ({player.fired} firings, {mission_time:g} s of "
          f"mission time): {best * 1e3:.2f} ms of wall time in process (best of 5, with the "
          f"run log), median {sorted(timings)[2] * 1e3:.2f} ms; compiling it took "
          f"{compile_time * 1e3:.0f} ms")
