"""``mcl run``'s timeline tells the progress of a long task (issue 25: "the timeline jumps from
21.7 s to 1175.8 s with nothing in between"): on the simulated dam survey, a line at least
every minute of mission time with the waypoint, the metres to go and the time left."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from tests.support import MISSIONS, cli

DAM = str(MISSIONS / "dam_inspection.mcl")
LINE = re.compile(r"^\s*(\d+\.\d) s  (\S*)\s+(→|←|…) (.*)$")
PROGRESS = re.compile(r"waypoint (\d+)/(\d+), ([\d.]+) m to go; (\d+) s, (\d+) s left of "
                      r"3600 s")


@pytest.mark.slow
def test_the_survey_reports_its_progress_every_minute(tmp_path: Path) -> None:
    result = cli("mcl", "run", DAM, "--no-images", "--log", str(tmp_path / "dam.jsonl"))
    assert result.returncode == 0, result.stderr
    timeline = [m.groups() for m in map(LINE.match, result.stdout.splitlines()) if m]
    times = [float(t) for t, *_ in timeline]
    start = next(i for i, (_, task, arrow, _) in enumerate(timeline)
                 if task == "WallInspect@39:13" and arrow == "→")
    end = next(i for i, (*_, what) in enumerate(timeline) if what == "WallInspection.done")
    assert times[end] - times[start] > 1000  # a survey of about 20 min
    # never more than a minute (and a round of the vehicle) of mission time without a line
    gaps = [b - a for a, b in zip(times[start:end + 1], times[start + 1:end + 1])]
    assert max(gaps) <= 60.2, gaps
    reports = [PROGRESS.search(what) for _, task, arrow, what in timeline[start:end]
               if arrow == "…" and task == "WallInspect@39:13"]
    assert len(reports) >= 15 and all(reports)
    waypoint = [int(m.group(1)) for m in reports if m]
    to_go = [float(m.group(3)) for m in reports if m]
    left = [int(m.group(5)) for m in reports if m]
    assert {int(m.group(2)) for m in reports if m} == {82}
    assert waypoint == sorted(waypoint) and waypoint[0] < 10 and waypoint[-1] >= 78
    assert to_go == sorted(to_go, reverse=True) and to_go[0] > 130 and to_go[-1] < 10
    assert left == sorted(left, reverse=True) and left[0] > 3500
    # the watchers of the whole mission (Alarms, no bound, no progress) make no lines
    assert not any(arrow == "…" and task.startswith("Alarms@") for _, task, arrow, _ in timeline)
