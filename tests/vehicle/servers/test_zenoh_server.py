"""The Zenoh vehicle server takes only the actions of the current player run (issue 22).

An action must name the run it belongs to: one with an empty run id was taken, whatever run
was current (or none), so a capture stripped of its run id, or an action anyone put without
one, moved the vehicle. Tested against a real server on a loopback endpoint, from a peer that
announces a run as a player does and then puts actions.
"""

from __future__ import annotations

import dataclasses
import json
import threading
import time
from collections.abc import Iterator
from typing import Any

import pytest

zenoh = pytest.importorskip("zenoh")

from aal.messages import ActionMessage  # noqa: E402
from aal.zenoh import keys, zenoh_config  # noqa: E402
from tests.support import TOLERANT_LEASE_MS, budget, free_endpoint  # noqa: E402
from vehicle.servers.zenoh_server import VehicleServer  # noqa: E402


def wait_for(predicate: Any, what: str, timeout: float = budget(6)) -> None:
    deadline = time.monotonic() + timeout
    while not predicate():
        if time.monotonic() > deadline:
            pytest.fail(f"{what}: not within {timeout:g} s")
        time.sleep(0.02)


@pytest.fixture()
def server() -> Iterator[VehicleServer]:
    """A vehicle server on a free loopback endpoint, running in a thread."""
    vehicle = VehicleServer(free_endpoint(), speed=10.0, player_timeout=30.0,
                            lease_ms=TOLERANT_LEASE_MS)
    thread = threading.Thread(target=vehicle.run, daemon=True)
    thread.start()
    assert vehicle.ready.wait(budget(10)), "the vehicle server did not start"
    try:
        yield vehicle
    finally:
        vehicle.stop.set()
        thread.join(budget(10))


def enable_camera(seq: int, run: str) -> ActionMessage:
    return ActionMessage(seq, 0.0, "m", "StartCamera@1:1", "enable", "StartCamera", {}, run=run)


def test_an_action_without_a_run_id_is_refused_before_and_during_a_run(
        server: VehicleServer) -> None:
    # without a current run: refused as naming no run, nothing queued
    assert "names no run" in str(server.take(enable_camera(0, "")))
    assert (server.dropped, server.stale) == (1, 0)
    session = zenoh.open(zenoh_config(server.endpoint, "client", connect=True))
    try:
        k = keys(server.name)
        token = session.liveliness().declare_token(f"{k['alive_player']}/run-1")
        wait_for(lambda: server.take(enable_camera(0, "run-1")) is None, "the run taken")
        wait_for(lambda: server.stack.behaviours["StartCamera"].active, "the camera on")
        # within the run, over the link: an action with an empty run id is dropped
        off = ActionMessage(1, 0.0, "m", "StopCamera@2:1", "disable", "StartCamera", {}, run="")
        session.put(k["action"], off.to_json())
        wait_for(lambda: server.dropped == 2, "the action without a run dropped")
        time.sleep(0.2)  # the loop applies what was queued at least every 10 ms
        assert server.stack.behaviours["StartCamera"].active
        assert server.actions == 1
        # so is one whose run field is there but empty
        raw = json.loads(off.to_json())
        assert "run" not in raw  # an empty run id is left out of the message
        session.put(k["action"], json.dumps({**raw, "seq": 2, "run": ""}))
        wait_for(lambda: server.dropped == 3, "the action with an empty run dropped")
        # the same action with the run's id is taken
        session.put(k["action"], dataclasses.replace(off, seq=3, run="run-1").to_json())
        wait_for(lambda: not server.stack.behaviours["StartCamera"].active, "the camera off")
        token.undeclare()
    finally:
        session.close()


def test_a_stale_action_still_says_why() -> None:
    vehicle = VehicleServer(free_endpoint())
    reason = vehicle.take(enable_camera(5, "another-run"))
    assert reason is not None and "stale" in reason and "another-run" in reason
    assert (vehicle.dropped, vehicle.stale) == (0, 1)
