"""missions/mcm.mcl on paper 003's simulated pair (mission/mcm_vehicles.py): proved, run to its
end in one process, surfacing when the guide goes silent, and drawn (docs/MCM.md)."""

from __future__ import annotations

import re
import subprocess
from pathlib import Path

import pytest

from mcl.analysis.fleet_verification import verify_fleet
from mcl.analysis.verification import verify_mission
from mcl.fleet import CompiledFleet, compile_fleet_file
from mission.fleet import FleetResult, run_fleet
from mission.mcm_vehicles import mcm_vehicles
from tests.support import BIN, MISSIONS, REPO
from vehicle.control.asv_stack import AsvStack
from vehicle.control.mcm_picture import top_view
from vehicle.control.uuv_stack import UuvStack

MCM = MISSIONS / "mcm.mcl"


def fleet() -> CompiledFleet:
    return compile_fleet_file(str(MCM), require_values=True)


def run(tmp_path: Path, seed: int, loss: float, faults: tuple[str, ...] = ()
        ) -> tuple[FleetResult, AsvStack, UuvStack]:
    vehicles = mcm_vehicles(seed, faults)
    result = run_fleet(fleet(), vehicles, loss=loss, seed=seed, log_dir=tmp_path / f"{seed}",
                       verify=False)
    asv, uuv = vehicles["asv"].modem, vehicles["uuv"].modem
    assert isinstance(asv, AsvStack) and isinstance(uuv, UuvStack)
    return result, asv, uuv


def raised(stack: AsvStack | UuvStack) -> list[str]:
    return [f"{b}.{e}" for _, b, e in stack.raised]


def test_each_vehicle_of_the_mission_is_proved() -> None:
    compiled = fleet()
    assert list(compiled.vehicles) == ["asv", "uuv"]
    assert compiled.channels["guide"].lossy
    for name, vehicle in compiled.vehicles.items():
        verdict = verify_mission(vehicle, "auto")
        assert verdict.ok, (name, [r.name for r in verdict.results if not r.holds])


@pytest.mark.slow
def test_the_fleet_is_proved_under_loss() -> None:
    verdict = verify_fleet(fleet())
    assert verdict.ok, [r.name for r in verdict.results if not r.holds]
    names = {r.name for r in verdict.results}
    assert {"fleet-no-deadlock", "fleet-silence", "fleet-nothing-on-at-end",
            "fleet-terminates"} <= names


def test_the_asv_guides_the_uuv_to_the_mine_and_it_lands(tmp_path: Path) -> None:
    result, asv, uuv = run(tmp_path, seed=1, loss=0.0)
    assert {n: r.status for n, r in result.runs.items()} == {"asv": "ok", "uuv": "ok"}
    assert raised(uuv)[-3:] == ["Home.over", "Land.landed", "Snapshot.taken"]
    assert "TrackUUV.landed" in raised(asv)  # the ASV ends on what its sonar sees
    s, (tx, ty, _) = uuv.world.uuv.state, uuv.world.scene.target
    assert uuv.world.uuv.on_bottom and ((s.x - tx) ** 2 + (s.y - ty) ** 2) ** 0.5 < 2.0
    channel = result.channels["guide"]
    assert channel["lost"] == 0 and channel["delivered"] >= 8
    figures = uuv.figures()  # what mcl run prints under the uuv, against ground truth
    assert figures["ended"] == "landed, the mine in the snapshot"
    errors = uuv.navigation_errors()
    assert len(errors) > 300 and max(errors) < 1.5  # from the first fix to the landing
    assert figures["navigator error"].startswith(
        f"{(sum(e * e for e in errors) / len(errors)) ** 0.5:.2f} m RMS")
    took = re.fullmatch(r"the UUV (\d+) times, clutter (\d+), the mine 0",
                        asv.figures()["sonar took for the UUV"])
    assert took is not None and int(took[2]) < 0.2 * int(took[1])  # clutter: now and then
    heard = {round(h.ping, 3) for _, h, _ in uuv.heard_fixes}  # the payload's 1 ms
    assert heard <= {round(f.ping, 3) for _, f in asv.sent_fixes}  # each heard was sent


