"""A long task's progress in the run log (mission/progress.py's ProgressLog, issue 25
deliverable 4: "long tasks report progress ... in the timeline, the monitor and the view"):
once a minute of mission time, what its behaviour says (metres to go) with the time left of
its bound, so that a finished run's view and MCAP file show it too; the replay passes over
it; and ``mcl run`` of the simulated vehicle logs its pose once a second."""

from __future__ import annotations


from typing import Any

import pytest

from app.view.data import timeline
from mcl.api import compile_file
from mission import run_mission, simulated_vehicle
from mission.mcap_messages import LogMessages
from mission.poses import track_of
from petri.execution.replay import check
from petri.execution.runlog import read_log, verify

Run = tuple[list[dict[str, Any]], Any]  # the run log's records, the compiled mission

LONG_GOTO = """\
MISSION long_goto {
    GoTo((-1.5, 50, 2, 0 deg))
}
"""


@pytest.fixture(scope="module")
def long_run(tmp_path_factory: pytest.TempPathFactory) -> Run:
    folder = tmp_path_factory.mktemp("long")
    (folder / "long.mcl").write_text(LONG_GOTO, encoding="utf-8")
    compiled = compile_file(str(folder / "long.mcl"), require_values=True)
    vehicle = simulated_vehicle(seed=1)
    result = run_mission(compiled, vehicle, log=folder / "run.jsonl", verify=False,
                         track=track_of(vehicle))
    assert result.status == "ok" and result.time > 125.0, result
    records = read_log(folder / "run.jsonl")
    verify(records, folder / "run.jsonl")
    return records, compiled


@pytest.mark.slow  # 140 s of a simulated GoTo: 2 to 5 s on a busy machine
def test_a_long_task_s_progress_once_a_minute(long_run: Run) -> None:
    records, compiled = long_run
    said = [r for r in records if r["kind"] == "progress"]
    assert [round(r["t"]) for r in said] == [60, 120]
    assert {r["task"] for r in said} == {"GoTo@2:5"}
    gone = [r["progress"]["to_go"] for r in said]
    assert gone[0] > gone[1] > 0.0  # metres to go, fewer a minute later
    for r in said:
        assert r["left"] == pytest.approx(r["since"] + r["bound"] - r["t"], abs=0.1)
    assert check(compiled.net, records, {}).ok


@pytest.mark.slow
def test_the_view_and_the_mcap_log_show_it_at_its_line(
        long_run: Run) -> None:
    records, _ = long_run
    entries = [e for e in timeline(records) if e["kind"] == "progress"]
    assert [e["line"] for e in entries] == [2, 2]
    assert entries[0]["text"].startswith("GoTo@2:5 … ") and " m to go" in entries[0]["text"]
    logged = [m.data for m in LogMessages.of_log(records) if m.topic == "/mission/log"
              and m.data["message"].startswith("progress: ")]
    assert [m["line"] for m in logged] == [2, 2]
    first = next(r for r in records if r["kind"] == "progress")
    assert logged[0]["message"].startswith(f"progress: to_go {first['progress']['to_go']}; ")


@pytest.mark.slow
def test_the_simulated_vehicle_s_pose_once_a_second(long_run: Run
                                                    ) -> None:
    records, _ = long_run
    poses = [r for r in records if r["kind"] == "pose"]
    end = records[-1]["t"]
    assert len(poses) == pytest.approx(end, abs=2)
    assert poses[-1]["y"] == pytest.approx(50.0, abs=1.0)  # where the GoTo went
    times = [r["t"] for r in records[1:]]
    assert times == sorted(times)
