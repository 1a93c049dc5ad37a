"""The Zenoh adapter with real processes on loopback.

The vehicle stack runs in a subprocess (``python -m vehicle_adapters.serve``) on a free port;
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
from collections.abc import Iterator
from contextlib import contextmanager
from typing import Any

import pytest

zenoh = pytest.importorskip("zenoh")

from mcl.api import compile_file  # noqa: E402
from petri.player import Player, Record  # noqa: E402
from petri.runner import run  # noqa: E402
from vehicle.stack import IctineuStack, StackConfig  # noqa: E402
from vehicle_adapters.aal import ActionMessage  # noqa: E402
from vehicle_adapters.inprocess import InProcess  # noqa: E402
from vehicle_adapters.zenoh_link import ZenohVehicle, keys, zenoh_config  # noqa: E402

from .support import MISSIONS, REPO  # noqa: E402

DAM = str(MISSIONS / "dam_inspection.mcl")
SPEED = 100.0  # the dam mission lasts ~1200 s of simulated time: ~12 s of wall time
SEED = 1
POLL = 0.5  # s of vehicle time: the runner's longest wait (5 ms of wall time at SPEED)


def free_endpoint() -> str:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return f"tcp/127.0.0.1:{s.getsockname()[1]}"


@contextmanager
def vehicle_process(endpoint: str, *extra: str, speed: float = SPEED
                    ) -> Iterator[subprocess.Popen[str]]:
    """The vehicle server as a real subprocess; yields once it says it is ready."""
    env = dict(os.environ, PYTHONDONTWRITEBYTECODE="1")
    proc = subprocess.Popen(
        [sys.executable, "-m", "vehicle_adapters.serve", "--zenoh", endpoint,
         "--speed", str(speed), "--seed", str(SEED), *extra],
        cwd=REPO, env=env, stdin=subprocess.DEVNULL, stdout=subprocess.PIPE,
        stderr=subprocess.PIPE, text=True)
    try:
        lines: queue.Queue[str] = queue.Queue()
        threading.Thread(target=lambda: lines.put(proc.stdout.readline()),  # type: ignore
                         daemon=True).start()
        try:
            line = lines.get(timeout=20)
        except queue.Empty:
            pytest.fail("the vehicle server did not become ready within 20 s")
        assert "ready" in line, f"vehicle server: {line!r} {proc.poll()}"
        yield proc
    finally:
        if proc.poll() is None:
            proc.terminate()
            try:
                proc.wait(timeout=5)
            except subprocess.TimeoutExpired:
                proc.kill()
                proc.wait(timeout=5)
        for stream in (proc.stdout, proc.stderr):
            if stream:
                stream.close()


def transitions(records: list[Record]) -> list[str]:
    """The event and timer transitions fired, in order (immediate ones left out)."""
    return [r.data["cause"] for r in records
            if r.kind == "fire" and r.data["cause"] != "immediate"]


@pytest.fixture(scope="module")
def compiled() -> Any:
    return compile_file(DAM, require_values=True)


@pytest.fixture(scope="module")
def in_process_transitions(compiled: Any) -> list[str]:
    player = Player(compiled.net)
    records: list[Record] = []
    player.observers.append(records.append)
    with InProcess(IctineuStack(StackConfig(seed=SEED))) as vehicle:
        outcome = run(player, vehicle, "dam_inspection")
    assert outcome.status == "ok"
    return transitions(records)


def run_over_zenoh(compiled: Any, endpoint: str, observer: Any = None, max_time: float = 3000,
                   **options: Any) -> tuple[Any, list[Record], ZenohVehicle]:
    player = Player(compiled.net)
    records: list[Record] = []
    player.observers.append(records.append)
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
    assert wall < 60


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
    assert vehicle.lost_at - killed["at"] < 1.0, "Link.lost came late"
    events = [r.data["event"] for r in records if r.kind == "event"]
    assert events[-1] == "Link.lost"
    assert outcome.status == "fail", outcome
    assert wall < 30


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
    config = zenoh_config(endpoint, connect=True)
    config.insert_json5("connect/endpoints", json.dumps([endpoint, rogue]))
    try:
        publisher = intruder.declare_publisher(keys("auv")["event"])
        with vehicle_process(endpoint):
            sent: list[bool] = []

            def inject(record: Record, vehicle: ZenohVehicle) -> None:
                if (record.kind == "event" and record.data["event"] == "GoTo.reached"
                        and not sent):
                    deadline = time.monotonic() + 5  # until the player's subscriber is seen
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
                deadline = time.monotonic() + 5
                while time.monotonic() < deadline:  # the action reached the stack
                    if "GoTo" in seen.get(timeout=max(0.01, deadline - time.monotonic()))[
                            "active"]:
                        break
                else:
                    pytest.fail("GoTo never became active")
            deadline = time.monotonic() + 5  # player gone: 0.3 s, then surface
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


def test_no_vehicle_gives_link_lost_without_hanging() -> None:
    endpoint = free_endpoint()  # nobody listens there
    start = time.monotonic()
    with ZenohVehicle(endpoint, "auv", connect_timeout=0.5) as vehicle:
        events = vehicle.receive(vehicle.now() + 1.0)
    assert time.monotonic() - start < 5
    assert [e.event for e in events] == ["Link.lost"]
    assert vehicle.lost
