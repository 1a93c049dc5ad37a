"""``mcl run MISSION.mcl --view HOST:PORT`` (app/view/run_view.py): mcl view's page served
by the run's own process, fed in process with the statuses the player would publish over
Zenoh, on any vehicle. End to end: a simulated run at wall-clock speed followed by a page open
in headless Chromium (through its DevTools protocol, so that the same page is read during the
run and after the server has stopped); runs on a MAVLink vehicle (``mcl vehicle --mavlink``,
a simulated ArduSub-class peer over UDP) and on a Zenoh vehicle (``mcl vehicle --zenoh``)
followed through ``data.json``; a signal; bad options, one line and exit 2 before the mission
starts."""

from __future__ import annotations

import base64
import json
import math
import re
import shutil
import signal
import socket
import subprocess
import time
import urllib.error
import urllib.request
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import pytest

from app.run import main as mcl_run
from app.view.live import LiveRun
from app.view.run_view import StatusTee
from mcl.api import compile_file
from mission import run_mission
from mission.vehicle import Vehicle
from tests.app.view.runs import DAM, LEAK
from tests.app.view.test_live import Feed, base
from tests.support import BIN, FAST_TASKS, REPO, budget, end, free_tcp_port, free_udp_port, \
    subprocess_env, write
from tests.websocket_client import WebSocket
from vehicle.scripted import ScriptedVehicle, load_script
from vehicle_adapters.inprocess import InProcess

GOTO_WAIT = "MISSION {\n    GoTo((-4.5, -2, 0.5, 0 deg));\n    Wait(4 s)\n}\n"  # 1.5 m, 4 s
CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser")
STATES = ("JSON.stringify(Object.fromEntries([...document.querySelectorAll("
          "'[data-block^=\"task@\"]')].map(e => [e.dataset.block, e.dataset.state])))")


# -- in process: the status dicts ---------------------------------------------------------------
def test_the_tee_feeds_the_page_and_the_vehicles_feed_the_same_statuses() -> None:
    feed = Feed()  # the leak run's statuses, as the Zenoh adapter would send them
    run_mission(compile_file(str(DAM), require_values=True),
                Vehicle(InProcess(ScriptedVehicle(load_script(str(LEAK)))), status=feed),
                verify=False)
    published = feed.published
    by_bytes, by_dict = LiveRun(base(), "auv", "ep"), LiveRun(base(), "sim", "here")
    feed = Feed()
    tee = StatusTee(by_dict, feed)
    assert tee.run == "run-1"  # the vehicle's feed names the run
    for payload in published:
        by_bytes.on_status(payload)
        tee.publish_status(json.loads(payload))
    assert feed.published == published  # the vehicle's observers get every status, as before
    assert by_dict.data()["changes"] == by_bytes.data()["changes"] != []
    assert by_dict.data()["timeline"] == by_bytes.data()["timeline"]
    assert by_dict.data()["end"] == {"t": 625.0, "status": "ok"}
    alone = StatusTee(LiveRun(base(), "sim", "here"), None)
    assert re.fullmatch(r"[0-9a-f]{32}", alone.run)  # a run of its own when nobody names it


