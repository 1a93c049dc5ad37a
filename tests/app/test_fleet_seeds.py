"""Each vehicle's log header gives that vehicle's own seed (``seed``) beside the fleet's
(``fleet_seed``): vehicle ``i`` of the fleet's order runs on a simulated vehicle seeded
``N + i`` (mod 2**64), the vehicles of one simulated world (paper 003's pair) on ``N``; the
replay takes every seed ``--seed`` takes, up to 2**64 - 1."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest

from app import fleet_run, replay, run
from mcl.fleet import compile_fleet_file
from tests.support import MISSIONS

RELAY = MISSIONS / "fleet_relay.mcl"
MCM = MISSIONS / "mcm.mcl"
TOP = 2**64 - 1


def header(path: Path) -> dict[str, Any]:
    with path.open(encoding="ascii") as f:
        return dict(json.loads(f.readline()))


def test_vehicle_i_has_seed_n_plus_i_and_a_world_s_vehicles_the_fleet_s() -> None:
    relay = compile_fleet_file(str(RELAY), require_values=True)
    mcm = compile_fleet_file(str(MCM), require_values=True)
    assert fleet_run.seeds_for(relay, 5) == {"leader": 5, "follower": 6}
    assert fleet_run.seeds_for(relay, TOP) == {"leader": TOP, "follower": 0}
    assert fleet_run.seeds_for(mcm, 5) == {"asv": 5, "uuv": 5}


@pytest.mark.slow
@pytest.mark.parametrize("mission, seed, own", [
    (RELAY, 5, {"leader": 5, "follower": 6}),
    (MCM, TOP, {"asv": TOP, "uuv": TOP}),
])
def test_each_log_s_header_says_its_vehicle_s_seed_and_the_fleet_s_and_replays(
        tmp_path: Path, capsys: pytest.CaptureFixture[str], mission: Path, seed: int,
        own: dict[str, int]) -> None:
    code = run.main([str(mission), "--log-dir", str(tmp_path), "--seed", str(seed), "--quiet"])
    assert code == 0, capsys.readouterr().err
    for name, expected in own.items():
        said = header(tmp_path / f"{name}.jsonl")
        assert (said["seed"], said["fleet_seed"], said["as"]) == (expected, seed, name)
    assert header(tmp_path / "channels.jsonl")["seed"] == seed
    capsys.readouterr()
    assert replay.main([str(tmp_path), str(mission)]) == 0, capsys.readouterr()
