"""A fleet across processes over Zenoh (docs/FLEET_ZENOH.md): each vehicle's ``mcl vehicle``
and each vehicle's player (``mcl run FLEET.mcl --as NAME``) in a process of its own, on
loopback, on free ports; the same fleet's result as in one process for the same seed; one
vehicle killed mid-run, the other ending safely by its own timeout. Every process is stopped
(tests/support.started), every wait bounded."""

from __future__ import annotations

import json
import subprocess
import sys
import time
import threading
from collections.abc import Iterator
from contextlib import ExitStack, contextmanager
from pathlib import Path
from typing import Any

import pytest

pytest.importorskip("zenoh")

from mcl.fleet import compile_fleet_file  # noqa: E402
from mission.fleet import run_fleet  # noqa: E402
from mission.simulated import simulated_vehicle  # noqa: E402

from tests.support import REPO, budget, free_endpoint, started, subprocess_env  # noqa: E402

pytestmark = pytest.mark.slow  # four processes over Zenoh

SPEED = 20.0  # the vehicles' clocks: 20 x wall time
SEED = 3
# The leader tells the follower to go, then, 40 s later, that it is done; the follower goes
# only when it has heard both, and surfaces when either does not come in time: its safe end
# when the leader falls silent.
FLEET = """\
FLEET pair {
    CHANNEL orders FROM leader TO follower ACOUSTIC DELAY 1 s .. 3 s EVERY 2 s LOSSY
        MESSAGES go, done;

    VEHICLE leader {
        MISSION lead {
            Send(orders, go);
            Wait(40 s);
            Send(orders, done);
            GoTo((-3, 0, 1, 0 deg), timeout = 1 min)
        } ON STOP { Surface() }
    }
    VEHICLE follower {
        MISSION follow {
            IF { Receive(orders, go, timeout = 1 min) } THEN {
                IF { Receive(orders, done, timeout = 90 s) } THEN {
                    GoTo((-3, 2, 1, 0 deg), timeout = 1 min)
                } ELSE {
                    Surface()
                }
            } ELSE {
                Surface()
            }
        } ON STOP { Surface() }
    }
}
"""


@pytest.fixture
def fleet_file(tmp_path: Path) -> Path:
    path = tmp_path / "pair.mcl"
    path.write_text(FLEET, encoding="utf-8")
    return path


def vehicle(endpoint: str, name: str, *extra: str) -> Any:
    """Vehicle i of the fleet gets the seed SEED + i, as in one process (app/fleet_run.py)."""
    seed = SEED + ("leader", "follower").index(name)
    return started([sys.executable, "-m", "app.mcl", "vehicle", "--zenoh", endpoint, "--name",
                    name, "--speed", str(SPEED), "--seed", str(seed), *extra])


def secured(fleet: Path, name: str) -> tuple[list[str], list[str]]:
    """The options of vehicle ``name`` and of its player for a fleet with access control:
    each player its own user, a reader on the other vehicle (docs/ZENOH_SECURITY.md)."""
    users = fleet.parent / "users.txt"
    users.write_text("leader:lead-secret\nfollower:follow-secret\noperator:watch\n")
    (fleet.parent / f"{name}.pw").write_text(f"{name.replace('er', '')}-secret\n")
    return (["--users", str(users), "--player-user", name, "--fleet", str(fleet)],
            ["--user", name, "--password-file", str(fleet.parent / f"{name}.pw")])


def player(fleet: Path, name: str, endpoint: str, logs: Path, *extra: str
           ) -> subprocess.Popen[str]:
    env = {k: v for k, v in subprocess_env().items() if k != "MCL_ZENOH_PASSWORD"}
    return subprocess.Popen(
        [sys.executable, "-m", "app.mcl", "run", str(fleet), "--as", name, "--vehicle",
         f"zenoh:{endpoint}", "--seed", str(SEED), "--log-dir", str(logs), *extra],
        cwd=REPO, env=env, stdin=subprocess.DEVNULL, stdout=subprocess.PIPE,
        stderr=subprocess.PIPE, text=True)


@contextmanager
def players(*procs: subprocess.Popen[str]) -> Iterator[None]:
    try:
        yield
    finally:
        for proc in procs:
            if proc.poll() is None:
                proc.kill()
            proc.communicate(timeout=budget(1))


def listening(proc: subprocess.Popen[str], log: Path) -> None:
    """Wait until a receiver's player has begun its mission (its run log is written once its
    channels listen), as docs/FLEET_ZENOH.md asks of a receiver before its sender starts: a
    sender waits for a subscriber on its channels, and a monitor's or a view's is one too."""
    end = time.monotonic() + budget(10)
    while not log.exists() and proc.poll() is None and time.monotonic() < end:
        time.sleep(0.05)
    assert log.exists(), f"{log.stem}'s player never began its mission"