# -- headless Chromium, through its DevTools protocol -------------------------------------------
class Browser:
    """Headless Chromium with one page, driven over its DevTools protocol (CDP)."""

    def __init__(self, tmp_path: Path) -> None:
        if CHROMIUM is None:
            pytest.skip("no Chromium on this machine (Debian: apt-get install chromium; "
                        ".ci/run does)")
        self.said = tmp_path / "chromium.err"
        with open(self.said, "wb") as err:
            self.proc = subprocess.Popen(
                [CHROMIUM, "--headless", "--no-sandbox", "--disable-gpu", "--disable-quic",
                 "--no-first-run", "--disable-background-networking",
                 "--disable-component-update", "--disable-sync", "--remote-debugging-port=0",
                 f"--user-data-dir={tmp_path / 'profile'}", "about:blank"],
                stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL, stderr=err)
        self.ws: WebSocket | None = None
        self.calls = 0
        try:
            deadline = time.monotonic() + budget(20)
            port = None
            while port is None and time.monotonic() < deadline:
                found = re.search(r"DevTools listening on ws://127\.0\.0\.1:(\d+)/",
                                  self.said.read_text(errors="replace"))
                port = int(found[1]) if found else None
                time.sleep(0.1)
            assert port is not None, self.said.read_text(errors="replace")[-2000:]
            with urllib.request.urlopen(f"http://127.0.0.1:{port}/json/list",
                                        timeout=budget(5)) as reply:
                page = next(p for p in json.load(reply) if p["type"] == "page")
            path = page["webSocketDebuggerUrl"].split(f":{port}", 1)[1]
            self.ws = WebSocket("127.0.0.1", port, "", timeout=budget(10), path=path)
        except BaseException:
            self.close()
            raise

    def call(self, method: str, **params: Any) -> dict[str, Any]:
        """A command's result (the events that come before it are passed over)."""
        assert self.ws is not None
        self.calls += 1
        self.ws.send_text(json.dumps({"id": self.calls, "method": method, "params": params}))
        while True:
            _, payload = self.ws.receive()
            message = json.loads(payload)
            if message.get("id") == self.calls:
                assert "error" not in message, message
                result: dict[str, Any] = message["result"]
                return result

    def evaluate(self, expression: str) -> Any:
        return self.call("Runtime.evaluate", expression=expression,
                         returnByValue=True)["result"].get("value")

    def until(self, expression: str, test: Any, within: float) -> Any:
        """The expression's value once ``test`` holds of it (fails after ``within`` s)."""
        deadline = time.monotonic() + within
        while True:
            value = self.evaluate(expression)
            if test(value) or time.monotonic() > deadline:
                return value
            time.sleep(0.2)

    def close(self) -> None:
        if self.ws is not None:
            self.ws.close()
        self.proc.kill()
        self.proc.wait(timeout=10)


@contextmanager
def run_with_view(tmp_path: Path, mission: Path, *args: str) -> Iterator[
        tuple[subprocess.Popen[bytes], str, Path]]:
    """``mcl run MISSION --view 127.0.0.1:PORT --quiet ARGS``, its output in a file; yields
    the process, the view's address and the output's file."""
    port = free_tcp_port()
    said = tmp_path / "run.out"
    with open(said, "wb") as out:
        proc = subprocess.Popen([str(BIN / "mcl"), "run", str(mission), "--quiet",
                                 "--view", f"127.0.0.1:{port}", "--log",
                                 str(tmp_path / "run.jsonl"), *args], cwd=REPO,
                                env=subprocess_env(), stdin=subprocess.DEVNULL, stdout=out,
                                stderr=subprocess.STDOUT)
    try:
        yield proc, f"http://127.0.0.1:{port}/", said
    finally:
        end(proc)  # type: ignore[arg-type]  # bytes or text: the same stop


def fetch(url: str) -> dict[str, Any] | None:
    """The page's data now; None once nothing serves there (a slow answer is asked again)."""
    for _ in range(5):
        try:
            with urllib.request.urlopen(url + "data.json", timeout=budget(2)) as reply:
                data: dict[str, Any] = json.load(reply)
                return data
        except (urllib.error.URLError, ConnectionError, TimeoutError) as exc:
            if not isinstance(getattr(exc, "reason", exc), TimeoutError):
                return None
    raise AssertionError(f"{url}data.json: no answer in 5 tries")


def states(data: dict[str, Any]) -> dict[str, str]:
    """Each block's state at the end of ``data``'s changes."""
    return {block: state for _, block, state in data["changes"]}


def until_running(proc: subprocess.Popen[bytes], url: str, said: Path,
                  within: float) -> dict[str, Any]:
    """The page's data once it shows a task call running."""
    deadline = time.monotonic() + within
    while time.monotonic() < deadline:
        assert proc.poll() is None, said.read_text(errors="replace")
        data = fetch(url)
        if data is not None and "running" in [s for b, s in states(data).items()
                                              if b.startswith("task@")]:
            return data
        time.sleep(0.1)
    raise AssertionError(f"no task ran within {within:g} s: {said.read_text()}")


def refused(url: str) -> bool:
    """Nothing listens at the view's address any more."""
    host, port = url.split("//")[1].rstrip("/").split(":")
    try:
        socket.create_connection((host, int(port)), timeout=1).close()
    except OSError:
        return True
    return False


