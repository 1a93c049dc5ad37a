"""The Zenoh adapter with real processes on loopback.

The vehicle stack runs in a subprocess (``python -m app.mcl vehicle``) on a free port;
the player runs here, through :class:`ZenohVehicle`. Every process is stopped in a ``finally``,
every wait is bounded, and the tests synchronise on events and liveliness, not on sleeps.
"""

from __future__ import annotations

import json
import os
import queue
import socket
import subprocess
import sys
import threading
import time
from contextlib import AbstractContextManager, ExitStack
from typing import Any

import pytest

zenoh = pytest.importorskip("zenoh")

from mcl.api import compile_file  # noqa: E402
from petri.execution.player import Player, Record  # noqa: E402
from petri.execution.runner import run  # noqa: E402
from petri.execution.status import task_calls  # noqa: E402
from aal.messages import ActionMessage  # noqa: E402
from aal.zenoh import LEASE_MS, keys, zenoh_config  # noqa: E402
from vehicle_adapters.zenoh_link import ZenohVehicle  # noqa: E402

from tests.dam_runs import DamRuns  # noqa: E402
from tests.support import (  # noqa: E402
    MISSIONS, REPO, TOLERANT_LEASE_MS, budget, free_endpoint, started)

pytestmark = pytest.mark.slow  # real vehicle processes over Zenoh: not in make test-quick

DAM = str(MISSIONS / "dam_inspection.mcl")
SPEED = 100.0  # the dam mission lasts ~1200 s of simulated time: ~12 s of wall time
SEED = 1
POLL = 0.5  # s of vehicle time: the runner's longest wait (5 ms of wall time at SPEED)


def vehicle_process(endpoint: str, *extra: str, speed: float = SPEED,
                    lease_ms: int = TOLERANT_LEASE_MS
                    ) -> AbstractContextManager[subprocess.Popen[str]]:
    """The vehicle server as a real subprocess; yields once it says it is ready."""
    env = dict(os.environ, PYTHONDONTWRITEBYTECODE="1", MCL_ZENOH_LEASE_MS=str(lease_ms))
    return started([sys.executable, "-m", "app.mcl", "vehicle", "--zenoh", endpoint,
                    "--speed", str(speed), "--seed", str(SEED), *extra], env=env)


def transitions(records: list[Record]) -> list[str]:
    """The event and timer transitions fired, in order (immediate ones left out)."""
    return [r.data["cause"] for r in records
            if r.kind == "fire" and r.data["cause"] != "immediate"]


@pytest.fixture(scope="module")
def compiled() -> Any:
    return compile_file(DAM, require_values=True)


@pytest.fixture(scope="module")
def in_process_transitions(dam_runs: DamRuns) -> list[str]:
    """The dam mission in process with the vehicle's seed (SEED): tests/dam_runs.py's run,
    made once per test run for this file, test_mavlink.py and the stack's tests."""
    assert SEED == 1  # the seed of dam_runs["dam"]
    dam = dam_runs["dam"]
    assert dam.outcome.status == "ok"
    return transitions(dam.records)


def run_over_zenoh(compiled: Any, endpoint: str, observer: Any = None, max_time: float = 3000,
                   **options: Any) -> tuple[Any, list[Record], ZenohVehicle]:
    player = Player(compiled.net)
    records: list[Record] = []
    player.observers.append(records.append)
    if "config" not in options:
        options.setdefault("lease_ms", TOLERANT_LEASE_MS)
    vehicle = ZenohVehicle(endpoint, "auv", **options)
    if observer is not None:
        player.observers.append(lambda r: observer(r, vehicle))
    with vehicle:
        outcome = run(player, vehicle, "dam_inspection", max_time=max_time, poll=POLL)
    return outcome, records, vehicle


