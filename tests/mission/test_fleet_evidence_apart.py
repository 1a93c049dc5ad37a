"""The logs of a fleet run apart over Zenoh (mission/fleet_evidence_apart.py): each vehicle's
own channel record, on its own clock, against the others' records and its run log. A run that
conforms passes; each forgery is named at the line that lies."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest

from diagnostics import Source
from mcl.fleet import CompiledFleet, compile_fleet_source
from mission.channels import ChannelRecord
from mission.fleet_evidence import RecordProblem
from mission.fleet_evidence_apart import is_apart, problem_apart, record_name

FLEET = """\
FLEET pair {
    CHANNEL orders FROM leader TO follower ACOUSTIC DELAY 1 s .. 3 s EVERY 2 s LOSSY
        MESSAGES go, done;
    CHANNEL calm FROM leader TO follower RADIO DELAY 1 s .. 2 s MESSAGES hush;
    VEHICLE leader { MISSION lead { Send(orders, go); Wait(40 s); Send(orders, done) } }
    VEHICLE follower {
        MISSION follow { Receive(orders, go, timeout = 1 min) } ON STOP { Surface() }
    }
}
"""
T0_LEADER, T0_FOLLOWER = 3.0, 1.5  # the vehicles' clocks at their missions' start

Line = dict[str, Any]


@pytest.fixture(scope="module")
def fleet() -> CompiledFleet:
    return compile_fleet_source(Source("pair.mcl", FLEET))


def sent(seq: int, message: str, at: float) -> Line:
    return {"t": at, "kind": "sent", "channel": "orders", "message": message,
            "sender": "leader", "seq": seq, "sent": at}


def heard(kind: str, seq: int, message: str, at: float, t: float, **more: Any) -> Line:
    return {"t": t, "kind": kind, "channel": "orders", "message": message, "sender": "leader",
            "seq": seq, "sent": at, "receiver": "follower", **more}


def honest() -> tuple[list[Line], list[Line], list[Line], list[Line]]:
    """The leader's record and log, the follower's record and log, of a run that conforms."""
    lead_record = [sent(0, "go", 3.0), sent(1, "done", 43.0)]
    follow_record = [heard("delivered", 0, "go", 3.0, 15.5, delay=1.7),
                     heard("delivered", 1, "done", 43.0, 55.25, delay=1.0)]
    lead_log = [{"t": 0.0, "kind": "action", "action": "send", "behaviour": "orders",
                 "params": {"message": "go"}, "_line": 4},
                {"t": 40.0, "kind": "action", "action": "send", "behaviour": "orders",
                 "params": {"message": "done"}, "_line": 8},
                {"t": 40.0, "kind": "end", "vehicle_t0": T0_LEADER, "_line": 12}]
    follow_log = [{"t": 14.0, "kind": "event", "event": "orders.go", "vt": 15.5000004,
                   "_line": 5},
                  {"t": 53.75, "kind": "ignored", "event": "orders.done", "vt": 55.25,
                   "_line": 9},
                  {"t": 54.0, "kind": "end", "vehicle_t0": T0_FOLLOWER, "_line": 10}]
    return lead_record, lead_log, follow_record, follow_log


def write(folder: Path, name: str, lines: list[Line], fleet_name: str = "pair") -> None:
    record = ChannelRecord(folder / record_name(name), {"fleet": fleet_name, "as": name})
    for line in lines:
        record.write(line)
    record.close(100.0, "ended")


def check(fleet: CompiledFleet, tmp_path: Path,
          forge: Callable[..., object] = lambda *_: None) -> RecordProblem | None:
    lead_record, lead_log, follow_record, follow_log = honest()
    forge(lead_record, lead_log, follow_record, follow_log)
    write(tmp_path, "leader", lead_record)
    write(tmp_path, "follower", follow_record)
    return problem_apart(fleet, tmp_path, {"leader": lead_log, "follower": follow_log})


def test_a_run_apart_that_conforms_passes(fleet: CompiledFleet, tmp_path: Path) -> None:
    assert check(fleet, tmp_path) is None
    assert is_apart(tmp_path, ["leader", "follower"])
    (tmp_path / "channels.jsonl").write_text("")
    assert not is_apart(tmp_path, ["leader", "follower"])  # one process's layout


FORGERIES: dict[str, tuple[Callable[..., object], str, str]] = {
    "heard, never sent": (
        lambda lr, ll, fr, fl: fr.append(heard("lost", 7, "go", 9.0, 20.0, why="x")),
        "channels-follower.jsonl", "which its sender's record does not send"),
    "send time changed": (
        lambda lr, ll, fr, fl: fr[0].update(sent=3.5),
        "channels-follower.jsonl", "which its sender's record does not send"),
    "delay outside DELAY": (
        lambda lr, ll, fr, fl: fr[1].update(delay=3.5),
        "channels-follower.jsonl", "outside orders's DELAY"),
    "heard twice": (
        lambda lr, ll, fr, fl: fr.append(heard("undelivered", 1, "done", 43.0, 99.0)),
        "channels-follower.jsonl", "heard twice"),
    "a delivery the log hides": (
        lambda lr, ll, fr, fl: fl.pop(1),
        "follower.jsonl", "the log does not show it"),
    "an event the record hides": (
        lambda lr, ll, fr, fl: fr.pop(1),
        "follower.jsonl", "does not deliver"),
    "a Send without its sent line": (
        lambda lr, ll, fr, fl: lr.pop(1),
        "leader.jsonl", "has no 'sent' line"),
    "a sent line without its Send": (
        lambda lr, ll, fr, fl: ll.pop(1),
        "leader.jsonl", "its log shows no such Send"),
    "dropped outside EVERY": (
        lambda lr, ll, fr, fl: fr.__setitem__(1, heard("dropped", 1, "done", 43.0, 44.0,
                                                       why="x")) or fl.pop(1),
        "channels-follower.jsonl", "not closer than EVERY"),
    "lost on a channel that is not LOSSY": (
        lambda lr, ll, fr, fl: (lr.append({**sent(2, "hush", 60.0), "channel": "calm"}),
                                ll.insert(2, {"t": 57.0, "kind": "action", "action": "send",
                                              "behaviour": "calm",
                                              "params": {"message": "hush"}, "_line": 11}),
                                fr.append({**heard("lost", 2, "hush", 60.0, 61.0, why="x"),
                                           "channel": "calm"})),
        "channels-follower.jsonl", "which is not LOSSY"),
}


@pytest.mark.parametrize("case", list(FORGERIES))
def test_a_forgery_is_named_where_it_lies(case: str, fleet: CompiledFleet,
                                          tmp_path: Path) -> None:
    forge, where, said = FORGERIES[case]
    wrong = check(fleet, tmp_path, forge)
    assert wrong is not None and said in wrong.reason, wrong
    assert Path(wrong.path).name == where


def test_a_record_of_another_vehicle_or_fleet_is_refused(fleet: CompiledFleet,
                                                         tmp_path: Path) -> None:
    lead_record, lead_log, follow_record, follow_log = honest()
    write(tmp_path, "leader", lead_record)
    write(tmp_path, "follower", follow_record, fleet_name="other")
    with pytest.raises(RecordProblem, match="not the channel record of vehicle follower"):
        problem_apart(fleet, tmp_path, {"leader": lead_log, "follower": follow_log})
    (tmp_path / record_name("follower")).unlink()
    with pytest.raises(RecordProblem, match="no channel record of vehicle follower"):
        problem_apart(fleet, tmp_path, {"leader": lead_log, "follower": follow_log})