@pytest.mark.slow
def test_a_simulated_run_followed_in_the_browser(tmp_path: Path) -> None:
    browser = Browser(tmp_path)  # started first: its start is not the mission's time
    try:
        mission = write(tmp_path, GOTO_WAIT, "goto_wait.mcl")
        with run_with_view(tmp_path, mission, "--realtime", "--no-images") as (proc, url, said):
            data = until_running(proc, url, said, budget(20))
            deadline = time.monotonic() + budget(5)
            while not data["track"] and time.monotonic() < deadline:  # a look every 0.2 s
                time.sleep(0.2)
                data = fetch(url) or data
            assert data["track"] and data["track_from"] == "the simulated vehicle's true pose"
            assert data["track"][-1][0] <= data["end"]["t"] + 1.0  # on mission time
            assert "vehicle sim @ mcl run's process: alive" in data["link"]
            browser.call("Page.navigate", url=url)
            shown = browser.until(STATES, lambda v: v and "running" in json.loads(v).values(),
                                  budget(10))
            during = json.loads(shown)
            assert "running" in during.values() and set(during) == {"task@2:5", "task@3:5"}
            assert during["task@3:5"] in ("waiting", "running"), during
            proc.wait(timeout=budget(60))
        assert proc.returncode == 0, said.read_text()
        assert f"mcl run: serving the view at {url}" in said.read_text()
        assert refused(url)  # the server stopped with the run
        # the page open during the run fetched the end before the server stopped
        assert json.loads(browser.evaluate(STATES)) == {"task@2:5": "ok", "task@3:5": "ok"}
        summary = browser.evaluate("document.body.innerText")
        assert "ended OK" in summary, summary
        live = browser.until("document.getElementById('live').textContent",
                             lambda v: "no answer" in v, budget(10))
        assert live == "live: no answer: the run ended OK and its server has stopped", live
        browser.call("Emulation.setDeviceMetricsOverride", width=1400, height=1000,
                     deviceScaleFactor=1, mobile=False)
        shot = tmp_path / "mcl-run-view.png"  # kept as the test's artefact
        shot.write_bytes(base64.b64decode(browser.call("Page.captureScreenshot")["data"]))
        assert shot.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and shot.stat().st_size > 20_000
        print(f"screenshot: {shot}")
    finally:
        browser.close()


@pytest.mark.slow
@pytest.mark.parametrize("kind", ["mavlink", "zenoh"])
def test_a_run_on_a_remote_vehicle_is_followed_with_its_track(tmp_path: Path,
                                                              kind: str) -> None:
    """A MAVLink vehicle's own position (LOCAL_POSITION_NED), a Zenoh vehicle's navigator
    telemetry: the track of the page served by ``mcl run``, whatever the vehicle."""
    if kind == "zenoh":
        pytest.importorskip("zenoh")
        where = f"tcp/127.0.0.1:{free_tcp_port()}"
        served, reached = ["--zenoh", where], f"zenoh:{where}"
    else:
        port = free_udp_port()
        served = ["--mavlink", f"udpout:127.0.0.1:{port}", "--gcs-timeout", "600",
                  "--pilot-timeout", "600"]
        reached = f"mavlink:udpin:127.0.0.1:{port}"
    vout = tmp_path / "vehicle.out"
    with open(vout, "wb") as out:
        vehicle = subprocess.Popen([str(BIN / "mcl"), "vehicle", *served, "--speed", "4"],
                                   cwd=REPO, env=subprocess_env(), stdin=subprocess.DEVNULL,
                                   stdout=out, stderr=subprocess.STDOUT)
    try:
        deadline = time.monotonic() + budget(20)
        while "ready" not in vout.read_text() and time.monotonic() < deadline:
            assert vehicle.poll() is None, vout.read_text()
            time.sleep(0.05)
        mission = write(tmp_path, "MISSION {\n    GoTo((-1.5, 0, 1, 0 deg))\n}\n", "goto.mcl")
        with run_with_view(tmp_path, mission, "--vehicle", reached) as (proc, url, said):
            seen = [until_running(proc, url, said, budget(30))]
            while (data := fetch(url)) is not None:  # a page open: it gets the end first
                seen.append(data)
                time.sleep(0.1)
            proc.wait(timeout=budget(30))
        assert proc.returncode == 0, said.read_text()
        link = f"vehicle {kind} @ {reached}: alive"
        assert any(d["link"] == link for d in seen), seen[0]["link"]
        last = seen[-1]
        assert last["end"]["status"] == "ok" and states(last)["task@2:5"] == "ok"
        tracked = [d for d in seen if d["track"]]
        assert tracked and tracked[-1]["track_from"] == "the vehicle's own position"
        track = tracked[-1]["track"]
        _, x, y, z = track[-1]  # where GoTo took it (its tolerance: 0.5 m)
        assert len(track) >= 5 and math.dist((x, y, z), (-1.5, 0.0, 1.0)) < 1.0, track
        ts = [p[0] for p in track]
        assert ts == sorted(ts) and ts[-1] > ts[0] >= 0.0  # on mission time, in order
        logged = [json.loads(x) for x in (tmp_path / "run.jsonl").read_text().splitlines()]
        assert ts[-1] <= logged[-1]["t"] + 1.0
    finally:
        end(vehicle)  # type: ignore[arg-type]


