"""The run log (petri/execution/runlog.py): RunLog writes what the player did, read_log reads it back
record for record, and the log replays as conformant. (Logs as evidence, edits and forgeries
refused by ``mcl replay``: tests/petri/test_replay_evidence.py.)
"""

from __future__ import annotations

from pathlib import Path

from petri.execution.replay import check
from petri.execution.runlog import FORMAT, RunLog, net_digest, read_log
from tests.harness import TRY, Harness, drive


# -- the run log: RunLog and read_log --------------------------------------------------------
def test_run_log_round_trip_and_replay(tmp_path: Path) -> None:
    h = Harness(TRY)
    path = tmp_path / "run.jsonl"
    with RunLog(path, {"mission": "m", "net": net_digest(h.net), "params": {}}) as log:
        h.player.observers.append(log)
        drive(h, [(1, "Watch.alarm"), (2, "Beta.ok")])
    records = read_log(path)
    assert records[0]["kind"] == "header" and records[0]["format"] == FORMAT
    assert len(records) == len(h.records) + 1
    assert [r["kind"] for r in records[1:]] == [r.kind for r in h.records]
    assert check(h.net, records, {}).ok