def finished(proc: subprocess.Popen[str], seconds: float) -> tuple[int, str, str]:
    out, err = proc.communicate(timeout=seconds)
    return proc.returncode, out, err


def events(log: Path) -> list[str]:
    """The events a run log's player fired transitions on, in order."""
    return [r["cause"] for r in map(json.loads, log.read_text().splitlines())
            if r.get("kind") == "fire" and r.get("cause") not in (None, "immediate")]


def record(path: Path) -> list[dict[str, Any]]:
    return [json.loads(line) for line in path.read_text().splitlines()]


def test_the_fleet_over_zenoh_ends_as_in_one_process(fleet_file: Path, tmp_path: Path) -> None:
    """Secured as in the field: each vehicle lets only its player put on its channels."""
    compiled = compile_fleet_file(str(fleet_file), require_values=True)
    alone = run_fleet(compiled, {n: simulated_vehicle(seed=SEED + i)
                                 for i, n in enumerate(compiled.vehicles)},
                      seed=SEED, log_dir=tmp_path / "alone")
    assert {n: r.status for n, r in alone.runs.items()} == {"leader": "ok", "follower": "ok"}
    logs, lead, follow = tmp_path / "zenoh", free_endpoint(), free_endpoint()
    (lead_vehicle, lead_player), (follow_vehicle, follow_player) = (
        secured(fleet_file, "leader"), secured(fleet_file, "follower"))
    operator = ["--user", "operator", "--password-file", str(tmp_path / "operator.pw")]
    (tmp_path / "operator.pw").write_text("watch\n")
    with (vehicle(lead, "leader", *lead_vehicle), vehicle(follow, "follower", *follow_vehicle),
          started([sys.executable, "-m", "app.mcl", "monitor", "--fleet-vehicle",
                   f"leader={lead}", "--fleet-vehicle", f"follower={follow}", "--until-end",
                   "--plain", "--timeout", str(budget(10)), *operator], ready="") as monitor):
        follower = player(fleet_file, "follower", follow, logs, "--fleet-vehicle",
                          f"leader={lead}", *follow_player)
        listening(follower, logs / "follower.jsonl")
        leader = player(fleet_file, "leader", lead, logs, *lead_player)
        with players(follower, leader):
            code_f, out_f, err_f = finished(follower, budget(10))
            code_l, out_l, err_l = finished(leader, budget(5))
        seen, _ = monitor.communicate(timeout=budget(2))  # --until-end: both ended
    assert (code_l, code_f, monitor.returncode) == (0, 0, 0), err_l + err_f + seen
    last = seen.splitlines()[-4:]  # every vehicle's line, the channel's, the verdict
    assert last[0].startswith("leader ") and " lead OK " in last[0], seen
    assert last[1].startswith("follower ") and " follow OK " in last[1], seen
    assert last[2].startswith("channel orders: 2 sent, last done from leader"), seen
    assert last[3] == "mission ended OK"
    for name in ("leader", "follower"):
        assert events(logs / f"{name}.jsonl") == events(tmp_path / "alone" / f"{name}.jsonl")
    assert "orders.go" in events(logs / "follower.jsonl")
    sent = [r for r in record(logs / "channels-leader.jsonl") if r["kind"] == "sent"]
    heard = [r for r in record(logs / "channels-follower.jsonl") if r["kind"] == "delivered"]
    assert [r["message"] for r in sent] == [r["message"] for r in heard] == ["go", "done"]
    assert all(1.0 <= r["delay"] <= 3.0 for r in heard)
    assert "channels: sent 2;" in out_l and "delivered 2," in out_f
    replay = subprocess.run([sys.executable, "-m", "app.mcl", "replay", str(logs),
                             str(fleet_file)], capture_output=True, text=True,
                            timeout=budget(3), cwd=REPO, env=subprocess_env(),
                            stdin=subprocess.DEVNULL)
    assert replay.returncode == 0 and "(run apart) conforms" in replay.stdout, replay.stderr


def test_a_vehicle_killed_mid_run_leaves_the_other_to_end_safely(fleet_file: Path,
                                                                 tmp_path: Path) -> None:
    logs, lead, follow = tmp_path / "zenoh", free_endpoint(), free_endpoint()
    with ExitStack() as stack:
        leader_vehicle = stack.enter_context(vehicle(lead, "leader"))
        stack.enter_context(vehicle(follow, "follower"))
        follower = player(fleet_file, "follower", follow, logs, "--fleet-vehicle",
                          f"leader={lead}")
        listening(follower, logs / "follower.jsonl")
        leader = player(fleet_file, "leader", lead, logs)
        stack.enter_context(players(follower, leader))
        heard = threading.Event()
        lines: list[str] = []

        def read() -> None:  # the follower's timeline, until it hears "go"
            assert follower.stdout is not None
            for line in follower.stdout:
                lines.append(line)
                if "orders.go" in line:
                    heard.set()
                    return

        threading.Thread(target=read, daemon=True).start()
        assert heard.wait(budget(3)), "".join(lines)
        leader_vehicle.kill()  # SIGKILL: no goodbye, 40 s before the leader says "done"
        code_f, out_f, err_f = finished(follower, budget(10))
        # the leader's player knows its vehicle is gone (it then runs its ON STOP for its
        # proved bound on a dead link: not waited for here)
        assert "Link.lost" in events(logs / "leader.jsonl")
    assert code_f == 0, err_f
    fired = events(logs / "follower.jsonl")
    assert fired[0] == "orders.go" and "orders.done" not in fired
    ends = [r for r in record(logs / "follower.jsonl") if r.get("kind") == "end"]
    assert ends and ends[-1]["status"] == "ok", ends
    assert "Surface" in "".join(lines) + out_f