@pytest.mark.slow
@pytest.mark.parametrize("stop, status", [("signal", 128 + signal.SIGTERM),
                                          ("limit", 4)])
def test_a_stop_ends_the_run_and_its_view_with_the_runs_exit_status(
        tmp_path: Path, stop: str, status: int) -> None:
    mission = write(tmp_path, GOTO_WAIT, "goto_wait.mcl")
    limit = ["--max-time", "2"] if stop == "limit" else []
    with run_with_view(tmp_path, mission, "--realtime", "--no-images", *limit) as (
            proc, url, said):
        seen = [until_running(proc, url, said, budget(20))]
        if stop == "signal":
            proc.send_signal(signal.SIGTERM)
        while (data := fetch(url)) is not None:  # a page open: it gets the end first
            seen.append(data)
            time.sleep(0.1)
        proc.wait(timeout=budget(30))
    assert proc.returncode == status, said.read_text()
    assert refused(url)
    assert seen[-1]["end"]["status"] == "fail"  # the mission aborted through its net
    assert "aborted" in states(seen[-1]).values(), states(seen[-1])
    last = json.loads((tmp_path / "run.jsonl").read_text().splitlines()[-1])
    assert last["kind"] == "end" and last["exit"] == status


def test_a_mission_the_vehicle_cannot_run_ends_the_view_too(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    library = write(tmp_path, FAST_TASKS, "fast.tasks")
    mission = write(tmp_path, "MISSION {\n    Fast((0, 0, 1, 0 deg))\n}\n")
    port = free_tcp_port()
    code = mcl_run([str(mission), "--tasks", str(library), "--view", f"127.0.0.1:{port}",
                    "--log", str(tmp_path / "run.jsonl")])
    err = capsys.readouterr().err
    assert code == 2 and "does not take" in err, err  # refused by run_mission: an exception
    assert f"serving the view at http://127.0.0.1:{port}/" in err
    assert refused(f"http://127.0.0.1:{port}/")  # its server stopped all the same


# -- bad options: one line, exit 2, before the mission starts ----------------------------------
@pytest.mark.parametrize("where, said", [
    ("8080", "is not HOST:PORT"),
    ("127.0.0.1:http", "is not HOST:PORT"),
    ("192.0.2.1:0", "--view 192.0.2.1:0: cannot serve there"),  # not this machine's address
])
def test_a_bad_address_is_one_line_and_exit_2(tmp_path: Path, where: str, said: str,
                                              capsys: pytest.CaptureFixture[str]) -> None:
    mission = write(tmp_path, GOTO_WAIT, "goto_wait.mcl")
    log = tmp_path / "run.jsonl"
    try:
        code = mcl_run([str(mission), "--view", where, "--log", str(log)])
    except SystemExit as exc:  # argparse's refusal
        code = int(exc.code or 0)
    err = capsys.readouterr().err
    assert code == 2 and said in err and "Traceback" not in err, err
    assert len(err.strip().splitlines()) <= 2, err  # argparse adds its usage line
    assert not log.exists()  # the mission never started


def test_a_busy_port_is_refused_before_the_mission_starts(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    mission = write(tmp_path, GOTO_WAIT, "goto_wait.mcl")
    log = tmp_path / "run.jsonl"
    with socket.socket() as taken:
        taken.bind(("127.0.0.1", 0))
        taken.listen()
        port = taken.getsockname()[1]
        code = mcl_run([str(mission), "--view", f"127.0.0.1:{port}", "--log", str(log)])
    err = capsys.readouterr().err
    assert code == 2 and len(err.splitlines()) == 1, err
    assert err.startswith(f"error: --view 127.0.0.1:{port}: cannot serve there (") and \
        err.endswith("); choose another port, or port 0 for a free one\n"), err
    assert not log.exists()  # the mission never started


def test_a_fleet_is_refused(capsys: pytest.CaptureFixture[str]) -> None:
    code = mcl_run([str(REPO / "examples" / "fleet" / "pair.mcl"), "--view", "127.0.0.1:0"])
    err = capsys.readouterr().err
    assert code == 2 and "--view: not for a fleet" in err and "Traceback" not in err, err
