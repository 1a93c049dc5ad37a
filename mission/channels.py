"""A fleet's channels at run time: what crosses them, the rule that decides each message's
fate, how messages reach the receivers' players, and the record of every message.

- :class:`Message`: what crosses a channel, small and enumerated (paper 003's acoustic
  payloads are tens of bytes); it carries its send time, since clocks are not shared.
- :class:`ChannelModel`: one per channel, seeded; the same rule in one process and over
  Zenoh. A message closer than the channel's ``EVERY`` to the last one sent on it is
  *dropped* (the modem cannot send it); a message on a ``LOSSY`` channel is *lost* with
  probability ``loss``; otherwise it is *delivered* after the modem's latency plus the
  distance at 1,500 m/s, clipped to the channel's ``DELAY`` range (drawn uniformly in that
  range when the positions are not known).
- :class:`Carrier`: how messages reach the receivers; :class:`InProcessCarrier` is the one of
  a fleet run in one process (the Zenoh carrier, ``vehicle_adapters/zenoh_channels.py``,
  applies the same model at the receiving side).
- :class:`ChannelRecord`: the channel record, JSON Lines, hash-chained like a run log: one
  line per message and receiver, ``sent``, then ``delivered`` (with its time), ``lost``,
  ``dropped`` or ``undelivered`` (the receiver's run ended first). ``mcl replay`` checks it
  against the vehicles' logs (:mod:`mission.fleet_evidence`). Format: docs/FLEET_RUN.md.

Acoustic silence is not ``Link.lost``: that stays the player-to-vehicle link.
"""

from __future__ import annotations

import heapq
import json
import math
import random
import threading
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import IO, Any, NamedTuple, Protocol

from mcl.fleet import Channel
from petri.execution.runlog import GENESIS, chain, finite

SOUND_SPEED = 1500.0  # m/s in sea water (not air's 343 m/s)
LATENCY = 0.5  # s: the modem's own latency, before the sound travels
RECORD_FORMAT = "mcl-channel-record/1"
FATES = ("delivered", "lost", "dropped")  # what ChannelModel decides for a message
Position = tuple[float, float, float]  # x, y, z in metres, in the simulated world's frame



@dataclass(frozen=True)
class Message:
    """What crosses a channel: small and enumerated."""

    channel: str
    message: str
    sender: str
    seq: int  # the sender's count of messages, from 0
    sent: float  # the sender's clock when sent (clocks are not shared: times travel)
    data: dict[str, Any] = field(default_factory=dict)  # the sender vehicle's payload

    def as_record(self) -> dict[str, Any]:
        return {"channel": self.channel, "message": self.message, "sender": self.sender,
                "seq": self.seq, "sent": round(self.sent, 6)}


class Fate(NamedTuple):
    """What :class:`ChannelModel` decided for one message and one receiver."""

    fate: str  # delivered | lost | dropped
    at: float | None  # the delivery time on the sender's clock (None: not delivered)
    why: str  # for people: the distance and delay, the loss draw, the interval


class ChannelModel:
    """The fate of each message on one channel (the module's doc); ``rng`` seeds it, so the
    same seed gives the same fates."""

    def __init__(self, channel: Channel, loss: float, rng: random.Random,
                 latency: float = LATENCY) -> None:
        if not 0.0 <= loss <= 1.0:
            raise ValueError(f"loss {loss!r} is not a probability (0 to 1)")
        self.channel = channel
        self.loss = loss if channel.lossy else 0.0
        self.rng = rng
        self.latency = latency
        self.last_sent: float | None = None  # the send time of the last message not dropped
        self.decided: tuple[int, bool] | None = None  # (seq, dropped) of the last message

    def decide(self, msg: Message, sender_pos: Position | None,
               receiver_pos: Position | None) -> float | None:
        """The delivery time on the sender's clock, or None: lost or dropped."""
        return self.judge(msg, sender_pos, receiver_pos).at

    def judge(self, msg: Message, sender_pos: Position | None,
              receiver_pos: Position | None) -> Fate:
        """The fate of ``msg`` for the receiver at ``receiver_pos``. A message to several
        receivers is judged once per receiver: dropped for all or for none, lost for each
        independently."""
        if self.dropped(msg):
            return Fate("dropped", None, f"{msg.sent - (self.last_sent or 0.0):.3g} s after "
                        f"the last message, closer than EVERY {self.channel.interval:g} s")
        if self.loss > 0.0 and self.rng.random() < self.loss:
            return Fate("lost", None, f"lost (loss {self.loss:g})")
        low, high = self.channel.delay_min, self.channel.delay_max
        if sender_pos is None or receiver_pos is None:
            delay = self.rng.uniform(low, high)
            return Fate("delivered", msg.sent + delay,
                        f"delay {delay:.3f} s drawn in {low:g} .. {high:g} s (positions unknown)")
        distance = math.dist(sender_pos, receiver_pos)
        delay = min(max(self.latency + distance / SOUND_SPEED, low), high)
        return Fate("delivered", msg.sent + delay,
                    f"{distance:.1f} m: delay {delay:.3f} s")

    def dropped(self, msg: Message) -> bool:
        """Is ``msg`` closer than EVERY to the last message sent? (Decided once per message.)"""
        if self.decided is not None and self.decided[0] == msg.seq:
            return self.decided[1]
        drop = (self.last_sent is not None and self.channel.interval > 0.0
                and msg.sent - self.last_sent < self.channel.interval - 1e-9)
        if not drop:
            self.last_sent = msg.sent
        self.decided = (msg.seq, drop)
        return drop


