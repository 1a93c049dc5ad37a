"""The Zenoh carrier of a fleet's channels, with real Zenoh sessions on loopback in this process:
a listening peer stands for the sender's vehicle, the sender's carrier connects to it as a peer,
the receiver's as a client (the routes of docs/FLEET_ZENOH.md)."""

from __future__ import annotations

import json
import math
import random
import time
from collections.abc import Iterator
from dataclasses import dataclass
from typing import Any

import pytest

zenoh = pytest.importorskip("zenoh")

from aal.zenoh import close_session, zenoh_config  # noqa: E402
from mission.channels import ChannelModel, Message  # noqa: E402
from vehicle_adapters.zenoh_channels import (  # noqa: E402
    ChannelUnreachable, Position, ZenohCarrier, channel_key, from_wire, position_in, to_wire)

from tests.support import budget, free_endpoint  # noqa: E402


@dataclass(frozen=True)
class Channel:
    name: str
    sender: str
    receivers: tuple[str, ...]
    messages: tuple[str, ...]


class Model:
    """Delay = distance / 1500 m/s when both positions are known, else 2 s; loses the seqs in
    ``lose``; remembers what it was asked."""

    def __init__(self, lose: tuple[int, ...] = ()) -> None:
        self.lose = lose
        self.asked: list[tuple[int, Position | None, Position | None]] = []

    def decide(self, msg: Message, sender_pos: Position | None,
               receiver_pos: Position | None) -> float | None:
        self.asked.append((msg.seq, sender_pos, receiver_pos))
        if msg.seq in self.lose:
            return None
        if sender_pos and receiver_pos:
            return msg.sent + math.dist(sender_pos, receiver_pos) / 1500
        return msg.sent + 2.0


GUIDE = Channel("guide", "asv", ("uuv",), ("release", "fix"))


@dataclass(frozen=True)
class LossyGuide:
    """The guide channel with what mission/channels.py's model reads too."""

    name: str = "guide"
    sender: str = "asv"
    receivers: tuple[str, ...] = ("uuv",)
    messages: tuple[str, ...] = ("release", "fix")
    delay_min: float = 1.0
    delay_max: float = 3.0
    interval: float = 2.0
    lossy: bool = True
CHANNELS = {"guide": GUIDE}


class Clock:
    def __init__(self) -> None:
        self.t = 100.0

    def __call__(self) -> float:
        return self.t


@pytest.fixture
def vehicle() -> Iterator[str]:
    """The sender's vehicle: a peer listening on a free endpoint."""
    endpoint = free_endpoint()
    session = zenoh.open(zenoh_config(endpoint, listen=True))
    try:
        yield endpoint
    finally:
        close_session(session)


def pair(endpoint: str, model: Model, clock: Clock, records: list[dict[str, Any]],
         where: Position | None = (0.0, 0.0, 0.0)
         ) -> tuple[ZenohCarrier[Message], ZenohCarrier[Message]]:
    sender: ZenohCarrier[Message] = ZenohCarrier(
        "mcm", "asv", CHANNELS, make=Message, models={}, clock=clock,
        publish=zenoh_config(endpoint, connect=True), record=records.append)
    receiver: ZenohCarrier[Message] = ZenohCarrier(
        "mcm", "uuv", CHANNELS, make=Message, models={"guide": model}, clock=clock,
        position=lambda: where, record=records.append,
        subscribe={"asv": zenoh_config(endpoint, "client", connect=True)})
    return sender, receiver


def wait_for(predicate: Any, seconds: float = budget(0.5)) -> None:
    end = time.monotonic() + seconds
    while not predicate():
        assert time.monotonic() < end, "not within the budget"
        time.sleep(0.01)


