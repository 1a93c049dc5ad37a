"""mcl/fleet.py: a fleet file compiles to one net per vehicle and the fleet's channels.

Send(CHANNEL, MESSAGE) is one immediate transition with a "send" action; Receive(CHANNEL,
MESSAGE[, timeout = D]) waits for the event CHANNEL.MESSAGE, fail on its timeout; each net is
named after its vehicle and its origins keep the fleet file's path and real line:col.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from diagnostics import MclError, Source
from mcl import parser
from mcl.api import compile_source
from mcl.fleet import Channel, CompiledFleet, compile_fleet_file, compile_fleet_source, is_fleet
from petri.execution.player import Order, Player

FLEET = """\
// a leader tells a follower to start
FLEET pair {
    CHANNEL orders FROM leader TO follower ACOUSTIC DELAY 1 s .. 3 s EVERY 2 s LOSSY
        MESSAGES go, abort;
    VEHICLE leader {
        MISSION lead { Wait(5 s); Send(orders, go) }
    }
    VEHICLE follower {
        MISSION follow {
            Receive(orders, go, timeout = 2 min)
        } ON STOP { Surface() }
    }
}
"""


def _fleet(text: str = FLEET, name: str = "pair.mcl") -> CompiledFleet:
    return compile_fleet_source(Source(name, text))


def test_a_fleet_compiles_to_one_net_per_vehicle_named_after_it() -> None:
    fleet = _fleet()
    assert fleet.name == "pair"
    assert list(fleet.vehicles) == ["leader", "follower"]
    assert [c.net.name for c in fleet.vehicles.values()] == ["leader", "follower"]
    assert fleet.vehicles["follower"].mission.name == "follow"


def test_channels_are_declared_in_seconds() -> None:
    channel = _fleet().channels["orders"]
    assert isinstance(channel, Channel)
    assert (channel.sender, channel.receivers, channel.link) == ("leader", ("follower",),
                                                                 "acoustic")
    assert (channel.delay_min, channel.delay_max, channel.interval) == (1.0, 3.0, 2.0)
    assert channel.lossy and channel.messages == ("go", "abort")
    assert channel.origin.where() == "pair.mcl:3:5"


def test_a_channel_without_every_or_lossy_has_no_interval_and_loses_nothing() -> None:
    text = FLEET.replace(" EVERY 2 s LOSSY", "")
    channel = _fleet(text).channels["orders"]
    assert channel.interval == 0.0 and not channel.lossy


def test_send_is_one_immediate_transition_with_a_send_action() -> None:
    net = _fleet().vehicles["leader"].net
    sends = [t for t in net.transitions if any(a.kind == "send" for a in t.actions)]
    assert len(sends) == 1
    (send,) = sends
    assert send.immediate
    assert [(a.kind, a.behaviour, a.params) for a in send.actions] == [
        ("send", "orders", (("message", "go"),))]
    assert send.origin is not None
    assert (send.origin.file, send.origin.line, send.origin.col) == ("pair.mcl", 6, 35)
    assert send.origin.text == "Send(orders, go)"


def test_receive_waits_for_the_message_and_fails_on_its_timeout() -> None:
    net = _fleet().vehicles["follower"].net
    waits = {t.name: t for t in net.transitions if t.name.startswith("Receive@")}
    ok = [t for t in waits.values() if t.event == "orders.go"]
    assert len(ok) == 1 and ok[0].origin is not None
    assert ok[0].origin.where() == "pair.mcl:10:13"
    timeouts = [t for t in waits.values() if t.timer is not None]
    assert [t.timer for t in timeouts] == [120.0]
    fail_places = {p for t in timeouts for p, _ in t.outputs}
    assert all(net.places[p].role == "fail" for p in fail_places)


def test_receptions_are_the_messages_of_the_channels_to_a_vehicle() -> None:
    fleet = _fleet()
    assert fleet.receptions("follower") == ["orders.go", "orders.abort"]
    assert fleet.receptions("leader") == []
    assert [c.name for c in fleet.sends("leader")] == ["orders"]


def test_uses_inside_a_vehicle_is_relative_to_the_fleet_file(tmp_path: Path) -> None:
    (tmp_path / "libs").mkdir()
    (tmp_path / "libs" / "sampler.tasks").write_text(
        "behaviour Sampler events done;\n"
        "task TakeSample() {\n  start: enable Sampler;\n  ok: Sampler.done;\n"
        "  timeout: 1 min -> fail;\n  stop: disable Sampler;\n}\n")
    text = FLEET.replace("MISSION lead {", 'USES "libs/sampler.tasks";\n        MISSION lead {'
                         ).replace("Wait(5 s)", "TakeSample()")
    path = tmp_path / "pair.mcl"
    path.write_text(text)
    fleet = compile_fleet_file(str(path))
    assert "Sampler" in fleet.vehicles["leader"].checked.library.behaviours
    assert "Sampler" not in fleet.vehicles["follower"].checked.library.behaviours
    assert is_fleet(str(path)) and is_fleet(Source("x", "/* c */ // d\n  FLEET f {}"))


def test_a_single_mission_is_no_fleet_and_keeps_send_unknown() -> None:
    source = Source("m.mcl", "MISSION { Send(orders, go) }")
    assert not is_fleet(source)
    with pytest.raises(MclError) as err:
        compile_fleet_source(source)
    assert err.value.diagnostics[0].code == "not-a-fleet"
    with pytest.raises(MclError) as err2:
        compile_source(source)
    assert err2.value.diagnostics[0].code == "unknown-task"


def test_a_fleet_file_is_refused_where_one_mission_is_expected() -> None:
    with pytest.raises(MclError) as err:
        parser.parse(Source("pair.mcl", FLEET))
    assert err.value.diagnostics[0].code == "fleet-file"
    assert str(err.value.diagnostics[0].span) == "pair.mcl:2:1"


def test_the_player_gives_a_send_to_its_sender_never_to_the_vehicle() -> None:
    net = _fleet().vehicles["leader"].net
    with pytest.raises(ValueError, match="orders"):
        Player(net).start(0.0)  # no channel to send on: refused before anything happens
    sent: list[Order] = []
    records: list[tuple[str, dict[str, object]]] = []
    player = Player(net, sender=sent.append,
                    observers=[lambda r: records.append((r.kind, r.data))])
    player.start(0.0)
    assert sent == [] and player.next_deadline() == 5.0
    player.settle(5.0)
    assert [(o.t, o.kind, o.behaviour, o.params) for o in sent] == [
        (5.0, "send", "orders", {"message": "go"})]
    assert list(player.outbox) == []  # the vehicle got nothing
    assert ("action", {"action": "send", "behaviour": "orders", "params": {"message": "go"},
                       "task": sent[0].task}) in records
    assert player.status == "ok"
