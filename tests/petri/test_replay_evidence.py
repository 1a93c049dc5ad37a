"""Run logs are evidence (issue 12, point 3): ``mcl replay`` refuses any log that is not
exactly what the run wrote, and names the first record that is not.

Every record carries a digest chained over the records before it (petri/execution/runlog.py), so an
edit anywhere — a record dropped, moved, inserted or changed — breaks the chain at that
record; a log cut at a line boundary lacks its end record; a header-only log is refused; a
malformed record is an error with its line number (exit 1), never an internal error. The net's
digest identifies the net, not the path used to name its file.

The logs are made in process (player, runner, scripted vehicle, RunLog) and replayed through
``app.mcl.main(["replay", ...])`` in process: exit 0 conformant, 1 not, 2 invalid input.
"""

from __future__ import annotations

import hashlib
import json
import shutil
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from mcl.api import compile_file
from app import mcl
from petri.execution.player import Player
from petri.execution.replay import check
from petri.execution.runlog import FORMAT, GENESIS, RunLog, canonical, net_digest, read_log, verify
from petri.execution.runner import run
from tests.support import MISSIONS
from vehicle_adapters.inprocess import InProcess
from vehicle.scripted import ScriptedVehicle, load_script

DAM = MISSIONS / "dam_inspection.mcl"
DAM_OK = MISSIONS / "vehicles" / "dam.toml"
TIMER_MISSION = """MISSION {
    StartLogs(enable);
    GoTo((0, 0, 1, 0 deg));
    Wait(305 s);
    StartLogs(disable)
}
"""


def make_log(mission: Path, script: Path, out: Path, file: str | None = None) -> Path:
    """Run ``mission`` on the scripted vehicle in process and write its run log, ending with
    the end record, as ``mcl run`` does."""
    compiled = compile_file(str(mission))
    player = Player(compiled.net)
    header = {"mission": compiled.mission.name or "m", "file": file or str(mission),
              "net": net_digest(compiled.net), "params": {}, "tasks": []}
    with RunLog(out, header) as log:
        player.observers.append(log)
        outcome = run(player, InProcess(ScriptedVehicle(load_script(str(script)))), "m")
        log.end(outcome.time, outcome.status, outcome.reason)
    assert outcome.status == "ok", outcome
    return out


