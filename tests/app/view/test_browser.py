"""``mcl view`` in a real browser: Debian's headless Chromium loads the page of a replayed
dam run (the leak: a CATCH handles it) at chosen instants (``?t=SECONDS``) and its DOM shows
every task call with the state the run gave it then; a screenshot is kept under the test's
tmp dir. Skips, saying why, only where no Chromium is installed (``.ci/run`` installs it)."""

from __future__ import annotations

import shutil
import subprocess
from collections.abc import Iterator
from html.parser import HTMLParser
from pathlib import Path
from typing import Any

import pytest

from app.view.command import load
from app.view.data import page_data, pictures
from app.view.server import ViewServer
from mcl.api import Compiled
from tests.app.view.runs import DAM, dam_log
from tests.support import budget

CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser")
pytestmark = pytest.mark.skipif(CHROMIUM is None, reason="no Chromium on this machine "
                                "(Debian: apt-get install chromium; .ci/run does)")
FLAGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
         "--disable-background-networking", "--disable-component-update", "--disable-sync",
         "--hide-scrollbars"]


class Blocks(HTMLParser):
    """The tree's blocks as the DOM holds them: data-block -> data-state; and the summary."""

    def __init__(self) -> None:
        super().__init__()
        self.states: dict[str, str] = {}
        self.future: list[bool] = []
        self.in_summary = False
        self.summary = ""

    def handle_starttag(self, tag: str, attrs: list[tuple[str, str | None]]) -> None:
        a = dict(attrs)
        classes = (a.get("class") or "").split()
        if tag == "li" and "block" in classes and a.get("data-block"):
            self.states[str(a["data-block"])] = str(a.get("data-state"))
        if tag == "li" and "entry" in classes:
            self.future.append("future" in classes)
        self.in_summary = a.get("id") == "summary"

    def handle_data(self, data: str) -> None:
        if self.in_summary:
            self.summary += data


def chromium(tmp_path: Path, *args: str) -> str:
    profile = tmp_path / "profile"
    shutil.rmtree(profile, ignore_errors=True)
    done = subprocess.run([str(CHROMIUM), *FLAGS, f"--user-data-dir={profile}", *args],
                          capture_output=True, text=True, timeout=budget(12),
                          stdin=subprocess.DEVNULL)
    assert done.returncode == 0, done.stderr[-2000:]
    return done.stdout


@pytest.fixture(scope="module")
def run(tmp_path_factory: pytest.TempPathFactory) -> Iterator[tuple[str, Compiled, dict[str, Any]]]:
    log = dam_log(tmp_path_factory.mktemp("leak"))
    compiled, records = load(str(log), str(DAM), [])
    data = page_data(compiled, records, log)
    server = ViewServer(lambda: data, pictures(log))
    server.start()
    try:
        yield server.url, compiled, data
    finally:
        server.shutdown()
        server.server_close()


# the leak run (missions/vehicles/dam_leak.toml), task call by line, as the page must show it:
#   t = 20:  StartLogs 32 ok; GoTo 34, Alarms 49 running; everything else waiting
#   t = 610: the leak (600) ended Alarms 49 fail, aborted the survey (39) and its CATCH (42);
#            the outer DO's Surface 51 runs; 44, 46, 47, 53 and ON STOP's 56 wait
#   t = 700: Surface 51 ok, StartLogs(disable) 53 ok, the mission OK
EXPECTED = {
    20.0: {32: "ok", 34: "running", 49: "running"},
    610.0: {32: "ok", 34: "ok", 35: "ok", 36: "ok", 38: "ok", 39: "aborted", 42: "aborted",
            49: "fail", 51: "running"},
    700.0: {32: "ok", 34: "ok", 35: "ok", 36: "ok", 38: "ok", 39: "aborted", 42: "aborted",
            49: "fail", 51: "ok", 53: "ok"},
}


@pytest.mark.parametrize("t", sorted(EXPECTED))
def test_every_task_call_shows_its_state(run: tuple[str, Compiled, dict[str, Any]], t: float,
                                         tmp_path: Path) -> None:
    url, compiled, data = run
    dom = Blocks()
    dom.feed(chromium(tmp_path, "--dump-dom", f"{url}?t={t:g}"))
    calls = compiled.mission.calls()
    shown = {c.span.line: dom.states.get(f"task@{c.span.line}:{c.span.col}") for c in calls}
    assert None not in shown.values(), shown  # every task call is on the page
    assert shown == {line: EXPECTED[t].get(line, "waiting") for line in shown}
    assert dom.states["MISSION"] == ("ok" if t >= data["end"]["t"] else "running")
    entries = data["timeline"]
    assert dom.future == [e["t"] > t for e in entries]
    assert f"t = {t:.1f} s" in dom.summary or "ended OK" in dom.summary, dom.summary


def test_a_screenshot_is_kept(run: tuple[str, Compiled, dict[str, Any]], tmp_path: Path) -> None:
    url, _, _ = run
    shot = tmp_path / "mcl-view.png"
    chromium(tmp_path, "--window-size=1400,1000", f"--screenshot={shot}", f"{url}?t=610")
    png = shot.read_bytes()
    assert png[:8] == b"\x89PNG\r\n\x1a\n" and len(png) > 20_000, len(png)
    print(f"screenshot: {shot}")