def test_dam_mission_over_zenoh_matches_in_process(compiled: Any,
                                                   in_process_transitions: list[str]) -> None:
    endpoint = free_endpoint()
    with vehicle_process(endpoint) as proc:
        start = time.monotonic()
        outcome, records, vehicle = run_over_zenoh(compiled, endpoint)
        wall = time.monotonic() - start
        assert proc.poll() is None, "the vehicle server died"
    assert outcome.status == "ok", outcome
    assert transitions(records) == in_process_transitions == [
        "GoTo.reached", "AchieveHeadDist.achieved", "WallInspection.done", "GoTo.reached"]
    assert vehicle.dropped == 0 and not vehicle.lost
    assert 1000 < outcome.time < 1400  # simulated seconds, as in process (~1200 s)
    assert wall < budget(15)  # ~12 s idle: a hang, not slowness, fails this


def test_vehicle_killed_mid_mission_gives_link_lost_and_fail(compiled: Any) -> None:
    endpoint = free_endpoint()
    killed: dict[str, float] = {}
    with vehicle_process(endpoint) as proc:
        def kill_on_achieved(record: Record, vehicle: ZenohVehicle) -> None:
            if (record.kind == "event" and record.data["event"] == "AchieveHeadDist.achieved"
                    and not killed):
                proc.kill()  # SIGKILL: no goodbye from the vehicle
                killed["at"] = time.monotonic()

        start = time.monotonic()
        outcome, records, vehicle = run_over_zenoh(compiled, endpoint, kill_on_achieved)
        wall = time.monotonic() - start
    assert killed, "the mission never reached AchieveHeadDist.achieved"
    assert vehicle.lost and vehicle.lost_at is not None
    # at once on an idle machine (the connection closes); the 1 s lease bounds it otherwise
    assert vehicle.lost_at - killed["at"] < budget(1.0), "Link.lost came late"
    events = [r.data["event"] for r in records if r.kind == "event"]
    assert events[-1] == "Link.lost"
    assert outcome.status == "fail", outcome
    assert wall < budget(5)


def test_invalid_event_is_dropped_and_the_run_goes_on(compiled: Any,
                                                      in_process_transitions: list[str]
                                                      ) -> None:
    endpoint = free_endpoint()
    garbage = [b"not json", json.dumps({"v": 1, "seq": 10**6, "t": 1.0, "source": "GoTo",
                                        "name": "not a name", "data": {}}).encode(),
               json.dumps({"v": 99, "seq": 10**6, "t": 1.0, "source": "GoTo",
                           "name": "reached", "data": {}}).encode()]
    # a third participant publishes garbage on the event key; the player is connected to it
    # as well as to the vehicle (peers do not forward for one another)
    rogue = free_endpoint()
    intruder = zenoh.open(zenoh_config(rogue, listen=True))
    config = zenoh_config(endpoint, connect=True, lease_ms=TOLERANT_LEASE_MS)
    config.insert_json5("connect/endpoints", json.dumps([endpoint, rogue]))
    try:
        publisher = intruder.declare_publisher(keys("auv")["event"])
        with vehicle_process(endpoint):
            sent: list[bool] = []

            def inject(record: Record, vehicle: ZenohVehicle) -> None:
                if (record.kind == "event" and record.data["event"] == "GoTo.reached"
                        and not sent):
                    deadline = time.monotonic() + budget(1.5)  # the player's subscriber seen
                    while not publisher.matching_status and time.monotonic() < deadline:
                        time.sleep(0.001)
                    for g in garbage:
                        publisher.put(g)
                    sent.append(True)

            outcome, records, vehicle = run_over_zenoh(compiled, endpoint, inject,
                                                       config=config)
    finally:
        intruder.close()
    assert sent
    assert vehicle.dropped == len(garbage)
    assert outcome.status == "ok", outcome
    assert transitions(records) == in_process_transitions