@pytest.fixture(scope="module")
def logs(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    folder = tmp_path_factory.mktemp("logs")
    timer = folder / "timer.mcl"
    timer.write_text(TIMER_MISSION, "utf-8")
    return {"dam": make_log(DAM, DAM_OK, folder / "dam.jsonl"),
            "timer": make_log(timer, DAM_OK, folder / "timer.jsonl"),
            "timer.mcl": timer}


def records_of(path: Path) -> list[dict[str, Any]]:
    return [json.loads(line) for line in path.read_text("utf-8").splitlines()]


def write_records(path: Path, records: list[dict[str, Any]], rechain: bool = False) -> Path:
    """Write records as a log; ``rechain``: recompute every digest (a forger who knows the
    chain's rule), so that only the records' meaning can betray the edit."""
    previous = GENESIS
    lines = []
    for r in records:
        if rechain:
            previous = hashlib.sha256((previous + canonical(r)).encode()).hexdigest()
            r = {**r, "digest": previous}
        lines.append(json.dumps(r, separators=(",", ":")) + "\n")
    path.write_text("".join(lines), "utf-8")
    return path


def replay(capsys: pytest.CaptureFixture[str], log: Path, mission: Path | str
           ) -> tuple[int, str]:
    code = mcl.main(["replay", str(log), str(mission)])
    captured = capsys.readouterr()
    return code, captured.out + captured.err


def index(records: list[dict[str, Any]], **match: Any) -> int:
    return next(i for i, r in enumerate(records) if all(r.get(k) == v for k, v in match.items()))


# -- the genuine log --------------------------------------------------------------------------
def test_a_genuine_log_conforms(logs: dict[str, Path], capsys: pytest.CaptureFixture[str]
                                ) -> None:
    code, out = replay(capsys, logs["dam"], DAM)
    assert code == 0, out
    assert "conforms" in out and "41 firings" in out
    records = records_of(logs["dam"])
    assert records[0]["format"] == FORMAT
    assert records[-1]["kind"] == "end"
    assert all(len(r["digest"]) == 64 for r in records)


def test_the_mission_path_may_be_spelt_differently(
        logs: dict[str, Path], tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
        capsys: pytest.CaptureFixture[str]) -> None:
    # run as missions/x.mcl from the repository, replayed as x.mcl from inside missions/
    folder = tmp_path / "repo"
    (folder / "missions").mkdir(parents=True)
    shutil.copy(DAM, folder / "missions" / "dam_inspection.mcl")
    monkeypatch.chdir(folder)
    log = make_log(Path("missions/dam_inspection.mcl"), DAM_OK, tmp_path / "run.jsonl")
    monkeypatch.chdir(folder / "missions")
    code, out = replay(capsys, log, "dam_inspection.mcl")
    assert code == 0, out
    # the same mission under another name and through an absolute path: the same net
    shutil.copy(DAM, tmp_path / "renamed.mcl")
    code, out = replay(capsys, log, tmp_path / "renamed.mcl")
    assert code == 0, out


def test_the_net_digest_ignores_file_names_but_not_the_net(tmp_path: Path) -> None:
    a = tmp_path / "a.mcl"
    b = tmp_path / "sub" / "b.mcl"
    b.parent.mkdir()
    text = DAM.read_text("utf-8")
    a.write_text(text, "utf-8")
    b.write_text(text, "utf-8")
    assert net_digest(compile_file(str(a)).net) == net_digest(compile_file(str(b)).net)
    b.write_text(text.replace("PARAM d           = 1.5 m;", "PARAM d           = 2 m;"))
    assert net_digest(compile_file(str(a)).net) != net_digest(compile_file(str(b)).net)
    # moved by one line: the origins (MCL lines) are part of the net
    b.write_text("\n" + text, "utf-8")
    assert net_digest(compile_file(str(a)).net) != net_digest(compile_file(str(b)).net)


# -- what a new user saw accepted (issue 12) ------------------------------------------------
def drop_event(records: list[dict[str, Any]], event: str) -> tuple[list[dict[str, Any]], int]:
    i = index(records, kind="event", event=event)
    return records[:i] + records[i + 1:], i + 1


def edited_cases(logs: dict[str, Path]) -> dict[str, tuple[list[dict[str, Any]], Path, int]]:
    """name -> (records, mission, the line replay must name)."""
    dam, timer = records_of(logs["dam"]), records_of(logs["timer"])
    out: dict[str, tuple[list[dict[str, Any]], Path, int]] = {}
    dropped, line = drop_event(dam, "WallInspection.done")
    out["the WallInspection.done event dropped"] = (dropped, DAM, line)
    first = index(dam, kind="event")
    out["every event dropped"] = ([r for r in dam if r["kind"] != "event"], DAM, first + 1)
    i = index(dam, kind="fire", cause="WallInspection.done")
    out["a firing's cause rewritten to Link.lost"] = (
        [*dam[:i], {**dam[i], "cause": "Link.lost"}, *dam[i + 1:]], DAM, i + 1)
    i = index(timer, kind="fire", cause="timer")
    assert timer[i]["t"] == 345.0  # 40 s to get there, then 305 s
    out["a timer firing moved from 345 s to 999 s"] = (
        [*timer[:i], {**timer[i], "t": 999.0}, *timer[i + 1:]], logs["timer.mcl"], i + 1)
    i = index(dam, kind="event", event="WallInspection.done")
    out["time going backwards"] = ([*dam[:i], {**dam[i], "t": 5.0}, *dam[i + 1:]], DAM, i + 1)
    out["two records swapped"] = ([*dam[:i], dam[i + 1], dam[i], *dam[i + 2:]], DAM, i + 1)
    out["a record inserted"] = ([*dam[:i], dam[i - 1], *dam[i:]], DAM, i + 1)
    out["the header's net digest edited"] = ([{**dam[0], "net": "0" * 16}, *dam[1:]], DAM, 1)
    out["the end record's reason edited"] = ([*dam[:-1], {**dam[-1], "why": "all fine"}], DAM,
                                             len(dam))
    out["cut at a line boundary"] = (dam[:30], DAM, 31)
    out["cut just before the end record"] = (dam[:-1], DAM, len(dam))
    out["header only"] = (dam[:1], DAM, 2)
    return out


@pytest.mark.parametrize("case", [
    "the WallInspection.done event dropped", "every event dropped",
    "a firing's cause rewritten to Link.lost", "a timer firing moved from 345 s to 999 s",
    "time going backwards", "two records swapped", "a record inserted",
    "the header's net digest edited", "the end record's reason edited",
    "cut at a line boundary", "cut just before the end record", "header only"])
def test_an_edited_log_is_refused_naming_the_first_edited_line(
        case: str, logs: dict[str, Path], tmp_path: Path,
        capsys: pytest.CaptureFixture[str]) -> None:
    records, mission, line = edited_cases(logs)[case]
    log = write_records(tmp_path / "edited.jsonl", records)
    code, out = replay(capsys, log, mission)
    assert code == 1, out
    assert f"{log}:{line}: not conformant" in out, (line, out)
    assert "Traceback" not in out and "internal error" not in out


@pytest.mark.parametrize("case", [
    "the WallInspection.done event dropped", "every event dropped",
    "a firing's cause rewritten to Link.lost", "time going backwards",
    "cut at a line boundary", "header only"])
def test_a_forged_log_with_a_recomputed_chain_is_still_refused(
        case: str, logs: dict[str, Path], tmp_path: Path,
        capsys: pytest.CaptureFixture[str]) -> None:
    # The chain is not a signature: whoever knows its rule can recompute it. The replay's
    # own checks still catch these edits by their meaning.
    records, mission, _ = edited_cases(logs)[case]
    log = write_records(tmp_path / "forged.jsonl", records, rechain=True)
    code, out = replay(capsys, log, mission)
    assert code == 1, out
    assert f"{log}:" in out and "not conformant" in out, out


def test_a_log_of_the_first_format_is_refused(logs: dict[str, Path], tmp_path: Path,
                                              capsys: pytest.CaptureFixture[str]) -> None:
    old = [{k: v for k, v in r.items() if k != "digest"} for r in records_of(logs["dam"])]
    old[0]["format"] = "mcl-run-log/1"
    log = write_records(tmp_path / "old.jsonl", old)
    code, out = replay(capsys, log, DAM)
    assert code == 1 and f"{log}:1: not conformant" in out and "digest" in out, out


# -- malformed records: an error with its line, never exit 3 ----------------------------------
MALFORMED: dict[str, Callable[[dict[str, Any]], Any]] = {
    '"t": "zero"': lambda r: {**r, "t": "zero"},
    '"t": null': lambda r: {**r, "t": None},
    '"t": true': lambda r: {**r, "t": True},
    "no kind": lambda r: {k: v for k, v in r.items() if k != "kind"},
    "kind a number": lambda r: {**r, "kind": 7},
    "a list, not an object": lambda r: [r],
    "a string": lambda r: "fire",
    "behaviour a list": lambda r: {**r, "kind": "action", "action": "enable",
                                   "behaviour": ["GoTo"], "params": {}, "task": "x"},
    "index a string": lambda r: {**r, "kind": "fire", "transition": "x", "index": "3",
                                 "cause": "immediate"},
    "params a list": lambda r: {**r, "kind": "action", "action": "enable",
                                "behaviour": "GoTo", "params": [], "task": "x"},
    "digest a number": lambda r: {**r, "digest": 12},
}


@pytest.mark.parametrize("what", sorted(MALFORMED))
@pytest.mark.parametrize("rechain", [False, True])
def test_a_malformed_record_is_an_error_naming_its_line(
        what: str, rechain: bool, logs: dict[str, Path], tmp_path: Path,
        capsys: pytest.CaptureFixture[str]) -> None:
    records: list[Any] = records_of(logs["dam"])
    records[5] = MALFORMED[what](records[5])
    log = tmp_path / "bad.jsonl"
    if rechain and isinstance(records[5], dict) and what != "digest a number":
        write_records(log, records, rechain=True)
    else:
        log.write_text("".join(json.dumps(r, separators=(",", ":")) + "\n" for r in records), "utf-8")
    code, out = replay(capsys, log, DAM)
    assert code == 1, out
    assert f"{log}:6:" in out, out
    assert "Traceback" not in out and "internal error" not in out, out


@pytest.mark.parametrize("junk", [b"", b"\n", b"{}\n", b"\xff\xfe\n", b"[[[[\n" * 3,
                                  b"[" * 100_000 + b"\n", b'{"kind":"header"}\n'])
def test_junk_is_not_a_run_log(junk: bytes, tmp_path: Path,
                               capsys: pytest.CaptureFixture[str]) -> None:
    log = tmp_path / "junk.jsonl"
    log.write_bytes(junk)
    code, out = replay(capsys, log, DAM)
    assert code in (1, 2), out
    assert out.startswith(str(log)), out
    assert "Traceback" not in out and "internal error" not in out, out


def test_a_log_that_is_a_directory_or_missing_is_invalid_input(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    code, out = replay(capsys, tmp_path, DAM)
    assert code == 2 and "is a directory" in out, out
    code, out = replay(capsys, tmp_path / "nope.jsonl", DAM)
    assert code == 2 and "no such file" in out, out


# -- any single edit, anywhere, is caught at its line (Hypothesis) ---------------------------
EDITS = st.sampled_from(["drop", "swap", "duplicate", "change", "cut"])


@settings(max_examples=150, deadline=None, derandomize=True,
          suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(edit=EDITS, where=st.integers(0, 10_000), value=st.one_of(
    st.integers(), st.floats(allow_nan=False), st.text(max_size=5), st.none()))
def test_any_single_edit_is_caught_at_its_line(logs: dict[str, Path], edit: str, where: int,
                                               value: Any) -> None:
    records = records_of(logs["dam"])
    n = len(records)
    i = where % n
    if edit == "drop":
        edited, line = records[:i] + records[i + 1:], i + 1
    elif edit == "swap":
        i = min(i, n - 2)
        edited, line = [*records[:i], records[i + 1], records[i], *records[i + 2:]], i + 1
    elif edit == "duplicate":
        edited, line = [*records[:i + 1], records[i], *records[i + 1:]], i + 2
    elif edit == "change":
        fields = sorted(k for k in records[i] if k != "digest")
        key = fields[where % len(fields)]
        if records[i][key] == value:
            return
        edited, line = [*records[:i], {**records[i], key: value}, *records[i + 1:]], i + 1
    else:
        edited, line = records[:i], i + 1
    folder = logs["dam"].parent
    path = write_records(folder / f"edit-{edit}.jsonl", edited)
    named = None
    try:
        parsed = read_log(path)
        verify(parsed, path)
    except ValueError as exc:
        named = getattr(exc, "line", None)
    assert named == line, (edit, i, named, line)


def test_the_genuine_records_pass_verify_and_check(logs: dict[str, Path]) -> None:
    records = read_log(logs["dam"])
    verify(records, logs["dam"])
    assert check(compile_file(str(DAM)).net, records, {}).ok
