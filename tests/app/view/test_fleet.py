"""``mcl view RUNDIR FLEET.mcl`` (app/view/fleet.py, issue 25 deliverable 3: "a fleet"):
every vehicle's tree under the fleet's, each block's state that vehicle's run gave it, every
vehicle's timeline with the channels' messages; refusals are one line, exit 2; and in
headless Chromium, the page shows every task call of every vehicle with its state."""

from __future__ import annotations

import shutil
from pathlib import Path
from typing import Any

import pytest

from app import run
from app.view import command
from app.view.fleet import fleet_data, load_fleet
from app.view.server import ViewServer
from mission.blocks import BlockStates, block_id
from tests.app.view.test_browser import Blocks, chromium
from tests.support import MISSIONS

RELAY = MISSIONS / "fleet_relay.mcl"
CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser")


@pytest.fixture(scope="module")
def relay(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, dict[str, Any], Any]:
    folder = tmp_path_factory.mktemp("relay")
    assert run.main([str(RELAY), "--log-dir", str(folder), "--seed", "2", "--quiet"]) == 0
    fleet, logs, record = load_fleet(str(folder), str(RELAY))
    return folder, fleet_data(fleet, logs, record, folder), (fleet, logs)


def ids(node: dict[str, Any]) -> list[str]:
    return [node["id"], *(i for child in node["children"] for i in ids(child))]


def states_at(data: dict[str, Any], t: float) -> dict[str, str]:
    states: dict[str, str] = {}
    for when, block, state in data["changes"]:
        if when <= t:
            states[block] = state
    return states


@pytest.mark.slow
def test_every_vehicle_s_tree_is_under_the_fleet_with_its_own_run_s_states(
        relay: Any) -> None:
    _, data, (fleet, logs) = relay
    assert data["tree"]["title"] == "FLEET relay"
    assert [c["title"] for c in data["tree"]["children"]] == [
        "VEHICLE leader · MISSION lead", "VEHICLE follower · MISSION follow"]
    shown = ids(data["tree"])
    assert len(shown) == len(set(shown) - {""}) + shown.count("")  # no id shared
    assert {block for _, block, _ in data["changes"]} <= set(shown)
    end = states_at(data, data["end"]["t"])
    for name, compiled in fleet.vehicles.items():
        own = BlockStates(compiled.net).read(logs[name])  # the vehicle's run alone
        alone: dict[str, str] = {}
        for change in own.changes:
            alone[f"{name}/{block_id(change.block)}"] = change.state
        assert {k: v for k, v in end.items() if k.startswith(f"{name}/")} == alone
        for call in compiled.mission.calls():
            assert f"{name}/task@{call.span.line}:{call.span.col}" in shown
        assert end[f"{name}/MISSION"] == logs[name][-1]["status"]
    assert end["MISSION"] == "ok"


@pytest.mark.slow
def test_the_timeline_is_every_vehicle_s_and_the_channel_s_in_time(relay: Any) -> None:
    folder, data, (_, logs) = relay
    entries = data["timeline"]
    assert [e["t"] for e in entries] == sorted(e["t"] for e in entries)
    for name in logs:
        assert any(e["text"].startswith(f"{name}: ") for e in entries), name
    channel = [e["text"] for e in entries if e["kind"] == "channel"]
    record = (folder / "channels.jsonl").read_text("ascii").splitlines()
    assert len(channel) == len(record) - 2 > 0  # every line but the header and the end
    assert channel[0] == "channel orders: start sent"
    assert data["bounds"]["worst"] == max(data["bounds"]["blocks"][f"{n}/MISSION"][1]
                                          for n in logs)


@pytest.mark.slow
@pytest.mark.parametrize("damage, says", [
    ("missing", "no run log of vehicle follower"),
    ("other", "the log is not of vehicle follower"),
])
def test_a_bad_fleet_folder_is_one_line_and_exit_2(
        relay: Any, tmp_path: Path, capsys: pytest.CaptureFixture[str], damage: str,
        says: str) -> None:
    folder, _, _ = relay
    (tmp_path / "leader.jsonl").write_bytes((folder / "leader.jsonl").read_bytes())
    if damage == "other":  # the leader's log where the follower's should be
        (tmp_path / "follower.jsonl").write_bytes((folder / "leader.jsonl").read_bytes())
    assert command.main([str(tmp_path), str(RELAY)]) == 2
    err = capsys.readouterr().err
    assert says in err and "Traceback" not in err and len(err.strip().splitlines()) <= 2


@pytest.mark.slow
@pytest.mark.skipif(CHROMIUM is None, reason="no Chromium on this machine (Debian: apt-get "
                    "install chromium; .ci/run does)")
def test_the_browser_shows_every_vehicle_s_task_calls(relay: Any, tmp_path: Path) -> None:
    _, data, (fleet, _) = relay
    server = ViewServer(lambda: data, {})
    server.start()
    try:
        t = 8.0  # the leader goes to its mark; the follower waits for its start
        dom = Blocks()
        dom.feed(chromium(tmp_path, "--dump-dom", f"{server.url}?t={t:g}"))
    finally:
        server.shutdown()
        server.server_close()
    expected = states_at(data, t)
    for name, compiled in fleet.vehicles.items():
        for call in compiled.mission.calls():
            block = f"{name}/task@{call.span.line}:{call.span.col}"
            assert dom.states.get(block) == expected.get(block, "waiting"), block
    assert {s for b, s in dom.states.items() if "/task@" in b} >= {"running"}
