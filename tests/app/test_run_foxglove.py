"""``mcl run --foxglove HOST:PORT``: a client speaking Foxglove's WebSocket protocol
(``foxglove.sdk.v1``) connects while a simulated run goes on in real time, and receives the
vehicle's pose and the mission's status as they change, up to the mission's end."""

from __future__ import annotations

import json
import struct
import subprocess
import time
from pathlib import Path
from typing import Any

import pytest

from tests.support import BIN, budget, free_tcp_port, subprocess_env, write
from tests.websocket_client import WebSocket, subscribe

pytest.importorskip("foxglove", reason="foxglove-sdk is an optional extra (mcl-auv[foxglove])")

GOTO = "MISSION {\n    GoTo((-1.5, 0, 1, 0 deg))\n}\n"  # 11.5 s of mission time
TOPICS = ("/mission/status", "/vehicle/pose/true")


def connect(port: int, proc: subprocess.Popen[str], within: float) -> WebSocket:
    deadline = time.monotonic() + within
    while True:
        try:
            return WebSocket("127.0.0.1", port, "foxglove.sdk.v1")
        except OSError:
            if proc.poll() is not None or time.monotonic() > deadline:
                raise
            time.sleep(0.1)


def test_a_client_follows_a_live_run(tmp_path: Path) -> None:
    mission = write(tmp_path, GOTO, "goto.mcl")
    port = free_tcp_port()
    proc = subprocess.Popen([str(BIN / "mcl"), "run", str(mission), "--realtime", "--quiet",
                             "--foxglove", f"127.0.0.1:{port}", "--log",
                             str(tmp_path / "goto.jsonl")], cwd=tmp_path, env=subprocess_env(),
                            stdin=subprocess.DEVNULL, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True)
    got: dict[str, list[dict[str, Any]]] = {topic: [] for topic in TOPICS}
    try:
        ws = connect(port, proc, budget(10))
        subscribe(ws, TOPICS)
        try:
            while True:  # until the run ends and its server closes
                opcode, payload = ws.receive()
                if opcode == 2 and payload[0] == 0x01:
                    sub = struct.unpack_from("<I", payload, 1)[0]
                    got[TOPICS[sub]].append(json.loads(payload[13:]))
        except (ConnectionError, OSError):
            pass
        out, err = proc.communicate(timeout=budget(30))
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.communicate()
    assert proc.returncode == 0, err
    assert f"serving Foxglove at ws://127.0.0.1:{port}" in err
    assert len(got["/vehicle/pose/true"]) >= 5  # 5 a second, from the connection on
    last = got["/mission/status"][-1]
    assert last["status"] == "ok" and last["tasks"] == [
        {"task": "GoTo@2:5", "line": 2, "state": "ok"}]


def test_a_bad_address_is_refused_with_exit_2(tmp_path: Path) -> None:
    mission = write(tmp_path, GOTO, "goto.mcl")
    result = subprocess.run([str(BIN / "mcl"), "run", str(mission), "--foxglove", "8765"],
                            capture_output=True, text=True, env=subprocess_env(),
                            timeout=budget(30))
    assert result.returncode == 2
    assert "HOST:PORT" in result.stderr and "Traceback" not in result.stderr
