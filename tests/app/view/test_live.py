"""``mcl view --zenoh`` (app/view/live.py): the page of a run as it happens, from the statuses
the player publishes. Unit: the statuses of a real run in, the page's data out. End to end:
a player's statuses published over Zenoh, ``mcl view --zenoh`` serving them, and the page in
headless Chromium changing colour as they come."""

from __future__ import annotations

import json
import re
import shutil
import subprocess
import time
import urllib.request
from pathlib import Path
from typing import Any

import pytest

from app.view.data import mission_data, timeline
from app.view.live import LiveRun
from mcl.api import compile_file
from mission import run_mission
from mission.blocks import BlockStates
from mission.vehicle import Vehicle
from tests.app.view.runs import DAM, LEAK
from tests.support import BIN, REPO, budget, first_line, free_endpoint, stop, subprocess_env
from vehicle.scripted import ScriptedVehicle, load_script
from vehicle_adapters.inprocess import InProcess


class Feed:
    """A status feed: keeps what the player publishes, as the Zenoh adapter sends it."""

    run = "run-1"

    def __init__(self) -> None:
        self.published: list[bytes] = []

    def publish_status(self, status: dict[str, Any]) -> None:
        self.published.append(json.dumps(status).encode())


@pytest.fixture(scope="module")
def statuses(tmp_path_factory: pytest.TempPathFactory) -> tuple[list[bytes], Path]:
    """The statuses of the leak run, and its log."""
    feed, log = Feed(), tmp_path_factory.mktemp("live") / "run.jsonl"
    run_mission(compile_file(str(DAM), require_values=True),
                Vehicle(InProcess(ScriptedVehicle(load_script(str(LEAK)))), status=feed),
                log=log, verify=False)
    return feed.published, log


def base() -> dict[str, Any]:
    return mission_data(compile_file(str(DAM), require_values=True))


def states_at(changes: list[list[Any]], t: float) -> dict[str, str]:
    out: dict[str, str] = {}
    for when, block, state in changes:
        if when <= t:
            out[block] = state
    return out


def test_statuses_become_the_pages_changes(statuses: tuple[list[bytes], Path]) -> None:
    published, log = statuses
    live = LiveRun(base(), "auv", "tcp/127.0.0.1:7447")
    assert live.data()["changes"] == [] and "no run of this mission yet" in live.data()["link"]
    for payload in published:  # after each status, the page shows its blocks' states
        live.on_status(payload)
        status = json.loads(payload)
        assert states_at(live.data()["changes"], status["t"]) == status["blocks"]
    data = live.data()
    assert data["live"] and data["end"] == {"t": 625.0, "status": "ok"}
    compiled = compile_file(str(DAM), require_values=True)
    records = [json.loads(line) for line in log.read_text().splitlines()]
    logged = BlockStates(compiled.net).read(records)
    assert states_at(data["changes"], 1e9) == logged.now()
    # each event carries the line of the firing it caused, as the log's own timeline says
    from_log = {(e["t"], e["text"]): e["line"] for e in timeline(records) if e["kind"] == "event"}
    leak = from_log[(600.0, "Alarms.leak")]
    assert leak is not None and "Alarms()" in compiled.source.text.splitlines()[leak - 1]
    assert {"t": 600.0, "kind": "event", "text": "Alarms.leak", "line": leak} in data["timeline"]
    events = [e for e in data["timeline"] if e["kind"] == "event"]
    assert events and all(e["line"] == from_log[(e["t"], e["text"])] for e in events)


def test_a_new_run_another_mission_old_news_and_a_lost_vehicle(
        statuses: tuple[list[bytes], Path]) -> None:
    published, _ = statuses
    live = LiveRun(base(), "auv", "ep")
    for payload in published[:6]:
        live.on_status(payload)
    before = live.data()
    live.on_status(published[2])  # older: set aside
    assert live.data() == before
    live.on_status(b"{not json")
    live.on_status(json.dumps({**json.loads(published[-1]), "mission": "other"}).encode())
    assert live.data() == before
    again = json.loads(published[1])
    live.on_status(json.dumps({**again, "run": "run-2"}).encode())  # a new run: afresh
    assert live.data()["changes"] == [[again["t"], b, s] for b, s in again["blocks"].items()]
    assert live.data()["track"] == []
    live.on_navigator(json.dumps({"t": again["clock"] + 2.0, "x": -1.5, "y": 0.25, "z": 1,
                                  "yaw": 0}).encode())
    live.on_navigator(b'{"t": 1, "x": "nan"}')
    assert live.data()["track"] == [[again["t"] + 2.0, -1.5, 0.25, 1.0]]
    assert again["status"] == "running" and live.data()["end"]["t"] == again["t"]
    live.on_clock(json.dumps({"t": again["clock"] + 7.5, "speed": 10}).encode())
    live.on_clock(b'{"t": "soon"}')
    assert live.data()["end"]["t"] == pytest.approx(again["t"] + 7.5)  # the clock moved on
    live.on_alive("mcl/auv/alive/vehicle", False)
    assert live.data()["end"]["status"] == "lost" and "LOST" in live.data()["link"]


