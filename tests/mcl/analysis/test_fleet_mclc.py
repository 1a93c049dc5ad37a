"""``mclc FLEET.mcl`` prints the fleet's own properties after each vehicle's: a broken fleet
fails (exit 1) with both vehicles' lines in its counterexample; ``--method compositional``
says undecided where it cannot establish a property, and is refused for a single mission
(exit 2)."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from app.mclc import main
from tests.mcl.analysis.fleet_missions import UUV_NO_SURFACING, fleet_text, where
from tests.support import MISSIONS


def run(capsys: pytest.CaptureFixture[str], *argv: str) -> tuple[int, str, str]:
    status = main(list(argv))
    out, err = capsys.readouterr()
    return status, out, err


@pytest.mark.slow  # numpy and the explicit routes of three nets: about 1 s
def test_a_fleet_without_its_surfacing_fails_with_both_vehicles_lines(
        capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    text = fleet_text(uuv=UUV_NO_SURFACING)
    path = tmp_path / "mcm.mcl"
    path.write_text(text)
    status, out, _ = run(capsys, str(path))
    assert status == 1
    fleet_part = out[out.index("fleet mcm: the fleet's properties"):]
    assert "[FAIL] fleet-silence:" in fleet_part
    send = f"asv {where(text, 'Send(guide, release)').replace('mcm.mcl', str(path))}"
    fix = "Receive(guide, fix, timeout = 10 s)"
    timeout = f"uuv {where(text, fix).replace('mcm.mcl', str(path))} {fix}: timeout 10 s"
    run_lines = [line.split(". ", 1)[-1] for line in fleet_part.splitlines()]
    assert any(line.startswith(send) for line in run_lines)
    assert any(line.startswith(timeout) for line in run_lines)
    status, out, _ = run(capsys, str(path), "--method", "compositional", "--json")
    report = json.loads(out)
    # the vehicle's own behaviours-off-at-end fails (exit 1); the fleet's route alone cannot
    # establish the failure: undecided, never a verdict it did not establish
    assert status == 1 and report["fleet_properties"]["undecided"]
    props = {p["property"]: p for p in report["fleet_properties"]["properties"]}
    assert props["fleet-silence"]["status"] == "undecided"
    assert "uuv alone" in props["fleet-silence"]["message"]


def test_the_shipped_fleet_is_proved_and_compositional_is_for_fleets_only(
        capsys: pytest.CaptureFixture[str]) -> None:
    status, out, _ = run(capsys, str(MISSIONS / "fleet_relay.mcl"), "--json")
    report = json.loads(out)
    assert status == 0 and report["fleet_properties"]["verified"]
    assert report["fleet_properties"]["reachable_markings"] > 1000
    status, _, err = run(capsys, str(MISSIONS / "dam_inspection.mcl"), "--method",
                         "compositional")
    assert status == 2 and "--method compositional proves a fleet" in err
    assert "Traceback" not in err


@pytest.mark.slow  # three explicit routes: about 1 s
def test_ci_formats_report_the_fleets_own_properties(capsys: pytest.CaptureFixture[str],
                                                     tmp_path: Path) -> None:
    text = fleet_text(uuv=UUV_NO_SURFACING)
    path = tmp_path / "mcm.mcl"
    path.write_text(text)
    status, out, _ = run(capsys, str(path), "--format", "github")
    assert status == 1
    fleet_lines = [x for x in out.splitlines() if "title=mclc fleet-silence" in x]
    assert len(fleet_lines) == 1 and fleet_lines[0].startswith("::error file=")
    assert f"{path} fleet mcm: property-fails" in out
    status, out, _ = run(capsys, str(path), "--format", "junit")
    assert 'name="fleet-silence"' in out and f'classname="{path} fleet mcm"' in out
