"""``mcl run`` with no vehicle there, as a real subprocess: progress while it waits ("waiting
for the vehicle at ... (N s)"), then a refusal before the mission starts ("no vehicle answered
at ... within N s"), exit 6 (``Exit.NO_VEHICLE``), nothing sent and a log whose end record says
the mission never started. Issue 21: it used to print timeline lines after "link lost",
"ended FAIL after 0.0 s" and exit 1, as if a mission had run."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from mission.exits import Exit
from tests.support import budget, cli, free_endpoint, free_udp_port, write

MISSION = "MISSION m { GoTo((-1, 0, 1, 0)) }\n"


@pytest.mark.slow
@pytest.mark.parametrize("kind, wait", [("mavlink", 10), ("zenoh", 5)])
def test_no_vehicle_is_refused_before_the_start(tmp_path: Path, kind: str, wait: int) -> None:
    where = (f"mavlink:udpin:127.0.0.1:{free_udp_port()}" if kind == "mavlink"
             else f"zenoh:{free_endpoint()}")  # nobody there
    log = tmp_path / "run.jsonl"
    result = cli("mcl", "run", str(write(tmp_path, MISSION)), "--vehicle", where,
                 "--log", str(log), timeout=budget(wait + 20))
    assert result.returncode == Exit.NO_VEHICLE == 6, result.stdout + result.stderr
    assert f"waiting for the vehicle at {where} (1 s)" in result.stderr
    assert f"no vehicle answered at {where} within {wait} s" in result.stderr
    assert "the mission never started" in result.stderr
    assert "Traceback" not in result.stderr
    assert "→" not in result.stdout and "ended" not in result.stdout  # no timeline, no end
    records = [json.loads(line) for line in log.read_text("utf-8").splitlines()]
    assert [r["kind"] for r in records] == ["header", "end"]  # nothing fired, nothing sent
    end = records[-1]
    assert (end["how"], end["exit"], end["status"]) == ("no vehicle", 6, "ready")
    assert "never started" in end["why"] and where in end["why"]
