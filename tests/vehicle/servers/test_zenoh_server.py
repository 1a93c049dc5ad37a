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
from vehicle.control.mcm_stack import mcm_world  # noqa: E402
from vehicle.control.uuv_stack import UuvStack  # noqa: E402
from vehicle.servers.zenoh_server import VehicleServer  # noqa: E402
from vehicle_adapters import zenoh_modem as modem  # noqa: E402
from vehicle_adapters.zenoh_link import ZenohVehicle  # noqa: E402


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


class RecordingUuv(UuvStack):
    """Paper 003's UUV, recording in what order its server applied the modem's messages
    and the actions."""

    def __init__(self) -> None:
        super().__init__(mcm_world(1), 1)
        self.applied: list[tuple[str, int]] = []

    def heard(self, channel: str, message: str, data: dict[str, Any], t: float) -> None:
        self.applied.append(("heard", int(data["i"])))
        super().heard(channel, message, data, t)

    def on_action(self, action: ActionMessage, now: float) -> None:
        self.applied.append(("action", action.seq))
        super().on_action(action, now)


def test_the_vehicle_hears_a_delivered_message_before_the_action_taken_on_it() -> None:
    """A player delivered a fix tells its vehicle's modem (so that the navigator fuses it), then
    acts on the fix: the vehicle must hear the fix before it applies that action, or the
    behaviour enabled reads an estimate without the fix (missions/mcm.mcl's FollowLine took the
    mine for where the UUV was, near at once, and the UUV ascended). Over a real loopback link,
    with the player's own adapter, back to back; an action sent before a message may still be
    applied after it (nothing on the vehicle waits for it)."""
    stack = RecordingUuv()
    vehicle = VehicleServer(free_endpoint(), "uuv", speed=1.0, player_timeout=30.0,
                            lease_ms=TOLERANT_LEASE_MS, stack=stack, safe="Ascend", dt=0.1)
    thread = threading.Thread(target=vehicle.run, daemon=True)
    thread.start()
    pairs = 100
    try:
        assert vehicle.ready.wait(budget(10)), "the vehicle server did not start"
        with ZenohVehicle(vehicle.endpoint, "uuv", connect_timeout=budget(10),
                          lease_ms=TOLERANT_LEASE_MS) as player:
            assert player.session is not None and not player.lost
            for i in range(pairs):
                assert modem.heard(player.session, "uuv", "guide", "fix", {"i": i}, 0.0,
                                   timeout=budget(2)), f"message {i} not acknowledged"
                kind = "enable" if i % 2 == 0 else "disable"
                player.send(ActionMessage(i + 1, 0.0, "m", f"FollowLine@{i}", kind,
                                          "KeepDepth", {}))
            wait_for(lambda: len(stack.applied) >= 2 * pairs, "every message applied")
    finally:
        vehicle.stop.set()
        thread.join(budget(10))
    assert sorted(stack.applied) == sorted(
        m for i in range(pairs) for m in (("heard", i), ("action", i + 1)))
    at = {m: n for n, m in enumerate(stack.applied)}
    overtaken = [i for i in range(pairs) if at[("action", i + 1)] < at[("heard", i)]]
    assert not overtaken, f"{len(overtaken)} of {pairs} actions applied before the message " \
                          f"they were taken on (the first after message {overtaken[0]})"


def test_a_vehicle_without_a_modem_does_not_answer_what_was_heard(
        server: VehicleServer) -> None:
    """The Ictineu has no modem: told of a message, it does not answer, and the player goes
    on (the query ends with no reply rather than waiting for one)."""
    assert not server.modem
    session = zenoh.open(zenoh_config(server.endpoint, "client", connect=True))
    try:
        assert modem.heard(session, server.name, "guide", "fix", {"i": 0}, 0.0,
                           timeout=budget(2)) is False
        assert modem.payload(session, server.name, "guide", "fix", 0.0,
                             timeout=budget(2)) == {}
    finally:
        session.close()