def test_vehicle_surfaces_when_the_player_goes_away() -> None:
    endpoint = free_endpoint()
    k = keys("auv")
    with vehicle_process(endpoint, "--player-timeout", "0.3", speed=20):
        seen: queue.Queue[dict[str, Any]] = queue.Queue()
        watcher = zenoh.open(zenoh_config(endpoint, connect=True))
        try:
            sub = watcher.declare_subscriber(
                f"{k['telemetry']}/behaviours",
                lambda s: seen.put(json.loads(s.payload.to_bytes())))
            with ZenohVehicle(endpoint, "auv") as vehicle:
                assert not vehicle.lost
                vehicle.send(ActionMessage(0, vehicle.now(), "m", "GoTo@1:1", "enable", "GoTo",
                                           {"x": 0.0, "y": 0.0, "z": 2.0, "yaw": 0.0,
                                            "tolerance": 0.3}))
                deadline = time.monotonic() + budget(1.5)
                while time.monotonic() < deadline:  # the action reached the stack
                    if "GoTo" in seen.get(timeout=max(0.01, deadline - time.monotonic()))[
                            "active"]:
                        break
                else:
                    pytest.fail("GoTo never became active")
            deadline = time.monotonic() + budget(1.5)  # player gone: 0.3 s, then surface
            state: dict[str, Any] = {}
            while time.monotonic() < deadline and not state.get("failsafe"):
                try:
                    state = seen.get(timeout=max(0.01, deadline - time.monotonic()))
                except queue.Empty:
                    break
            assert state.get("failsafe"), state
            assert state["active"] == ["Surface"]
            sub.undeclare()
        finally:
            watcher.close()


def test_the_vehicle_tells_the_player_its_behaviours_progress() -> None:
    """Issue 25: the behaviours telemetry carries each active behaviour's progress, which the
    player's adapter gives the mission status (a GoTo's distance to its target)."""
    endpoint = free_endpoint()
    # at 20x: the telemetry (5 a second) tells the progress every 4 s of vehicle time, 2 m of
    # travel (at 100x, 10 m: the first told could already be under 15 m to go)
    with vehicle_process(endpoint, speed=20), ZenohVehicle(endpoint, "auv") as vehicle:
        assert vehicle.progress() == {}
        vehicle.send(ActionMessage(0, vehicle.now(), "m", "GoTo@1:1", "enable", "GoTo",
                                   {"x": -1.5, "y": 20.0, "z": 2.0, "yaw": 0.0,
                                    "tolerance": 0.3}))
        wait_for(lambda: "GoTo" in vehicle.progress(), "GoTo's progress", budget(3))
        first = vehicle.progress()["GoTo"]["to_go"]
        assert 15.0 < first < 25.0  # the vehicle starts near y = 0
        wait_for(lambda: vehicle.progress()["GoTo"]["to_go"] < first - 0.5,
                 "the distance to go shrinking", budget(6))


def test_no_vehicle_gives_link_lost_without_hanging() -> None:
    endpoint = free_endpoint()  # nobody listens there
    start = time.monotonic()
    with ZenohVehicle(endpoint, "auv", connect_timeout=0.5) as vehicle:
        events = vehicle.receive(vehicle.now() + 1.0)
    assert time.monotonic() - start < 0.5 + budget(1.0)  # the timeout, not a hang
    assert [e.event for e in events] == ["Link.lost"]
    assert vehicle.lost


# -- the operator's monitor and the mission status ------------------------------------------------

def mcl(*args: str) -> subprocess.Popen[str]:
    """A real ``mcl`` subprocess (stdout and stderr piped)."""
    return subprocess.Popen([sys.executable, "-m", "app.mcl", *args], cwd=REPO,
                            env=dict(os.environ, PYTHONDONTWRITEBYTECODE="1",
                                     MCL_ZENOH_LEASE_MS=str(TOLERANT_LEASE_MS)),
                            stdin=subprocess.DEVNULL, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True)


def stop(proc: subprocess.Popen[str]) -> tuple[str, str]:
    if proc.poll() is None:
        proc.terminate()
    try:
        return proc.communicate(timeout=10)
    except subprocess.TimeoutExpired:
        proc.kill()
        return proc.communicate(timeout=5)


def wait_for(predicate: Any, what: str, timeout: float = budget(6)) -> None:
    deadline = time.monotonic() + timeout
    while not predicate():
        if time.monotonic() > deadline:
            pytest.fail(f"{what}: not within {timeout:g} s")
        time.sleep(0.02)


