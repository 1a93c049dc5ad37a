"""``mcl view FLEET.mcl --fleet-vehicle NAME=ENDPOINT ...`` (app/view/live_fleet.py, issue 25
deliverable 3: "from a live run (over Zenoh, any vehicle kind, a fleet)"). Unit: the two
vehicles' statuses of a real fleet run in, the page's data out, ending as the finished run's
view (app/view/fleet.py) of the same logs. End to end: the fleet over Zenoh (two vehicles, two
players), ``mcl view`` following it, and the page in headless Chromium."""

from __future__ import annotations

import dataclasses
import json
import re
import subprocess
import sys
import time
import urllib.request
from pathlib import Path
from typing import Any

import pytest

from app.view import command
from app.view.fleet import fleet_data, load_fleet
from app.view.live_fleet import LiveFleet
from mcl.fleet import CompiledFleet, compile_fleet_file
from mission.fleet import run_fleet
from mission.simulated import simulated_vehicle
from tests.app.test_fleet_zenoh import (FLEET, SEED, finished, listening, player, players,
                                        vehicle)
from tests.app.view.test_browser import Blocks, chromium
from tests.app.view.test_fleet import CHROMIUM, states_at
from tests.support import MISSIONS, REPO, budget, first_line, free_endpoint, stop, subprocess_env

CHANNEL = "mcl/fleet/pair/channel/orders"


class Feed:
    """A status feed: keeps what a player publishes, as the Zenoh adapter sends it."""

    run = "run-1"

    def __init__(self) -> None:
        self.published: list[bytes] = []

    def publish_status(self, status: dict[str, Any]) -> None:
        self.published.append(json.dumps(status).encode())


@pytest.fixture(scope="module")
def pair(tmp_path_factory: pytest.TempPathFactory
         ) -> tuple[CompiledFleet, dict[str, list[bytes]], dict[str, Any]]:
    """The fleet, each vehicle's statuses of its run in one process, and that run's finished
    view (from its logs)."""
    folder = tmp_path_factory.mktemp("pair")
    (folder / "pair.mcl").write_text(FLEET, encoding="utf-8")
    fleet = compile_fleet_file(str(folder / "pair.mcl"), require_values=True)
    feeds = {name: Feed() for name in fleet.vehicles}
    run_fleet(fleet, {name: dataclasses.replace(simulated_vehicle(seed=SEED + i),
                                                status=feeds[name])
                      for i, name in enumerate(fleet.vehicles)},
              seed=SEED, log_dir=folder / "logs")
    loaded, logs, record = load_fleet(str(folder / "logs"), str(folder / "pair.mcl"))
    return fleet, {n: f.published for n, f in feeds.items()}, fleet_data(
        loaded, logs, record, folder / "logs")


def message(name: str, seq: int, sent: float, sender: str = "leader") -> bytes:
    return json.dumps({"v": 1, "channel": "orders", "message": name, "sender": sender,
                       "seq": seq, "sent": sent, "data": {}}).encode()


@pytest.mark.slow  # the fleet's run in the fixture: 1 s
def test_both_vehicles_statuses_become_the_fleet_s_page(pair: Any) -> None:
    fleet, published, done = pair
    live = LiveFleet(fleet, {"leader": "tcp/127.0.0.1:1", "follower": "tcp/127.0.0.1:2"})
    data = live.data()
    assert data["live"] and data["end"]["status"] is None
    assert data["changes"] == [[0.0, "MISSION", "running"]]
    assert data["link"].count("no run of this mission yet") == 2
    assert [c["title"] for c in data["tree"]["children"]] == [
        c["title"] for c in done["tree"]["children"]]
    for payload in published["leader"]:  # the leader ends first: the fleet has not
        live.runs["leader"].on_status(payload)
    half = live.data()
    assert half["end"]["status"] is None and half["changes"][-1][1] != "MISSION"
    assert states_at(half, 1e9)["leader/MISSION"] == "ok"
    assert "follower/MISSION" not in states_at(half, 1e9)
    for payload in published["follower"]:
        live.runs["follower"].on_status(payload)
        status = json.loads(payload)
        shown = states_at(live.data(), status["t"])
        assert {b: s for b, s in shown.items() if b.startswith("follower/")} == {
            f"follower/{b}": s for b, s in status["blocks"].items()}
    data = live.data()
    assert data["end"]["status"] == "ok" and data["changes"][-1][1:] == ["MISSION", "ok"]
    assert states_at(data, 1e9) == states_at(done, 1e9)  # as the finished run's view says
    events = [e for e in data["timeline"] if e["kind"] == "event"]
    assert {e["text"].split(":")[0] for e in events} == {"leader", "follower"}
    assert {"t": 52.9, "kind": "event", "text": "follower: GoTo.reached", "line": 17} in events
    assert all(e["line"] is not None for e in data["timeline"] if e["kind"] == "action")