class Carrier(Protocol):
    """How messages reach the receivers' players."""

    def send(self, msg: Message) -> None: ...

    def deliveries(self, receiver: str, until: float) -> list[tuple[float, Message]]:
        """The messages due at ``receiver`` by time ``until``, each with its delivery time."""
        ...


class ChannelRecord:
    """The channel record: JSON Lines, each line's ``digest`` chained as in a run log
    (:func:`petri.execution.runlog.chain`), a header first and an ``end`` line last."""

    def __init__(self, path: str | Path, header: Mapping[str, Any]) -> None:
        self.path = Path(path)
        self.path.parent.mkdir(parents=True, exist_ok=True)
        self.file: IO[str] | None = open(self.path, "w", encoding="ascii")  # noqa: SIM115
        self.digest = GENESIS
        self.failure = ""  # why the record is incomplete ("": it is whole)
        self.write({"kind": "header", "format": RECORD_FORMAT, **header})

    def write(self, obj: dict[str, Any]) -> None:
        """One line, flushed; a record that cannot be written says why once, and the run
        goes on (the vehicles' logs are the run's evidence of its end)."""
        if self.file is None:
            return
        plain = finite(json.loads(json.dumps(obj, default=str)))
        body = json.dumps(plain, separators=(",", ":"))
        self.digest = chain(self.digest, body)
        try:
            self.file.write(body[:-1] + f',"digest":"{self.digest}"' + "}\n")
            self.file.flush()
        except OSError as exc:
            self.failure = f"the channel record could not be written: {exc.strerror or exc}"
            self.close()

    def close(self, t: float | None = None, why: str = "") -> None:
        """The end line (when ``t`` is given), then the file is closed."""
        if self.file is not None and t is not None:
            self.write({"t": round(t, 6), "kind": "end", "why": why})
        if self.file is not None:
            try:
                self.file.close()
            except OSError:
                pass
            self.file = None


class InProcessCarrier:
    """The carrier of a fleet run in one process: each message is judged by its channel's
    model when sent, then waits in the receiver's queue until its delivery time.

    ``where(vehicle)``: the vehicle's position now (None: not known); ``record``: the channel
    record (None: none is written). Thread-safe: each vehicle's runner calls it from its own
    thread (one at a time, :mod:`mission.fleet`)."""

    def __init__(self, channels: Mapping[str, Channel], models: Mapping[str, ChannelModel],
                 where: Callable[[str], Position | None] = lambda name: None,
                 record: ChannelRecord | None = None) -> None:
        self.channels = dict(channels)
        self.models = dict(models)
        self.where = where
        self.record = record
        self.lock = threading.Lock()
        self.queues: dict[str, list[tuple[float, int, Message]]] = {}
        self.order = 0  # ties in a queue: the order the messages were sent in
        self.counts: dict[str, dict[str, int]] = {
            name: {"sent": 0, "delivered": 0, "lost": 0, "dropped": 0, "undelivered": 0}
            for name in self.channels}
        self.delays: dict[str, list[float]] = {name: [] for name in self.channels}

    def send(self, msg: Message) -> None:
        channel = self.channels[msg.channel]
        with self.lock:
            self.counts[msg.channel]["sent"] += 1
            self.note(msg.sent, "sent", msg)
            for receiver in channel.receivers:
                fate = self.models[msg.channel].judge(msg, self.where(msg.sender),
                                                      self.where(receiver))
                if fate.at is None:
                    self.counts[msg.channel][fate.fate] += 1
                    self.note(msg.sent, fate.fate, msg, receiver=receiver, why=fate.why)
                    continue
                self.order += 1
                heapq.heappush(self.queues.setdefault(receiver, []), (fate.at, self.order, msg))

    def deliveries(self, receiver: str, until: float) -> list[tuple[float, Message]]:
        due: list[tuple[float, Message]] = []
        with self.lock:
            queue = self.queues.get(receiver, [])
            while queue and queue[0][0] <= until + 1e-9:
                at, _, msg = heapq.heappop(queue)
                due.append((at, msg))
                self.counts[msg.channel]["delivered"] += 1
                self.delays[msg.channel].append(at - msg.sent)
                self.note(at, "delivered", msg, receiver=receiver, delay=round(at - msg.sent, 6))
        return due

    def next_due(self, receiver: str) -> float | None:
        """When the next message falls due at ``receiver`` (None: none is in flight)."""
        with self.lock:
            queue = self.queues.get(receiver)
            return queue[0][0] if queue else None

    def undelivered(self, receiver: str, t: float, why: str) -> None:
        """``receiver``'s run has ended at ``t``: what is still in flight to it never arrives."""
        with self.lock:
            for at, _, msg in sorted(self.queues.pop(receiver, [])):
                self.counts[msg.channel]["undelivered"] += 1
                self.note(max(t, msg.sent), "undelivered", msg, receiver=receiver,
                          due=round(at, 6), why=why)

    def note(self, t: float, kind: str, msg: Message, **more: Any) -> None:
        if self.record is not None:
            self.record.write({"t": round(t, 6), "kind": kind, **msg.as_record(), **more})

    def summary(self) -> dict[str, dict[str, Any]]:
        """Each channel's counts (sent, delivered, lost, dropped, undelivered; a message to
        two receivers counts once sent and once per receiver after) and its median delay."""
        with self.lock:
            return {name: {**counts, "median_delay": median(self.delays[name])}
                    for name, counts in self.counts.items()}


def median(values: list[float]) -> float | None:
    """The median of ``values`` (None: there are none)."""
    if not values:
        return None
    ordered = sorted(values)
    middle = len(ordered) // 2
    if len(ordered) % 2:
        return ordered[middle]
    return (ordered[middle - 1] + ordered[middle]) / 2