class Telemetry:
    """The vehicle's behaviour telemetry (5 Hz), seen from a client session."""

    def __init__(self, endpoint: str):
        self.session = zenoh.open(zenoh_config(endpoint, "client", connect=True))
        self.states: list[dict[str, Any]] = []
        self.sub = self.session.declare_subscriber(
            f"{keys('auv')['telemetry']}/behaviours",
            lambda s: self.states.append(json.loads(s.payload.to_bytes())))

    def last(self) -> dict[str, Any]:
        return self.states[-1] if self.states else {}

    def close(self) -> None:
        self.sub.undeclare()
        self.session.close()


def test_monitor_follows_the_dam_mission_from_start_and_from_the_middle(tmp_path: Any) -> None:
    endpoint = free_endpoint()
    log = tmp_path / "run.jsonl"
    with vehicle_process(endpoint):
        early = mcl("monitor", "--zenoh", endpoint, "--until-end", "--plain", "--timeout", "120")
        late = None
        try:
            telemetry = Telemetry(endpoint)
            try:
                # the early monitor is connected once the vehicle counts two clients' ... we
                # cannot see that: wait for its line saying the vehicle is alive instead (on a
                # loaded machine a "vehicle not seen" line may come first; the monitor's own
                # --timeout bounds the wait)
                assert early.stdout is not None
                first = ""
                for _ in range(20):  # status lines until the vehicle is seen
                    line = early.stdout.readline()
                    first += line
                    if not line or "vehicle alive" in line:
                        break
                last = first.splitlines()[-1] if first else ""
                assert "vehicle alive" in last and "no mission yet" in last, first
                player = mcl("run", DAM, "--vehicle", f"zenoh:{endpoint}", "--quiet",
                             "--log", str(log))
                try:
                    wait_for(lambda: "WallInspection" in telemetry.last().get("active", []),
                             "WallInspection enabled")
                    late = mcl("monitor", "--zenoh", endpoint, "--until-end", "--plain",
                               "--timeout", "120")
                    out, err = player.communicate(timeout=budget(12))
                finally:
                    stop(player)
            finally:
                telemetry.close()
            assert player.returncode == 0, out + err
            early_out, _ = early.communicate(timeout=budget(3))
            late_out, late_err = late.communicate(timeout=budget(3))
        finally:
            stop(early)
            if late is not None:
                stop(late)
    assert early.returncode == 0 and late.returncode == 0, late_err
    lines = (first + early_out).splitlines()
    assert lines[-1] == "mission ended OK"
    # the count of tasks done, against the run log: task calls that fired, of all calls
    compiled = compile_file(DAM, require_values=True)
    calls = set(task_calls(Player(compiled.net)))
    fired = {json.loads(line)["transition"].split(".")[0]
             for line in log.read_text().splitlines() if '"kind":"fire"' in line.replace(" ", "")}
    assert 0 < len(fired & calls) < len(calls)  # the CATCH branches never ran
    assert (f"dam_inspection OK  {len(fired & calls)}/{len(calls)} tasks done  running: —"
            in lines[-2])
    running = " ".join(lines)
    for call in ("GoTo@34:9", "AchieveHeadDist@35:9", "WallInspect@39:13", "GoTo@47:9"):
        assert call in running, f"{call} never shown running"
    # the late monitor asked for the status: its first line already shows the running survey
    late_lines = late_out.splitlines()
    assert "RUNNING" in late_lines[0] and "WallInspect@39:13" in late_lines[0], late_lines[:3]
    assert late_lines[-1] == "mission ended OK"


def test_monitor_without_vehicle_gives_up_after_its_timeout() -> None:
    proc = mcl("monitor", "--zenoh", free_endpoint(), "--timeout", "1", "--plain")
    out, err = proc.communicate(timeout=budget(3))
    assert proc.returncode == 4, (out, err)  # no verdict (docs/EXIT.md; 3 is a bug)
    assert "waiting for the vehicle" in err and "Traceback" not in err


# -- restarts: no behaviour left enabled, no stale action replayed ----------------------------------