@pytest.mark.parametrize("case", ["unknown vehicle", "not over zenoh", "no sender endpoint",
                                  "bad endpoint", "not in the fleet", "single mission",
                                  "fleet-vehicle without as"])
def test_a_bad_as_is_one_line_and_exit_2(case: str, fleet_file: Path) -> None:
    ep = "zenoh:tcp/127.0.0.1:9"
    args, said = {
        "unknown vehicle": (["--as", "ghost", "--vehicle", ep], "fleet pair has no vehicle"),
        "not over zenoh": (["--as", "leader"], "not on --vehicle sim"),
        "no sender endpoint": (["--as", "follower", "--vehicle", ep],
                               "--fleet-vehicle leader=ENDPOINT"),
        "bad endpoint": (["--as", "follower", "--vehicle", ep, "--fleet-vehicle",
                          "leader=tcp/127.0.0.1"], "has no port"),
        "not in the fleet": (["--as", "follower", "--vehicle", ep, "--fleet-vehicle",
                              "follower=tcp/127.0.0.1:9"], "not another vehicle"),
        "single mission": ([str(REPO / "missions" / "dam_inspection.mcl"), "--as", "leader"],
                           "--as: only for a fleet"),
        "fleet-vehicle without as": (["--fleet-vehicle", "leader=tcp/127.0.0.1:9"],
                                     "--fleet-vehicle: only with --as"),
    }[case]
    mission = [] if args[0].endswith(".mcl") else [str(fleet_file)]
    result = subprocess.run([sys.executable, "-m", "app.mcl", "run", *mission, *args],
                            capture_output=True, text=True, timeout=budget(3), cwd=REPO,
                            env=subprocess_env(), stdin=subprocess.DEVNULL)
    assert result.returncode == 2, result.stderr
    assert "Traceback" not in result.stderr
    errors = [line for line in result.stderr.splitlines() if "error:" in line]
    assert len(errors) == 1 and said in errors[0], result.stderr


def test_monitor_and_vehicle_refuse_a_bad_fleet_option(fleet_file: Path) -> None:
    for argv, said in [
        (["monitor", "--fleet-vehicle", "asv"], "write NAME=ENDPOINT"),
        (["monitor", "--fleet-vehicle", "a=tcp/127.0.0.1:9", "--fleet-vehicle",
          "a=tcp/127.0.0.1:8"], "given twice"),
        (["vehicle", "--zenoh", "tcp/127.0.0.1:9", "--name", "ghost", "--fleet",
          str(fleet_file)], "fleet pair has no vehicle 'ghost'"),
    ]:
        result = subprocess.run([sys.executable, "-m", "app.mcl", *argv], capture_output=True,
                                text=True, timeout=budget(3), cwd=REPO, env=subprocess_env(),
                                stdin=subprocess.DEVNULL)
        assert result.returncode == 2 and said in result.stderr, result.stderr
        assert "Traceback" not in result.stderr


def test_a_fleet_that_can_hang_is_refused_before_any_vehicle_is_reached(tmp_path: Path) -> None:
    """The fleet is proved as a whole, as in one process: here the follower waits for ever for
    a message the leader never sends (its own mission alone may hear it)."""
    hang = tmp_path / "hang.mcl"
    hang.write_text(FLEET.replace("Send(orders, go);", "").replace(
        "IF { Receive(orders, go, timeout = 1 min) }", "IF { Receive(orders, go) }")
        .replace("LOSSY", ""), encoding="utf-8")
    result = subprocess.run(
        [sys.executable, "-m", "app.mcl", "run", str(hang), "--as", "follower", "--vehicle",
         "zenoh:tcp/127.0.0.1:9", "--fleet-vehicle", "leader=tcp/127.0.0.1:9"],
        capture_output=True, text=True, timeout=budget(5), cwd=REPO, env=subprocess_env(),
        stdin=subprocess.DEVNULL)
    assert result.returncode == 1, result.stderr
    assert "fleet pair not verified (" in result.stderr and "refusing" in result.stderr
    assert "waiting for the vehicle" not in result.stderr  # refused before connecting
