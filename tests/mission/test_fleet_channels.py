"""The channel model and the in-process carrier (mission/channels.py): delay from distance at
1,500 m/s plus latency, clipped to the DELAY range; loss only on a LOSSY channel, at its rate;
messages closer than EVERY dropped; one way; every fate in the chained channel record."""

from __future__ import annotations

import json
import random
from dataclasses import dataclass
from pathlib import Path

import pytest

from mission.channels import (
    SOUND_SPEED,
    ChannelModel,
    ChannelRecord,
    InProcessCarrier,
    Message,
    median,
)
from petri.execution.runlog import GENESIS, chain


@dataclass(frozen=True)
class Chan:
    name: str = "guide"
    sender: str = "asv"
    receivers: tuple[str, ...] = ("uuv",)
    delay_min: float = 1.0
    delay_max: float = 3.0
    interval: float = 2.0
    lossy: bool = True
    messages: tuple[str, ...] = ("fix",)


def msg(seq: int, sent: float, message: str = "fix") -> Message:
    return Message("guide", message, "asv", seq, sent, {})


def test_delay_is_latency_plus_travel_at_the_speed_of_sound_clipped_to_the_range() -> None:
    model = ChannelModel(Chan(interval=0.0), 0.0, random.Random(1), latency=0.5)
    at = model.decide(msg(0, 10.0), (0.0, 0.0, 0.0), (1500.0, 0.0, 0.0))
    assert at == pytest.approx(10.0 + 0.5 + 1500.0 / SOUND_SPEED)
    assert model.decide(msg(1, 20.0), (0.0, 0.0, 0.0), (0.0, 3.0, 4.0)) == 21.0  # clipped up
    assert model.decide(msg(2, 30.0), (0.0, 0.0, 0.0), (9000.0, 0.0, 0.0)) == 33.0  # down


def test_unknown_positions_draw_the_delay_in_the_range_the_same_for_the_same_seed() -> None:
    one = ChannelModel(Chan(interval=0.0), 0.0, random.Random(5))
    two = ChannelModel(Chan(interval=0.0), 0.0, random.Random(5))
    times = [one.decide(msg(i, 10.0 * i), None, None) for i in range(50)]
    assert times == [two.decide(msg(i, 10.0 * i), None, None) for i in range(50)]
    delays = [t - 10.0 * i for i, t in enumerate(times) if t is not None]
    assert len(delays) == 50 and all(1.0 <= d <= 3.0 for d in delays)
    assert max(delays) - min(delays) > 1.0  # drawn, not a constant


@pytest.mark.parametrize("loss", [0.0, 0.3, 0.5, 1.0])
def test_a_lossy_channel_loses_at_its_rate(loss: float) -> None:
    model = ChannelModel(Chan(interval=0.0), loss, random.Random(3))
    fates = [model.judge(msg(i, float(i)), None, None).fate for i in range(2000)]
    assert fates.count("lost") / len(fates) == pytest.approx(loss, abs=0.04)


def test_a_channel_without_lossy_loses_nothing_whatever_the_loss() -> None:
    model = ChannelModel(Chan(lossy=False, interval=0.0), 1.0, random.Random(3))
    assert all(model.decide(msg(i, float(i)), None, None) is not None for i in range(100))


def test_a_message_closer_than_every_is_dropped_and_does_not_reset_the_interval() -> None:
    model = ChannelModel(Chan(interval=2.0), 0.0, random.Random(1))
    fates = [model.judge(msg(i, t), None, None).fate
             for i, t in enumerate([0.0, 1.0, 1.9, 2.0, 3.5, 4.0])]
    assert fates == ["delivered", "dropped", "dropped", "delivered", "dropped", "delivered"]


def test_a_probability_outside_zero_to_one_is_refused() -> None:
    with pytest.raises(ValueError, match="not a probability"):
        ChannelModel(Chan(), 1.5, random.Random(1))


def test_the_carrier_delivers_in_time_order_one_way_and_records_every_fate(
        tmp_path: Path) -> None:
    record = ChannelRecord(tmp_path / "channels.jsonl", {"fleet": "f"})
    chan = Chan(receivers=("uuv", "rov"), interval=2.0)
    model = ChannelModel(chan, 0.5, random.Random(11))
    carrier = InProcessCarrier({"guide": chan}, {"guide": model}, lambda n: None, record)
    for i in range(40):
        carrier.send(msg(i, 1.5 * i))
    assert carrier.deliveries("asv", 1e9) == []  # one way: nothing back to the sender
    got = carrier.deliveries("uuv", 30.0)
    assert [t for t, _ in got] == sorted(t for t, _ in got) and all(t <= 30.0 for t, _ in got)
    assert all(1.0 <= t - m.sent <= 3.0 for t, m in got)
    rest = carrier.deliveries("uuv", 1e9)
    assert all(t > 30.0 for t, _ in rest)
    carrier.undelivered("rov", 60.0, "its run ended")
    record.close(60.0, "done")
    counts = carrier.summary()["guide"]
    assert counts["sent"] == 40 and counts["dropped"] == 2 * 20  # every other one, twice
    assert counts["delivered"] == len(got) + len(rest)
    assert counts["delivered"] + counts["lost"] + counts["undelivered"] == 2 * 20
    assert 0 < counts["lost"] < 40  # loss 0.5, each receiver drawn apart
    lines = (tmp_path / "channels.jsonl").read_text("ascii").splitlines()
    kinds = [json.loads(line)["kind"] for line in lines]
    assert kinds[0] == "header" and kinds[-1] == "end"
    assert kinds.count("sent") == 40 and kinds.count("delivered") == counts["delivered"]
    previous = GENESIS  # the record's chain holds, line by line
    for line in lines:
        obj = json.loads(line)
        body = json.dumps({k: v for k, v in obj.items() if k != "digest"},
                          separators=(",", ":"))
        assert obj["digest"] == chain(previous, body)
        previous = obj["digest"]


def test_median() -> None:
    assert median([]) is None
    assert median([3.0, 1.0, 2.0]) == 2.0
    assert median([4.0, 1.0, 2.0, 3.0]) == 2.5
