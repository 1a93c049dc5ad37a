"""``mcl monitor --fleet-vehicle``'s view of a fleet (app/monitor_fleet.py), fed as Zenoh would
feed it: each vehicle's status and liveliness, the channels' messages."""

from __future__ import annotations

import json

from app.monitor import View
from app.monitor_fleet import FleetView, fleet_vehicles


def status(state: str, t: float = 10.0, mission: str = "m") -> bytes:
    return json.dumps({"v": 1, "run": "r", "mission": mission, "status": state, "t": t,
                       "done": 1, "total": 2}).encode()


def message(seq: int, name: str = "go", sender: str = "leader") -> bytes:
    return json.dumps({"v": 1, "channel": "orders", "message": name, "sender": sender,
                       "seq": seq, "sent": 1.5 * seq, "data": {}}).encode()


def fleet() -> tuple[FleetView, dict[str, View]]:
    views = {n: View(n, f"tcp/127.0.0.1:{7447 + i}")
             for i, n in enumerate(("leader", "follower"))}
    return FleetView(views), views


def test_it_ends_when_every_vehicle_ended_or_is_lost() -> None:
    view, each = fleet()
    assert view.ended() is None and view.vehicle_alive is None
    each["leader"].on_status(status("ok"))
    assert view.ended() is None  # the follower still runs
    each["follower"].on_alive("mcl/follower/alive/vehicle", True)
    each["follower"].on_status(status("running"))
    assert view.ended() is None
    each["follower"].on_status(status("ok", t=20.0))
    assert view.ended() == "ok"
    each["leader"].on_status(status("fail", t=30.0))
    assert view.ended() == "fail"


def test_a_lost_vehicle_ends_its_watch_as_a_failure() -> None:
    view, each = fleet()
    each["leader"].on_status(status("ok"))
    each["follower"].on_alive("mcl/follower/alive/vehicle", True)
    each["follower"].on_status(status("running"))
    each["follower"].on_alive("mcl/follower/alive/vehicle", False)
    assert view.ended() == "fail"
    assert "LOST" in view.line().splitlines()[1]


def test_each_message_is_counted_once_and_the_last_shown() -> None:
    view, each = fleet()
    for payload in (message(0), message(0), message(1, "done"), b"not json",
                    json.dumps({"v": 1}).encode()):
        view.on_channel("mcl/fleet/pair/channel/orders", payload)
    assert view.channel_lines() == ["channel orders: 2 sent, last done from leader at 1.5 s"]
    lines = view.line().splitlines()
    assert [line.split()[0] for line in lines] == ["leader", "follower", "channel"]
    assert view.changed.is_set()
    screen = view.screen(60)
    assert screen[-1].startswith("channel orders") and all(len(s) <= 60 for s in screen)


def test_its_option_is_name_equals_endpoint_once_each() -> None:
    assert fleet_vehicles(["a=tcp/127.0.0.1:1", "b=tcp/127.0.0.1:2"]) == {
        "a": "tcp/127.0.0.1:1", "b": "tcp/127.0.0.1:2"}
    for bad, said in [(["a"], "NAME=ENDPOINT"), (["a=tcp/x"], "has no port"),
                      (["a b=tcp/127.0.0.1:1"], "a vehicle's name"),
                      (["a=tcp/127.0.0.1:1", "a=tcp/127.0.0.1:2"], "given twice")]:
        problem = fleet_vehicles(bad)
        assert isinstance(problem, str) and said in problem and problem.startswith(
            "--fleet-vehicle "), problem