@pytest.mark.slow  # the fleet's run in the fixture: 1 s
def test_the_channel_s_messages_a_lost_vehicle_and_bad_messages(pair: Any) -> None:
    fleet, published, _ = pair
    live = LiveFleet(fleet, {"leader": "a", "follower": "b"})
    live.runs["leader"].on_status(json.dumps(
        {**json.loads(published["leader"][0]), "clock": 1000.0, "t": 0.0}).encode())
    for key, payload in [(CHANNEL, message("go", 0, 1000.0)),
                         (CHANNEL, message("go", 0, 1000.0)),  # heard through two vehicles
                         (CHANNEL, message("done", 1, 1040.0, sender="follower")),
                         ("mcl/fleet/pair/channel/other", message("done", 2, 1040.0)),
                         (CHANNEL, b"{not json"), (CHANNEL, message("done", 3, 1040.0))]:
        live.on_channel(key, payload)
    channel = [e for e in live.data()["timeline"] if e["kind"] == "channel"]
    assert channel == [  # on the leader's mission time: its clock less its status's offset
        {"t": 0.0, "kind": "channel", "line": None, "text": "channel orders: go sent by leader"},
        {"t": 40.0, "kind": "channel", "line": None,
         "text": "channel orders: done sent by leader"}]
    live.runs["follower"].on_status(published["follower"][0])
    live.runs["follower"].on_alive("mcl/follower/alive/vehicle", False)
    live.runs["leader"].on_status(published["leader"][-1])
    data = live.data()
    assert data["end"]["status"] == "leader ok, follower lost"
    assert data["changes"][-1][1:] == ["MISSION", "fail"] and "LOST" in data["link"]


@pytest.mark.slow  # five processes over Zenoh and Chromium: 8 s
def test_a_fleet_over_zenoh_live_in_the_browser(tmp_path: Path) -> None:
    pytest.importorskip("zenoh")
    fleet_file = tmp_path / "pair.mcl"
    fleet_file.write_text(FLEET, encoding="utf-8")
    logs, lead, follow = tmp_path / "zenoh", free_endpoint(), free_endpoint()
    with vehicle(lead, "leader"), vehicle(follow, "follower"):
        view = subprocess.Popen([sys.executable, "-m", "app.mcl", "view", str(fleet_file),
                                 "--fleet-vehicle", f"leader={lead}", "--fleet-vehicle",
                                 f"follower={follow}"], cwd=REPO, env=subprocess_env(),
                                stdin=subprocess.DEVNULL, stdout=subprocess.PIPE,
                                stderr=subprocess.PIPE, text=True)
        try:
            line = first_line(view, budget(10))
            assert line and "fleet pair, live from 2 vehicles" in line, line
            url = re.search(r"http://\S+/", line).group(0)  # type: ignore[union-attr]
            follower = player(fleet_file, "follower", follow, logs, "--fleet-vehicle",
                              f"leader={lead}")
            listening(follower, logs / "follower.jsonl")
            leader = player(fleet_file, "leader", lead, logs)
            with players(follower, leader):
                code_f, _, err_f = finished(follower, budget(10))
                code_l, _, err_l = finished(leader, budget(5))
            assert (code_l, code_f) == (0, 0), err_l + err_f
            data = until_ended(url)
            dom = Blocks()
            if CHROMIUM is not None:
                dom.feed(chromium(tmp_path, "--dump-dom", url))
        finally:
            stop(view)
    assert data["end"]["status"] == "ok", data["link"]
    assert states_at(data, 1e9)["follower/task@17:21"] == "ok"  # its GoTo, after "done"
    texts = [e["text"] for e in data["timeline"]]
    assert [t for t in texts if t.startswith("channel")] == [
        "channel orders: go sent by leader", "channel orders: done sent by leader"]
    assert "follower: orders.go" in texts and "leader: GoTo.reached" in texts
    if CHROMIUM is None:
        pytest.skip("no Chromium on this machine (Debian: apt-get install chromium)")
    calls = {b: s for b, s in dom.states.items() if "/task@" in b}
    expected = states_at(data, 1e9)
    assert calls and calls == {b: expected.get(b, "waiting") for b in calls}
    assert calls["follower/task@17:21"] == "ok" and calls["leader/task@7:13"] == "ok"


def until_ended(url: str) -> dict[str, Any]:
    """The page's data once the fleet has ended and both messages are on it (or the last
    seen after a bounded wait)."""
    deadline = time.monotonic() + budget(5)
    data: dict[str, Any] = {}
    while time.monotonic() < deadline:
        with urllib.request.urlopen(url + "data.json", timeout=budget(1)) as reply:
            data = json.load(reply)
        if data["end"]["status"] is not None and len(
                [e for e in data["timeline"] if e["kind"] == "channel"]) == 2:
            break
        time.sleep(0.2)
    return data


@pytest.mark.parametrize("case", ["unknown", "missing", "not name=endpoint", "single mission",
                                  "with --zenoh"])
def test_a_bad_fleet_vehicle_is_one_line_and_exit_2(
        case: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    fleet_file = tmp_path / "pair.mcl"
    fleet_file.write_text(FLEET, encoding="utf-8")
    ep = "tcp/127.0.0.1:9"
    mission, args, said = {
        "unknown": (fleet_file, [f"leader={ep}", f"ghost={ep}"], "pair.mcl:1:1: error: "
                    "--fleet-vehicle: fleet pair has no vehicle 'ghost'"),
        "missing": (fleet_file, [f"leader={ep}"], "say where vehicle follower is"),
        "not name=endpoint": (fleet_file, ["leader"], "write NAME=ENDPOINT"),
        "single mission": (MISSIONS / "dam_inspection.mcl", [f"leader={ep}"],
                           "dam_inspection.mcl:31:1: error: this file is a single mission"),
        "with --zenoh": (fleet_file, [f"leader={ep}", f"follower={ep}", "--zenoh"], "or "
                         "FLEET.mcl --fleet-vehicle NAME=ENDPOINT"),
    }[case]
    argv = [str(mission)]
    for a in args:
        argv += ["--fleet-vehicle", a] if a != "--zenoh" else ["--zenoh", ep]
    try:
        code = command.main(argv)
    except SystemExit as exc:  # argparse's own refusals
        code = int(exc.code or 0)
    err = capsys.readouterr().err
    assert code == 2 and "Traceback" not in err
    errors = [line for line in err.splitlines() if "error:" in line]
    assert len(errors) == 1 and said in errors[0], err