@pytest.mark.slow
def test_when_the_guide_goes_silent_the_uuv_ascends(tmp_path: Path) -> None:
    # at a loss of 0.8 the release gets through, and the first fix, but the fixes then stop
    # for 10 s or more: the watchdog's Receive times out and the UUV ascends
    for seed in (3, 5):
        result, _, uuv = run(tmp_path, seed=seed, loss=0.8)
        assert uuv.world.released_at is not None and uuv.fixes >= 1
        assert raised(uuv)[-1] == "Ascend.surfaced"
        assert uuv.world.uuv.state.z < 0.3
        assert all(r.status == "ok" and not r.switched_off for r in result.runs.values())
        assert result.runs["asv"].time <= 360.0  # the ASV ends on its own timers


@pytest.mark.slow
@pytest.mark.parametrize("fault", ["clutter@0", "falsetarget@0", "current=0,0.2"])
def test_each_fault_ends_as_the_mission_provides(tmp_path: Path, fault: str) -> None:
    for seed in (1, 4):
        result, _, uuv = run(tmp_path / fault, seed=seed, loss=0.0, faults=(fault,))
        assert all(r.status == "ok" and not r.switched_off for r in result.runs.values())
        assert raised(uuv)[-1] in ("Snapshot.taken", "Snapshot.missed", "Ascend.surfaced")
        if raised(uuv)[-1] == "Snapshot.taken":  # landed only where the camera saw the mine
            s, (tx, ty, _) = uuv.world.uuv.state, uuv.world.scene.target
            assert ((s.x - tx) ** 2 + (s.y - ty) ** 2) ** 0.5 < 2.0


def test_the_top_view_shows_both_tracks_the_fixes_and_the_mine(tmp_path: Path) -> None:
    _, asv, uuv = run(tmp_path, seed=3, loss=0.3)
    svg = top_view(asv, uuv, "seed 3")
    heard = {round(f.ping, 3) for _, f, _ in uuv.heard_fixes}
    not_heard = sum(1 for _, f in asv.sent_fixes if round(f.ping, 3) not in heard)
    assert 0 < not_heard < len(asv.sent_fixes)
    assert svg.count('stroke="#d62728"') == not_heard  # a red ring per fix never heard
    assert svg.count("<polyline") == 3 and svg.count("<polygon") == 1
    assert f"not heard ({not_heard} of {len(asv.sent_fixes)})" in svg


def mcl(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run([str(BIN / "mcl"), *args], capture_output=True, text=True,
                          cwd=REPO, timeout=300)


@pytest.mark.slow
def test_a_bad_fault_is_one_line_and_exit_2() -> None:
    done = mcl("run", str(MCM), "--inject", "clutte@5")
    assert done.returncode == 2 and done.stdout == ""
    assert re.fullmatch(r"--inject clutte@5: error: expected clutter@SECONDS, "
                        r"falsetarget@SECONDS or current=VX,VY \(m/s\) \(did you mean "
                        r"clutter\?\) \(docs/MCM.md\)\n", done.stderr), done.stderr
    other = mcl("run", str(MISSIONS / "fleet_relay.mcl"), "--inject", "clutter@5")
    assert other.returncode == 2 and other.stderr.startswith("--inject: error: not for this")


@pytest.mark.slow
def test_mcl_run_runs_the_mission_to_its_end_with_a_fault(tmp_path: Path) -> None:
    done = mcl("run", str(MCM), "--inject", "current=0,0.2", "--log-dir", str(tmp_path))
    assert done.returncode == 0, done.stderr
    assert "uuv: mission go_to_mine ended OK" in done.stdout
    assert "Snapshot.taken" in done.stdout
    assert "    ended: landed, the mine in the snapshot\n" in done.stdout
    assert re.search(r"\n    navigator error: \d+\.\d\d m RMS, \d+\.\d\d m at most\n",
                     done.stdout)
    assert (tmp_path / "asv.jsonl").exists() and (tmp_path / "channels.jsonl").exists()
    replayed = mcl("replay", str(tmp_path), str(MCM))  # the fault is in the logs' headers
    assert replayed.returncode == 0 and "fleet mcm conforms" in replayed.stdout, replayed.stderr