def test_the_wire_form_round_trips_and_refuses_what_is_not_a_message() -> None:
    msg = Message("guide", "fix", "asv", 3, 12.5, {"position": [1.0, 2.0, 0.0], "range": 40})
    assert Message(**from_wire(to_wire(msg))) == msg
    for bad, why in [(b"[]", "version"), (b'{"v": 2}', "version"),
                     (json.dumps({"v": 1, "channel": "g", "message": "m", "sender": "a",
                                  "seq": -1, "sent": 0, "data": {}}).encode(), "seq"),
                     (json.dumps({"v": 1, "channel": "g", "message": "m", "sender": "a",
                                  "seq": 1, "sent": 0, "data": []}).encode(), "data"),
                     (b" " * 5000, "longer")]:
        with pytest.raises(ValueError, match=why):
            from_wire(bad)
    with pytest.raises(ValueError, match="at most"):
        to_wire(Message("guide", "fix", "asv", 1, 0.0, {"blob": "x" * 5000}))


def test_the_senders_position_is_read_from_its_data() -> None:
    assert position_in({"position": [1, 2, 3]}) == (1.0, 2.0, 3.0)
    assert position_in({"x": 1, "y": 2, "z": -3}) == (1.0, 2.0, -3.0)
    assert position_in({}) is None
    assert position_in({"position": [1, "a", 3]}) is None
    assert position_in({"position": [1, float("nan"), 3]}) is None


def test_messages_cross_with_the_receivers_model_applied_on_its_own_clock(vehicle: str) -> None:
    model, clock = Model(lose=(2,)), Clock()
    records: list[dict[str, Any]] = []
    sender, receiver = pair(vehicle, model, clock, records, where=(3000.0, 0.0, 0.0))
    with receiver, sender:
        assert sender.wait_matched(budget(0.5)), "the receiver never subscribed"
        for seq in (1, 2, 3):
            sender.send(Message("guide", "fix", "asv", seq, 10.0 * seq,
                                {"position": [0.0, 0.0, 0.0]}))
        wait_for(lambda: receiver.summary()["received"] == 3)
        # 3000 m at 1500 m/s: due 2 s after arriving at t = 100 on the receiver's clock
        assert receiver.deliveries("uuv", 101.9) == []
        due = receiver.deliveries("uuv", 102.0)
        assert [(t, m.seq) for t, m in due] == [(102.0, 1), (102.0, 3)]
        assert receiver.deliveries("uuv", 1e9) == []  # each given once
    assert model.asked == [(s, (0.0, 0.0, 0.0), (3000.0, 0.0, 0.0)) for s in (1, 2, 3)]
    kinds = [(r["kind"], r["seq"]) for r in records]
    assert kinds.count(("sent", 2)) == 1 and ("lost", 2) in kinds
    assert [(r["t"], r["delay"]) for r in records if r["kind"] == "delivered"] == [(102.0, 2.0)] * 2
    assert receiver.summary() == {"fleet": "mcm", "vehicle": "uuv", "sent": 0, "received": 3,
                                  "delivered": 2, "lost": 1, "dropped": 0, "undelivered": 0,
                                  "refused": 0}


def test_a_message_due_before_the_receivers_mission_began_is_delivered_when_it_began(
        vehicle: str) -> None:
    """The fleet over Zenoh failed replay at random: a 'go' due at 1.97 s of the follower's
    clock, its mission begun at 2.18 s, was heard as raised before the mission started."""
    model, clock = Model(), Clock()
    records: list[dict[str, Any]] = []
    sender, receiver = pair(vehicle, model, clock, records, where=(3000.0, 0.0, 0.0))
    with receiver, sender:
        assert sender.wait_matched(budget(0.5)), "the receiver never subscribed"
        sender.send(Message("guide", "fix", "asv", 1, 10.0, {"position": [0.0, 0.0, 0.0]}))
        wait_for(lambda: receiver.summary()["received"] == 1)
        # due at 102 s of the receiver's clock; its mission began at 105 s
        due = receiver.deliveries("uuv", 106.0, since=105.0)
        assert [(t, m.seq) for t, m in due] == [(105.0, 1)]
    delivered = [r for r in records if r["kind"] == "delivered"]
    assert [(r["t"], r["delay"]) for r in delivered] == [(105.0, 2.0)]  # the model's delay