def test_player_restarted_leaves_nothing_enabled_and_its_actions_are_stale(tmp_path: Any
                                                                           ) -> None:
    endpoint = free_endpoint()
    short = tmp_path / "surface.mcl"
    short.write_text("MISSION surface { Surface() }\n", encoding="utf-8")
    with vehicle_process(endpoint, "--player-timeout", "30"):  # no failsafe in this test
        telemetry = Telemetry(endpoint)
        try:
            first = mcl("run", DAM, "--vehicle", f"zenoh:{endpoint}", "--quiet",
                        "--log", str(tmp_path / "a.jsonl"))
            try:
                wait_for(lambda: "WallInspection" in telemetry.last().get("active", []),
                         "the first player's survey")
                old_run = telemetry.last()["run"]
                first.kill()  # no goodbye: the vehicle keeps the survey going
            finally:
                stop(first)
            before = len(telemetry.states)
            second = mcl("run", str(short), "--vehicle", f"zenoh:{endpoint}", "--quiet",
                         "--log", str(tmp_path / "b.jsonl"))
            out, err = second.communicate(timeout=budget(6))
            assert second.returncode == 0, out + err
            wait_for(lambda: len(telemetry.states) > before + 2, "telemetry after the restart")
            after = telemetry.states[before:]
            assert all(old_run != s["run"] or "WallInspection" in s["active"] for s in after)
            new = [s for s in after if s["run"] != old_run]
            assert new, "the vehicle never saw the second player"
            assert all(set(s["active"]) <= {"Surface"} for s in new), new
            # the first run's action, replayed now, is refused as stale; counted from a state
            # in which the second player is gone and all its actions are applied
            wait_for(lambda: not telemetry.last()["player"], "the second player gone")
            settled = len(telemetry.states) + 1
            wait_for(lambda: len(telemetry.states) > settled, "telemetry after it")
            stale_before = telemetry.last()["stale"]
            actions_before = telemetry.last()["actions"]
            replay = ActionMessage(10**6, 0.0, "dam_inspection", "StartCamera@38:13",
                                   "enable", "StartCamera", {}, run=old_run)
            telemetry.session.put(keys("auv")["action"], replay.to_json())
            wait_for(lambda: telemetry.last()["stale"] > stale_before, "the stale count")
            assert telemetry.last()["actions"] == actions_before
            assert "StartCamera" not in telemetry.last()["active"]
        finally:
            telemetry.close()


def test_vehicle_restarted_mid_mission_gets_no_stale_action(compiled: Any) -> None:
    endpoint = free_endpoint()
    with ExitStack() as stack:
        first = stack.enter_context(vehicle_process(endpoint))
        restarted: dict[str, Any] = {}

        def restart_on_achieved(record: Record, vehicle: ZenohVehicle) -> None:
            if (record.kind == "event" and record.data["event"] == "AchieveHeadDist.achieved"
                    and not restarted):
                first.kill()  # and a new vehicle process at once, on the same endpoint
                first.wait(timeout=10)
                restarted["proc"] = stack.enter_context(vehicle_process(endpoint))
                restarted["telemetry"] = Telemetry(endpoint)
                stack.callback(restarted["telemetry"].close)

        outcome, records, vehicle = run_over_zenoh(compiled, endpoint, restart_on_achieved)
        assert restarted, "the mission never reached AchieveHeadDist.achieved"
        assert vehicle.lost and outcome.status == "fail", outcome
        events = [r.data["event"] for r in records if r.kind == "event"]
        assert events[-1] == "Link.lost"
        # the abort after Link.lost switched behaviours off in the player: those actions are
        # not sent to the vehicle that took the first one's place
        lost_at = next(r.t for r in records if r.kind == "event"
                       and r.data["event"] == "Link.lost")
        assert [r for r in records if r.kind == "action" and r.t >= lost_at]
        telemetry = restarted["telemetry"]
        wait_for(lambda: len(telemetry.states) >= 3, "the new vehicle's telemetry")
        state = telemetry.last()
        assert state["actions"] == 0 and state["active"] == [], state
        assert restarted["proc"].poll() is None


