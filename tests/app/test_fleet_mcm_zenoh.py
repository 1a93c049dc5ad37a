"""Paper 003's mission over Zenoh in separate processes (docs/FLEET_ZENOH.md, docs/MCM.md):
``mcl vehicle --world mcm`` serves the ASV and the UUV of one simulated world, each on its own
loopback endpoint, and each vehicle's player (``mcl run missions/mcm.mcl --as NAME``) runs in
a process of its own; the fixes the ASV's sonar takes reach the UUV's navigator through the
modem over Zenoh. Every process is stopped (tests/support.started), every wait bounded."""

from __future__ import annotations

import json
import subprocess
import sys
import time
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import pytest

pytest.importorskip("zenoh")

from tests.app.test_fleet_zenoh import player as fleet_player  # noqa: E402
from tests.app.test_fleet_zenoh import players  # noqa: E402
from tests.support import REPO, budget, free_endpoint, started, subprocess_env  # noqa: E402

pytestmark = pytest.mark.slow  # three processes over Zenoh

MISSION = REPO / "missions" / "mcm.mcl"
SPEED = 20.0  # the world's clock: 20 x wall time (the mission takes about 60 s of it)
SEED = 3


@contextmanager
def world(asv: str, uuv: str, *extra: str) -> Iterator[subprocess.Popen[str]]:
    with started([sys.executable, "-m", "app.mcl", "vehicle", "--world", "mcm", "--zenoh",
                  f"{asv},{uuv}", "--speed", str(SPEED), "--seed", str(SEED), *extra]) as proc:
        yield proc


def secured(folder: Path) -> tuple[list[str], list[str]]:
    """The world's options and each player's with access control: one player user for both
    (docs/ZENOH_SECURITY.md), each vehicle's channels from the fleet."""
    (folder / "users.txt").write_text("player:pilot-secret\noperator:watch\n")
    (folder / "player.pw").write_text("pilot-secret\n")
    return (["--users", str(folder / "users.txt"), "--fleet", str(MISSION)],
            ["--user", "player", "--password-file", str(folder / "player.pw")])


def player(name: str, endpoint: str, logs: Path, *extra: str) -> subprocess.Popen[str]:
    """``mcl run missions/mcm.mcl --as NAME`` on the vehicle at ``endpoint``, quiet."""
    return fleet_player(MISSION, name, endpoint, logs, "--quiet", *extra)


def records(path: Path) -> list[dict[str, Any]]:
    return [json.loads(line) for line in path.read_text().splitlines()] if path.exists() else []


def actions(log: Path) -> list[str]:
    """The behaviours a run log's player enabled, in order."""
    return [r["behaviour"] for r in records(log)
            if r.get("kind") == "action" and r.get("action") == "enable"]


def stopped(proc: subprocess.Popen[str]) -> str:
    """What the world says when stopped (SIGTERM): each vehicle and its figures."""
    proc.terminate()
    out, _ = proc.communicate(timeout=budget(2))
    return out


def test_the_uuv_is_guided_to_the_mine_and_lands_and_both_logs_replay(tmp_path: Path) -> None:
    """Secured: each player may put only its actions, its channels and its modem's keys."""
    logs, asv, uuv = tmp_path / "run", free_endpoint(), free_endpoint()
    served, login = secured(tmp_path)
    with world(asv, uuv, *served) as vehicles:
        uuv_player = player("uuv", uuv, logs, "--fleet-vehicle", f"asv={asv}", *login)
        asv_player = player("asv", asv, logs, *login)
        with players(uuv_player, asv_player):
            _, err_u = uuv_player.communicate(timeout=budget(10))
            _, err_a = asv_player.communicate(timeout=budget(5))
        said = stopped(vehicles)
    assert (asv_player.returncode, uuv_player.returncode) == (0, 0), err_a + err_u
    assert actions(logs / "uuv.jsonl")[-3:] == ["Home", "Land", "Snapshot"], said
    assert "ended: landed, the mine in the snapshot" in said, said
    # the UUV's navigator fused the ASV's fixes: each a sonar detection the ASV's vehicle
    # put in the message (R, epsilon, its position and heading, the ping's time)
    heard = [line for line in said.splitlines() if "fixes heard:" in line]
    assert heard and not heard[0].strip().startswith("fixes heard: 0 "), said
    sent = [r for r in records(logs / "channels-asv.jsonl") if r["kind"] == "sent"]
    delivered = [r for r in records(logs / "channels-uuv.jsonl") if r["kind"] == "delivered"]
    assert [r["message"] for r in sent][:1] == ["release"] and len(delivered) >= 5
    replay = subprocess.run([sys.executable, "-m", "app.mcl", "replay", str(logs),
                             str(MISSION)], capture_output=True, text=True,
                            timeout=budget(3), cwd=REPO, env=subprocess_env(),
                            stdin=subprocess.DEVNULL)
    assert replay.returncode == 0 and "(run apart) conforms" in replay.stdout, replay.stderr


def test_with_the_asvs_player_killed_mid_guidance_the_uuv_ascends(tmp_path: Path) -> None:
    logs, asv, uuv = tmp_path / "run", free_endpoint(), free_endpoint()
    with world(asv, uuv) as vehicles:
        uuv_player = player("uuv", uuv, logs, "--fleet-vehicle", f"asv={asv}")
        asv_player = player("asv", asv, logs)
        with players(uuv_player, asv_player):
            deadline = time.monotonic() + budget(6)
            while "FollowLine" not in actions(logs / "uuv.jsonl"):  # guided on the fixes
                assert time.monotonic() < deadline and uuv_player.poll() is None, \
                    uuv_player.stderr.read() if uuv_player.stderr else ""
                time.sleep(0.02)
            asv_player.kill()  # SIGKILL: no more fixes, no goodbye
            _, err_u = uuv_player.communicate(timeout=budget(10))
        said = stopped(vehicles)
    assert uuv_player.returncode == 0, err_u
    fired = actions(logs / "uuv.jsonl")
    assert fired[-1] == "Ascend" and "Land" not in fired, fired
    ends = [r for r in records(logs / "uuv.jsonl") if r.get("kind") == "end"]
    assert ends and ends[-1]["status"] == "ok", ends
    assert "ended: ascended" in said, said


@pytest.mark.parametrize(("argv", "said"), [
    (["--zenoh", "tcp/127.0.0.1:9"], "--world mcm serves two vehicles"),
    (["--zenoh", "tcp/127.0.0.1:9,tcp/127.0.0.1"], "has no port"),
    (["--zenoh", "tcp/127.0.0.1:9,tcp/127.0.0.1:8", "--inject", "leak@5"],
     "expected clutter@SECONDS"),
    (["--zenoh", "tcp/127.0.0.1:9,tcp/127.0.0.1:8", "--name", "a,b", "--fleet",
      str(MISSION)], "fleet mcm has no vehicle 'a'"),
])
def test_a_bad_world_option_is_one_line_and_exit_2(argv: list[str], said: str) -> None:
    result = subprocess.run([sys.executable, "-m", "app.mcl", "vehicle", "--world", "mcm",
                             *argv], capture_output=True, text=True, timeout=budget(3),
                            cwd=REPO, env=subprocess_env(), stdin=subprocess.DEVNULL)
    assert result.returncode == 2 and "Traceback" not in result.stderr, result.stderr
    errors = [line for line in result.stderr.splitlines() if "error:" in line]
    assert len(errors) == 1 and said in errors[0], result.stderr
