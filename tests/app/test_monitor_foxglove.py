"""``mcl monitor --foxglove HOST:PORT``: what the monitor hears over Zenoh (the player's
status, the navigator's telemetry) is served to a client speaking Foxglove's WebSocket
protocol (``foxglove.sdk.v1``), while a mission runs on a Zenoh vehicle."""

from __future__ import annotations

import json
import struct
import subprocess
import sys
import threading
import time
from pathlib import Path
from typing import Any

import pytest

from mission.foxglove_schemas import SCHEMAS
from tests.support import (REPO, budget, free_endpoint, free_tcp_port, started, stop,
                           subprocess_env, write)
from tests.websocket_client import WebSocket, subscribe

pytest.importorskip("foxglove", reason="foxglove-sdk is an optional extra (mcl-auv[foxglove])")
pytest.importorskip("zenoh")
jsonschema = pytest.importorskip("jsonschema")

GOTO = "MISSION {\n    GoTo((-1.5, 0, 1, 0 deg))\n}\n"
TOPICS = ("/mission/status", "/vehicle/pose/estimated")


def mcl(*args: str) -> list[str]:
    return [sys.executable, "-m", "app.mcl", *args]


def subscribed(port: int) -> WebSocket:
    deadline = time.monotonic() + budget(10)
    while True:
        try:
            ws = WebSocket("127.0.0.1", port, "foxglove.sdk.v1")
            break
        except OSError:
            if time.monotonic() > deadline:
                raise
            time.sleep(0.1)
    subscribe(ws, TOPICS)
    return ws


def test_the_monitor_serves_status_and_pose_to_foxglove(tmp_path: Path) -> None:
    endpoint, port = free_endpoint(), free_tcp_port()
    mission = write(tmp_path, GOTO, "goto.mcl")
    got: dict[str, list[dict[str, Any]]] = {topic: [] for topic in TOPICS}
    with started(mcl("vehicle", "--zenoh", endpoint, "--speed", "4"), env=subprocess_env()):
        with started(mcl("monitor", "--zenoh", endpoint, "--plain", "--until-end",
                         "--timeout", "60", "--foxglove", f"127.0.0.1:{port}"),
                     ready=None) as monitor:
            ws = subscribed(port)

            def read() -> None:
                try:
                    while True:
                        opcode, payload = ws.receive()
                        if opcode == 2 and payload[0] == 0x01:
                            sub = struct.unpack_from("<I", payload, 1)[0]
                            got[TOPICS[sub]].append(json.loads(payload[13:]))
                except (ConnectionError, OSError):
                    pass

            reader = threading.Thread(target=read, daemon=True)
            reader.start()
            run = subprocess.run(mcl("run", str(mission), "--vehicle", f"zenoh:{endpoint}",
                                     "--quiet", "--log", str(tmp_path / "goto.jsonl")),
                                 cwd=REPO, env=subprocess_env(), capture_output=True,
                                 text=True, timeout=budget(60))
            assert run.returncode == 0, run.stderr
            monitor.wait(timeout=budget(10))  # --until-end: the mission ended ok
            reader.join(budget(5))
            ws.close()
            err = monitor.stderr.read() if monitor.stderr else ""
            stop(monitor)
    assert monitor.returncode == 0, err
    assert f"serving Foxglove at ws://127.0.0.1:{port}" in err
    assert got["/vehicle/pose/estimated"], "no pose"
    for topic, messages in got.items():
        schema = SCHEMAS["foxglove.PoseInFrame" if "pose" in topic else "mcl.MissionStatus"]
        for message in messages:
            jsonschema.validate(message, schema)
    states = [s["tasks"] for s in got["/mission/status"]]
    assert [{"task": "GoTo@2:5", "line": 2, "state": "running"}] in states
    assert got["/mission/status"][-1]["status"] == "ok"


def test_a_bad_foxglove_address_is_one_line_and_exit_2() -> None:
    result = subprocess.run(mcl("monitor", "--zenoh", free_endpoint(), "--foxglove", "nope"),
                            cwd=REPO, env=subprocess_env(), capture_output=True, text=True,
                            timeout=budget(30))
    assert result.returncode == 2
    assert result.stderr.startswith("mcl monitor: --foxglove: ") and "HOST:PORT" in result.stderr
    assert "Traceback" not in result.stderr