def test_monitor_on_a_terminal_redraws_one_screen() -> None:
    import pty

    endpoint = free_endpoint()
    with vehicle_process(endpoint):
        master, slave = pty.openpty()
        proc = subprocess.Popen([sys.executable, "-m", "app.mcl", "monitor", "--zenoh",
                                 endpoint, "--timeout", "1.5"], cwd=REPO, stdin=subprocess.DEVNULL,
                                stdout=slave, stderr=subprocess.PIPE)
        os.close(slave)
        chunks = []
        try:
            deadline = time.monotonic() + 30
            while time.monotonic() < deadline:
                try:
                    chunk = os.read(master, 65536)
                except OSError:  # the monitor closed the terminal
                    break
                if not chunk:
                    break
                chunks.append(chunk)
            proc.wait(timeout=budget(3))
        finally:
            if proc.poll() is None:
                proc.kill()
                proc.wait(timeout=5)
            os.close(master)
            if proc.stderr:
                proc.stderr.close()
    screen = b"".join(chunks).decode("utf-8", "replace")
    frames = screen.split("\x1b[H\x1b[J")
    assert len(frames) >= 3, screen  # redrawn in place, several times
    assert "vehicle alive" in frames[-1] and "none reported yet" in frames[-1], frames[-1]
    assert "navigator" in frames[-1]  # the vehicle's telemetry, before any mission
    assert proc.returncode == 4  # --timeout ran out: no verdict (docs/EXIT.md)


@pytest.mark.parametrize("kind", ["unix", "ipv6"])
def test_other_endpoints_unix_socket_and_ipv6_loopback(kind: str, tmp_path: Any) -> None:
    if kind == "unix":
        endpoint = f"unixsock-stream/{tmp_path / 'auv.sock'}"
    else:
        if not socket.has_ipv6:
            pytest.skip("no IPv6 on this machine")
        with socket.socket(socket.AF_INET6) as s:
            try:
                s.bind(("::1", 0))
            except OSError:
                pytest.skip("no IPv6 loopback (::1) on this machine")
            endpoint = f"tcp/[::1]:{s.getsockname()[1]}"
    mission = tmp_path / "surface.mcl"
    mission.write_text("MISSION surface { Surface() }\n", encoding="utf-8")
    with vehicle_process(endpoint):
        proc = mcl("run", str(mission), "--vehicle", f"zenoh:{endpoint}", "--quiet",
                   "--log", str(tmp_path / "run.jsonl"))
        try:
            out, err = proc.communicate(timeout=budget(6))
        finally:
            stop(proc)
    assert proc.returncode == 0, out + err
    assert "ended OK" in out


def test_vehicle_frozen_mid_mission_gives_link_lost_within_the_lease(compiled: Any) -> None:
    import signal as signals

    endpoint = free_endpoint()
    frozen: dict[str, float] = {}
    with vehicle_process(endpoint, lease_ms=LEASE_MS) as proc:
        def freeze_on_achieved(record: Record, vehicle: ZenohVehicle) -> None:
            if (record.kind == "event" and record.data["event"] == "AchieveHeadDist.achieved"
                    and not frozen):
                proc.send_signal(signals.SIGSTOP)  # alive but silent: a hung machine
                frozen["at"] = time.monotonic()

        try:
            outcome, records, vehicle = run_over_zenoh(compiled, endpoint, freeze_on_achieved,
                                                       lease_ms=LEASE_MS)
        finally:
            proc.send_signal(signals.SIGCONT)  # so that it can be terminated
    assert frozen, "the mission never reached AchieveHeadDist.achieved"
    assert vehicle.lost and vehicle.lost_at is not None
    delay = vehicle.lost_at - frozen["at"]
    # the transport lease is 1 s: the silence is noticed within it (plus scheduling slack,
    # which a loaded machine stretches)
    assert delay <= LEASE_MS / 1000 + budget(0.25), f"Link.lost {delay:.2f} s after the freeze"
    assert [r.data["event"] for r in records if r.kind == "event"][-1] == "Link.lost"
    assert outcome.status == "fail", outcome