def test_a_live_run_over_zenoh_in_the_browser(statuses: tuple[list[bytes], Path],
                                              tmp_path: Path) -> None:
    zenoh = pytest.importorskip("zenoh")
    from aal.zenoh import close_session, keys, zenoh_config

    published, _ = statuses
    endpoint = free_endpoint()
    player = zenoh.open(zenoh_config(endpoint, listen=True))  # the vehicle's side: a peer
    k = keys("auv")
    token = player.liveliness().declare_token(k["alive_vehicle"])
    proc = subprocess.Popen([str(BIN / "mcl"), "view", "--zenoh", endpoint, str(DAM)],
                            cwd=REPO, env=subprocess_env(), stdin=subprocess.DEVNULL,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        line = first_line(proc, budget(10))
        assert line and "live from" in line, line
        url = re.search(r"http://\S+/", line).group(0)  # type: ignore[union-attr]
        at_55 = [p for p in published if json.loads(p)["t"] == 55.0][-1]  # surveying
        deadline = time.monotonic() + budget(5)
        data: dict[str, Any] = {}
        while time.monotonic() < deadline:  # until the view's subscription is there
            player.put(k["status"], at_55)
            player.put(k["telemetry"] + "/navigator", json.dumps(
                {"t": json.loads(at_55)["clock"], "x": -1.5, "y": 0.0, "z": 1.0}))
            with urllib.request.urlopen(url + "data.json", timeout=budget(1)) as reply:
                data = json.load(reply)
            if data["changes"] and data["track"]:
                break
            time.sleep(0.2)
        assert states_at(data["changes"], 1e9) == json.loads(at_55)["blocks"]
        assert "vehicle auv @" in data["link"] and "alive" in data["link"]
        assert data["track"][-1] == [55.0, -1.5, 0.0, 1.0]
        browser = shutil.which("chromium")
        if browser is None:
            pytest.skip("no Chromium on this machine (Debian: apt-get install chromium)")
        dom = subprocess.run(
            [browser, "--headless", "--no-sandbox", "--disable-gpu", "--disable-quic",
             "--no-first-run", "--disable-background-networking", "--disable-component-update",
             "--disable-sync", f"--user-data-dir={tmp_path / 'profile'}", "--dump-dom", url],
            capture_output=True, text=True, timeout=budget(12)).stdout
        shown = dict(re.findall(r'data-block="(task@[\d:]+)"[^>]*data-state="(\w+)"', dom))
        assert shown["task@39:13"] == "running" and shown["task@34:9"] == "ok"
        assert shown["task@51:9"] == "waiting" and len(shown) == 15
    finally:
        stop(proc)
        token.undeclare()
        close_session(player)


def test_the_page_shows_the_running_tasks_progress() -> None:
    """Issue 25: the view shows how far along a long task is, as the status says it."""
    live = LiveRun(base(), "auv", "ep")
    status = {"v": 1, "mission": base()["mission"], "run": "r", "t": 266.7, "clock": 266.7,
              "status": "running", "blocks": {"MISSION": "running"},
              "running": [{"task": "WallInspect@39:13", "since": 23.6, "bound": 3600.0,
                           "left": 3356.9, "progress": {"waypoint": 18, "of": 82,
                                                        "to_go": 120.9}},
                          {"task": "Alarms@49:9", "since": 0.0}]}
    live.on_status(json.dumps(status).encode())
    assert live.data()["progress"] == {
        "WallInspect@39:13": "waypoint 18/82, 120.9 m to go; 243 s, 3357 s left of 3600 s"}
    live.on_clock(json.dumps({"t": 326.7}).encode())  # a minute on: the time left goes down
    assert live.data()["progress"]["WallInspect@39:13"].endswith("3297 s left of 3600 s")
    live.on_status(json.dumps({**status, "t": 1200.7, "status": "ok", "running": []}).encode())
    assert live.data()["progress"] == {}
