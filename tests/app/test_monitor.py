"""``mcl monitor``'s view (app/monitor.py), fed a mission status as the player publishes it:
a lost vehicle's mission, every running task with its progress and time left, the
terminal's width."""

from __future__ import annotations

import io
import json
import os
import threading
from typing import Any

import pytest

from app import monitor
from app.monitor import View

SURVEY = {"task": "WallInspect@39:13", "since": 23.6, "bound": 3600.0, "left": 3359.9,
          "progress": {"waypoint": 18, "of": 82, "to_go": 121.3}}
TIMEOUT = {"task": "Timeout@24:41", "since": 200.0, "bound": 300.0, "left": 263.6}


def status(**changes: Any) -> bytes:
    st = {"v": 1, "mission": "dam_inspection", "run": "r1", "t": 263.6, "clock": 263.6,
          "status": "running", "running": [SURVEY, TIMEOUT], "done": 5, "total": 15,
          "behaviours": ["KeepHeadDist", "StartCamera", "WallInspection"], "fired": 80,
          "last_event": None, "last_action": None}
    return json.dumps({**st, **changes}).encode()


def view_of(payload: bytes, alive: bool | None = True) -> View:
    view = View("auv", "tcp/127.0.0.1:7447")
    view.on_status(payload)
    if alive is not None:
        view.on_alive("mcl/auv/alive/vehicle", alive)
    return view


def test_a_lost_vehicles_mission_shows_lost_not_running() -> None:
    view = view_of(status(), alive=False)
    assert "mission dam_inspection  LOST" in "\n".join(view.screen(200))
    assert " LOST " in view.line() and "RUNNING" not in view.line()
    alive = view_of(status(), alive=True)
    assert "RUNNING" in alive.line() and "LOST" not in alive.line()
    # a mission that ended before the vehicle was lost keeps its word
    assert "dam_inspection OK " in view_of(status(status="ok", running=[]), False).line()


def test_every_running_task_with_its_progress_and_time_left() -> None:
    screen = view_of(status()).screen(200)
    text = "\n".join(screen)
    assert ("    WallInspect@39:13 (waypoint 18/82, 121.3 m to go; 240 s, 3360 s left of "
            "3600 s)") in screen, text
    assert "    Timeout@24:41 (64 s, 236 s left of 300 s)" in screen, text
    line = view_of(status()).line()
    assert "waypoint 18/82" in line and "Timeout@24:41 (64 s, 236 s left of 300 s)" in line


def test_the_screen_takes_the_terminals_width(monkeypatch: pytest.MonkeyPatch) -> None:
    view = view_of(status())
    monkeypatch.setattr(monitor.shutil, "get_terminal_size",
                        lambda *_: os.terminal_size((120, 40)))
    out = io.StringIO()
    code = monitor.watch(view, False, 0.01, False, out, threading.Event())
    assert code == 4  # the timeout ran out
    lines = out.getvalue().replace("\x1b[H\x1b[J", "").splitlines()
    widest = max(len(line) for line in lines)
    assert 80 < widest <= 120, lines  # before: cut at 80 columns whatever the terminal
    assert any(line.endswith("3360 s left of 3600 s)") for line in lines), lines
    # a narrower terminal cuts there
    monkeypatch.setattr(monitor.shutil, "get_terminal_size",
                        lambda *_: os.terminal_size((60, 40)))
    out = io.StringIO()
    monitor.watch(view, False, 0.01, False, out, threading.Event())
    assert max(len(line) for line in out.getvalue().splitlines()) <= 60 + len("\x1b[H\x1b[J")