def test_a_mission_that_catches_link_lost_reacts_as_written(tmp_path: Any) -> None:
    """TRY { GoTo } CATCH { LinkLost() } DO { Wait }: the vehicle killed mid-GoTo, the
    mission catches the loss and ends as its DO block does (ok), and the log says so."""
    endpoint = free_endpoint()
    mission = tmp_path / "watch.mcl"
    mission.write_text("PARAM far = (-20, 30, 5, 0 deg);\n"
                       "MISSION link_watch {\n"
                       "    TRY { GoTo(far) } CATCH { LinkLost() } DO { Wait(2 s) }\n"
                       "}\n", encoding="utf-8")
    log = tmp_path / "run.jsonl"
    with vehicle_process(endpoint) as vehicle:
        telemetry = Telemetry(endpoint)
        monitor = mcl("monitor", "--zenoh", endpoint, "--until-end", "--plain", "--timeout",
                      "60")
        try:
            player = mcl("run", str(mission), "--vehicle", f"zenoh:{endpoint}", "--quiet",
                         "--log", str(log))
            lines: list[str] = []  # the monitor's, as they come

            def read_monitor() -> None:
                for line in monitor.stdout or ():
                    lines.append(line)

            reader = threading.Thread(target=read_monitor, daemon=True)
            reader.start()
            try:
                wait_for(lambda: "GoTo" in telemetry.last().get("active", []), "GoTo enabled")
                # the monitor hears of the mission through the vehicle: before the kill (on a
                # loaded machine it may lag the telemetry)
                wait_for(lambda: any("GoTo@3:11" in line for line in lines),
                         "the monitor showing the GoTo", timeout=budget(3))
                vehicle.kill()
                out, err = player.communicate(timeout=budget(6))
                monitor.wait(timeout=budget(6))
                reader.join(budget(0.5))
                seen = "".join(lines)
            finally:
                stop(player)
        finally:
            stop(monitor)
            telemetry.close()
    # the monitor hears the player through the vehicle: it says so and ends, status 1
    assert monitor.returncode == 1, seen
    assert seen.splitlines()[-1] == "vehicle lost: the mission's end cannot be known from here"
    assert "GoTo@3:11" in seen
    assert player.returncode == 0, out + err
    assert "mission link_watch ended OK" in out
    records = [json.loads(line) for line in log.read_text().splitlines()]
    events = [r["event"] for r in records if r["kind"] == "event"]
    assert events == ["Link.lost"]
    causes = [r["cause"] for r in records if r["kind"] == "fire" and r["cause"] != "immediate"]
    assert causes[0] == "Link.lost" and causes[-1] == "timer"  # caught, then the DO's Wait
    assert not any("no block catches it" in r.get("note", "") for r in records)


def test_multicast_scouting_is_off_unless_asked_for() -> None:
    """Only the configuration is checked: multicast does not stay on loopback, and tests keep
    to loopback."""
    def multicast(config: Any) -> Any:
        return json.loads(config.get_json("scouting/multicast/enabled"))

    endpoint = free_endpoint()
    for options in ({"listen": True}, {"connect": True}, {"connect": True, "mode": "client"}):
        assert multicast(zenoh_config(endpoint, **options)) is False
        assert multicast(zenoh_config(endpoint, scouting=True, **options)) is True
        assert json.loads(zenoh_config(endpoint, **options).get_json(
            "scouting/gossip/enabled")) is False


def test_a_second_player_takes_the_vehicle_and_the_first_gets_link_lost() -> None:
    endpoint = free_endpoint()
    with vehicle_process(endpoint, "--no-wait"):
        with ZenohVehicle(endpoint, "auv") as first:
            assert not first.lost, first.lost_reason
            with ZenohVehicle(endpoint, "auv") as second:
                assert not second.lost, second.lost_reason
                events = []
                deadline = time.monotonic() + budget(1.0)
                while not first.lost and time.monotonic() < deadline:
                    events += first.receive(first.now() + 1.0)
                assert first.lost, "the first player never learnt it had lost the vehicle"
                events += first.receive(first.now())  # the Link.lost already in its inbox
                assert f"run {second.run}" in first.lost_reason
                assert [e.event for e in events][-1:] == ["Link.lost"]
                assert not second.lost
