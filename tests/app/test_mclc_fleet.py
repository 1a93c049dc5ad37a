"""``mclc FLEET.mcl``: each vehicle's mission verified with its receptions as environment
events, printed under the vehicle's name; JSON, SARIF, JUnit and GitHub reports keep working;
a fleet's static errors exit 2 with file:line:col."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from app.mclc import main
from tests.support import MISSIONS, cli, write

RELAY = MISSIONS / "fleet_relay.mcl"

PAIR = """\
FLEET pair {
    CHANNEL orders FROM leader TO follower ACOUSTIC DELAY 1 s .. 3 s LOSSY MESSAGES go;
    VEHICLE leader { MISSION lead { Wait(5 s); Send(orders, go) } }
    VEHICLE follower {
        PARAM wait = 2 min;
        MISSION follow { Receive(orders, go, timeout = wait) } ON STOP { Surface() }
    }
}
"""


def _run(capsys: pytest.CaptureFixture[str], *argv: str) -> tuple[int, str, str]:
    status = main(list(argv))
    out, err = capsys.readouterr()
    return status, out, err


@pytest.mark.slow  # the first explicit route of the session loads numpy (about 1 s)
def test_each_vehicle_is_verified_under_its_name(capsys: pytest.CaptureFixture[str],
                                                tmp_path: Path) -> None:
    path = write(tmp_path, PAIR, "pair.mcl")
    status, out, _ = _run(capsys, str(path))
    assert status == 0, out
    lines = out.splitlines()
    assert lines[0] == f"{path}: fleet pair: 2 vehicles, 1 channel"
    heads = [line for line in lines if line.startswith("vehicle ")]
    assert [h.split(":")[0] for h in heads] == ["vehicle leader", "vehicle follower"]
    follower = lines.index(heads[1])
    assert any("[ok  ] terminates" in line and "120 s" in line for line in lines[follower:])


def test_the_json_report_holds_the_channels_and_one_report_per_vehicle(
        capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    path = write(tmp_path, PAIR, "pair.mcl")
    status, out, _ = _run(capsys, str(path), "--json")
    report = json.loads(out)
    assert status == 0 and report["fleet"] == "pair" and report["status"] == "verified"
    assert report["channels"] == [{"channel": "orders", "from": "leader", "to": ["follower"],
                                   "link": "acoustic", "delay": [1.0, 3.0], "every": 0.0,
                                   "lossy": True, "messages": ["go"], "line": 2, "col": 5}]
    assert [v["vehicle"] for v in report["vehicles"]] == ["leader", "follower"]
    assert all(v["verification"]["properties"] for v in report["vehicles"])
    assert report["vehicles"][1]["duration"]["worst"] == 120.0


def test_a_vehicle_parameter_is_given_as_vehicle_dot_name(
        capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    path = write(tmp_path, PAIR, "pair.mcl")
    status, out, _ = _run(capsys, str(path), "--json", "--param", "follower.wait=30s")
    assert status == 0
    assert json.loads(out)["vehicles"][1]["duration"]["worst"] == 30.0
    status, _, err = _run(capsys, str(path), "--param", "wait=30s")
    assert status == 2 and "--param VEHICLE.NAME=VALUE" in err
    status, _, err = _run(capsys, str(path), "--param", "diver.wait=30s")
    assert status == 2 and "fleet-vehicle-unknown" not in err and "diver" in err


@pytest.mark.parametrize("option", [["--tasks", "x.tasks"], ["--dot", "out.dot"],
                                    ["--params", "p.txt"]])
def test_options_of_a_single_mission_are_refused_for_a_fleet(
        capsys: pytest.CaptureFixture[str], tmp_path: Path, option: list[str]) -> None:
    path = write(tmp_path, PAIR, "pair.mcl")
    status, _, err = _run(capsys, str(path), *option)
    assert status == 2
    assert err.startswith(f"{path}: error: {option[0]} takes a single mission")


def test_sarif_junit_and_github_name_each_vehicle(capsys: pytest.CaptureFixture[str],
                                                  tmp_path: Path) -> None:
    path = write(tmp_path, PAIR.replace("timeout = wait", "timeout = 0 s"), "pair.mcl")
    _, junit, _ = _run(capsys, str(path), "--format", "junit")
    assert f'<testsuite name="{path} leader"' in junit
    assert f'<testsuite name="{path} follower"' in junit
    _, sarif, _ = _run(capsys, str(path), "--format", "sarif")
    assert json.loads(sarif)["runs"][0]["tool"]["driver"]["name"] == "mclc"
    _, github, _ = _run(capsys, str(path), "--format", "github")
    assert f"{path} leader: verified" in github.splitlines()


def test_a_fleet_error_exits_2_at_file_line_col(capsys: pytest.CaptureFixture[str],
                                                tmp_path: Path) -> None:
    path = write(tmp_path, PAIR.replace("Receive(orders, go, timeout = wait)",
                                        "Receive(orders, go)"), "pair.mcl")
    status, out, err = _run(capsys, str(path), "--json")
    assert status == 2
    assert err.startswith(f"{path}:6:26: error: Receive(orders, go) may wait for ever")
    (diagnostic,) = json.loads(out)["diagnostics"]
    assert (diagnostic["code"], diagnostic["line"], diagnostic["col"]) == (
        "fleet-wait-unbounded", 6, 26)


@pytest.mark.slow
def test_the_shipped_relay_verifies_and_a_broken_copy_fails_from_the_command(
        tmp_path: Path) -> None:
    proc = cli("mclc", str(RELAY))
    assert proc.returncode == 0, proc.stdout + proc.stderr
    assert "fleet relay: 2 vehicles, 1 channel" in proc.stdout
    broken = write(tmp_path, RELAY.read_text().replace("timeout = 3 min", "within = 3 min"),
                   "relay.mcl")
    proc = cli("mclc", str(broken))
    assert proc.returncode == 2 and "Traceback" not in proc.stderr
    assert f"{broken}:" in proc.stderr and "fleet-bad-arguments" not in proc.stdout