def test_a_message_not_from_the_channels_sender_is_refused(vehicle: str) -> None:
    clock, records = Clock(), list[dict[str, Any]]()
    _, receiver = pair(vehicle, Model(), clock, records)
    intruder = zenoh.open(zenoh_config(vehicle, connect=True))
    try:
        with receiver:
            publisher = intruder.declare_publisher(channel_key("mcm", "guide"))
            wait_for(lambda: publisher.matching_status.matching)
            for sender, message in [("uuv", "fix"), ("asv", "detonate"), ("asv", "fix")]:
                publisher.put(to_wire(Message("guide", message, sender, 1, 0.0)))
            publisher.put(b"not json")
            wait_for(lambda: receiver.summary()["refused"] + receiver.summary()["received"] == 4)
            assert receiver.summary()["refused"] == 3
            assert [m.message for _, m in receiver.deliveries("uuv", 1e9)] == ["fix"]
    finally:
        close_session(intruder)
    assert [r["why"].split(" ")[0] for r in records if r["kind"] == "refused"][:2] == [
        "'uuv'", "guide"]


def test_the_missions_model_judges_over_zenoh_as_in_one_process(vehicle: str) -> None:
    """mission/channels.py's ChannelModel at the receiver: the same fates as in process for
    the same seed; a message dropped by EVERY or lost is recorded so, and what is still due
    when the run ends is recorded undelivered."""
    channel = LossyGuide()
    sent = [Message("guide", "fix", "asv", i, t, {}) for i, t in enumerate(
        [0.0, 1.0, 4.0, 8.0, 12.0, 16.0, 20.0, 24.0])]
    alone = ChannelModel(channel, 0.5, random.Random(9))
    expected = [alone.judge(m, None, None) for m in sent]
    assert {f.fate for f in expected} == {"delivered", "lost", "dropped"}
    clock, records = Clock(), list[dict[str, Any]]()
    sender: ZenohCarrier[Message] = ZenohCarrier(
        "mcm", "asv", {"guide": channel}, make=Message, models={}, clock=clock,
        publish=zenoh_config(vehicle, connect=True), record=records.append)
    receiver: ZenohCarrier[Message] = ZenohCarrier(
        "mcm", "uuv", {"guide": channel}, make=Message, clock=clock, record=records.append,
        models={"guide": ChannelModel(channel, 0.5, random.Random(9))},
        subscribe={"asv": zenoh_config(vehicle, "client", connect=True)})
    with receiver, sender:
        assert sender.wait_matched(budget(0.5))
        for m in sent:
            sender.send(m)
        wait_for(lambda: receiver.summary()["received"] == len(sent))
        got = receiver.deliveries("uuv", 100.0 + 2.0)
        receiver.undelivered(102.0, "the run ended")
    fates = {r["seq"]: r["kind"] for r in records if r["kind"] != "sent"}
    assert [fates[m.seq].replace("undelivered", "delivered") for m in sent] == [
        f.fate for f in expected]
    delays = {r["seq"]: r["delay"] for r in records if r["kind"] == "delivered"}
    assert all(delays[m.seq] == pytest.approx((f.at or 0.0) - m.sent)
               for m, f in zip(sent, expected) if m.seq in delays)
    assert [t for t, _ in got] == sorted(100.0 + f.at - m.sent for m, f in zip(sent, expected)
                                         if f.at is not None and f.at - m.sent <= 2.0)


def test_a_carrier_sends_only_on_its_own_channels(vehicle: str) -> None:
    sender, receiver = pair(vehicle, Model(), Clock(), [])
    with sender:
        with pytest.raises(ValueError, match="does not send"):
            sender.send(Message("other", "fix", "asv", 1, 0.0))
    with pytest.raises(ValueError, match="delivers to uuv"):
        receiver.deliveries("asv", 0.0)


@pytest.mark.slow
def test_an_absent_senders_vehicle_is_a_clear_error() -> None:
    endpoint = free_endpoint()  # nobody listens
    _, receiver = pair(endpoint, Model(), Clock(), [])
    with pytest.raises(ChannelUnreachable, match="cannot reach asv's vehicle"):
        receiver.__enter__()
