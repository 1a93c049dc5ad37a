"""A fleet paced at wall time (``run_fleet(speed=...)``, ``mcl run FLEET.mcl --realtime``):
the one clock keeps pace with the wall, and the run is the same run as unpaced, firing for
firing, since the turns go by mission time alone."""

from __future__ import annotations

import time

import pytest

from mcl.fleet import compile_fleet_file
from mission.fleet import run_fleet
from mission.simulated import simulated_vehicle
from tests.support import REPO

PAIR = REPO / "examples" / "fleet" / "pair.mcl"
SPEED = 200.0  # times wall time: the pair's minute of mission time in about 0.3 s


@pytest.mark.slow
def test_a_paced_fleet_keeps_pace_with_the_wall_and_runs_the_same() -> None:
    fleet = compile_fleet_file(str(PAIR), require_values=True)

    def once(speed: float | None) -> tuple[float, dict[str, tuple[str, int, float]]]:
        vehicles = {n: simulated_vehicle(seed=3 + i) for i, n in enumerate(fleet.vehicles)}
        t0 = time.monotonic()
        result = run_fleet(fleet, vehicles, loss=0.0, seed=3, verify=False, speed=speed)
        wall = time.monotonic() - t0
        return wall, {n: (r.status, r.firings, r.time) for n, r in result.runs.items()}

    _, fast = once(None)
    paced_wall, paced = once(SPEED)
    assert paced == fast
    mission_time = max(t for _, _, t in paced.values())
    assert mission_time > 10.0, "too short a run to tell pacing from none"
    assert paced_wall >= mission_time / SPEED * 0.95, (paced_wall, mission_time)
