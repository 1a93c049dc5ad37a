"""A Zenoh vehicle knows a player that left on purpose from one that is lost: after a mission
that ended (its last mission status, ok or fail, names the run), the player's token going away
is a goodbye, not a reason for the failsafe. Issue 21: after a normal end ``mcl vehicle``
logged "surfacing (the player is lost)" and ``mcl monitor`` showed ``active: Surface
FAILSAFE``. Real processes: ``mcl vehicle`` and ``mcl run``."""

from __future__ import annotations

import json
import time
from pathlib import Path
from typing import Any

import pytest

zenoh = pytest.importorskip("zenoh")

from aal.zenoh import keys, zenoh_config  # noqa: E402
from tests.support import budget, cli, free_endpoint, write  # noqa: E402
from tests.vehicle_adapters.test_zenoh import stop, vehicle_process  # noqa: E402

pytestmark = pytest.mark.slow  # a real vehicle process over Zenoh: not in make test-quick

SHORT = "MISSION short { GoTo((-1, 0, 1, 0)) }\n"
PLAYER_TIMEOUT = 0.3  # wall s: the vehicle's failsafe delay in these tests


def test_no_failsafe_after_a_mission_that_ended(tmp_path: Path) -> None:
    endpoint = free_endpoint()
    states: list[dict[str, Any]] = []
    with vehicle_process(endpoint, "--player-timeout", str(PLAYER_TIMEOUT), speed=50) as proc:
        watcher = zenoh.open(zenoh_config(endpoint, connect=True))
        try:
            sub = watcher.declare_subscriber(f"{keys('auv')['telemetry']}/behaviours",
                                             lambda s: states.append(
                                                 json.loads(s.payload.to_bytes())))
            result = cli("mcl", "run", str(write(tmp_path, SHORT)), "--vehicle",
                         f"zenoh:{endpoint}", "--log", str(tmp_path / "run.jsonl"),
                         timeout=budget(30))
            assert result.returncode == 0, result.stdout + result.stderr
            assert "ended OK" in result.stdout
            ended = len(states)
            # the vehicle has seen the player's token go once its telemetry says so; a failsafe
            # would come PLAYER_TIMEOUT after that: wait well past it from then
            deadline = time.monotonic() + budget(1.0)
            while time.monotonic() < deadline and all(s["player"] for s in states[ended:]):
                time.sleep(0.02)
            time.sleep(PLAYER_TIMEOUT + budget(0.1))
            after = states[ended:]
            sub.undeclare()
        finally:
            watcher.close()
        _, err = stop(proc)
    assert after, "no telemetry after the run"
    assert not any(s["failsafe"] for s in after), after[-1]
    assert after[-1]["active"] == [] and not after[-1]["player"]
    assert "surfacing (the player is lost)" not in err, err
    assert "left after its mission ended OK" in err, err
