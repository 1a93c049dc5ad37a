"""A fleet's channels over Zenoh: the carrier of the messages between vehicles' players that run
in separate processes or machines (docs/FLEET_ZENOH.md).

Key layout (``<f>`` the fleet's name, ``<c>`` a channel's)::

    mcl/fleet/<f>/channel/<c>     the channel's sender -> its receivers, one message (JSON) a put

Who talks to whom. Every vehicle's player keeps its own link to its own vehicle
(``mcl/<v>/...``, :mod:`vehicle_adapters.zenoh_link`). The carrier adds:

- on the sender's side, a **peer** session connected to the sender's own vehicle, with the
  player's credentials: it puts each message on the channel's key;
- on each receiver's side, one **client** session per sender, connected to the *sender's*
  vehicle, which routes to its clients what its player puts (as it does for ``mcl monitor``).

The sender's vehicle is therefore the one point every message of its channels goes through,
and the one that enforces who may put on them (docs/ZENOH_SECURITY.md: only the player of a
channel's sender). The receiver checks again: a message is taken only on a channel of the
fleet directed to it, with a message the channel declares, from the channel's sender.

The channel model (delay, loss, minimum interval) is applied on the **receiving** side, where
the receiver knows its own position; the sender's position travels in the message's ``data``
(``"position": [x, y, z]``, or ``"x"``, ``"y"``, ``"z"``). Clocks are not shared: the model
gives the delivery time on the sender's clock, so the delay it adds is that minus the
message's ``sent``, and the message is delivered that long after it arrived, on the
receiver's clock (the Zenoh transport's own latency, milliseconds, is the only time added).

The carrier is generic in the types it carries (this layer sits below the mission's, which
defines the fleet's Message, Channel and ChannelModel): it takes them as protocols and a
constructor for messages, so that it hands the player the mission's own Message.
"""

from __future__ import annotations

import heapq
import json
import logging
import math
import threading
import time
from collections.abc import Callable, Mapping
from typing import Any, Generic, Protocol, TypeVar

import zenoh

from aal.zenoh import close_session, payload_text, zenoh_error
from diagnostics import MclError

log = logging.getLogger(__name__)

KEY = "mcl/fleet/{fleet}/channel/{channel}"
MAX_BYTES = 4096  # a fleet message is tens of bytes of payload: anything longer is refused
WIRE_VERSION = 1

Position = tuple[float, float, float]


class ChannelSpec(Protocol):
    """What the carrier needs of a channel (mcl's compiled Channel)."""

    @property
    def name(self) -> str: ...
    @property
    def sender(self) -> str: ...
    @property
    def receivers(self) -> tuple[str, ...]: ...
    @property
    def messages(self) -> tuple[str, ...]: ...


class MessageFields(Protocol):
    """What crosses a channel (the mission's Message): small and enumerated."""

    @property
    def channel(self) -> str: ...
    @property
    def message(self) -> str: ...
    @property
    def sender(self) -> str: ...
    @property
    def seq(self) -> int: ...
    @property
    def sent(self) -> float: ...
    @property
    def data(self) -> dict[str, Any]: ...


M = TypeVar("M", bound=MessageFields)
M_contra = TypeVar("M_contra", bound=MessageFields, contravariant=True)


class Decides(Protocol[M_contra]):
    """A channel's model (the mission's ChannelModel): the delivery time of a message on the
    sender's clock, or None when it is lost or dropped."""

    def decide(self, msg: M_contra, sender_pos: Position | None,
               receiver_pos: Position | None) -> float | None: ...


class ChannelUnreachable(MclError):
    """A carrier's session could not be opened (a sender's vehicle is not there)."""


def channel_key(fleet: str, channel: str) -> str:
    """The Zenoh key of one channel of one fleet."""
    return KEY.format(fleet=fleet, channel=channel)


def to_wire(msg: MessageFields) -> bytes:
    """A message as it crosses Zenoh (JSON; ValueError if it is too long)."""
    text = json.dumps({"v": WIRE_VERSION, "channel": msg.channel, "message": msg.message,
                       "sender": msg.sender, "seq": msg.seq, "sent": msg.sent,
                       "data": msg.data}, separators=(",", ":"), allow_nan=False).encode()
    if len(text) > MAX_BYTES:
        raise ValueError(f"a message on {msg.channel} of {len(text)} bytes: at most "
                         f"{MAX_BYTES} (a fleet message is small and enumerated)")
    return text


def from_wire(payload: bytes) -> dict[str, Any]:
    """The fields of a message read from Zenoh, checked; ValueError saying what is wrong."""
    if len(payload) > MAX_BYTES:
        raise ValueError(f"{len(payload)} bytes: longer than {MAX_BYTES}")
    d = json.loads(payload)
    if not isinstance(d, dict) or d.get("v") != WIRE_VERSION:
        raise ValueError(f"not a version {WIRE_VERSION} fleet message")
    fields = {"channel": str, "message": str, "sender": str, "data": dict}
    for name, kind in fields.items():
        if not isinstance(d.get(name), kind):
            raise ValueError(f"field {name!r} missing or not a {kind.__name__}")
    seq, sent = d.get("seq"), d.get("sent")
    if not isinstance(seq, int) or isinstance(seq, bool) or seq < 0:
        raise ValueError("field 'seq' is not a natural number")
    if not isinstance(sent, (int, float)) or isinstance(sent, bool) or not math.isfinite(sent):
        raise ValueError("field 'sent' is not a finite time")
    return {"channel": d["channel"], "message": d["message"], "sender": d["sender"],
            "seq": seq, "sent": float(sent), "data": d["data"]}


def position_in(data: Mapping[str, Any]) -> Position | None:
    """The sender's position a message's data carries (``position: [x, y, z]`` or ``x``,
    ``y``, ``z``), or None if it carries none (the model then draws the delay)."""
    raw = data.get("position")
    if raw is None and all(k in data for k in ("x", "y", "z")):
        raw = [data["x"], data["y"], data["z"]]
    try:
        x, y, z = (float(v) for v in raw)  # type: ignore[union-attr]
    except (TypeError, ValueError):
        return None
    return (x, y, z) if all(math.isfinite(v) for v in (x, y, z)) else None


class ZenohCarrier(Generic[M]):
    """The channels of one vehicle (``me``) of one fleet, over Zenoh: a Carrier (send,
    deliveries) and a context manager that opens and closes its sessions.

    ``publish``: the configuration of the peer session to this vehicle's own vehicle (None
    if it sends on no channel); ``subscribe``: per sender of a channel directed to ``me``,
    the configuration of the client session to that sender's vehicle. ``make`` builds the
    mission's Message from its fields; ``models``: each channel's model (directed to me);
    ``clock``: this vehicle's time; ``position``: its position now (or None); ``record``:
    told every message's fate, one dict each (the channel record's lines).
    """

    def __init__(self, fleet: str, me: str, channels: Mapping[str, ChannelSpec], *,
                 make: Callable[..., M], models: Mapping[str, Decides[M]],
                 clock: Callable[[], float],
                 position: Callable[[], Position | None] = lambda: None,
                 record: Callable[[dict[str, Any]], None] = lambda line: None,
                 publish: zenoh.Config | None = None,
                 subscribe: Mapping[str, zenoh.Config] | None = None) -> None:
        self.fleet, self.me, self.channels = fleet, me, dict(channels)
        self.make, self.models, self.clock = make, dict(models), clock
        self.position, self.record = position, record
        self._publish_config = publish
        self._subscribe_configs = dict(subscribe or {})
        self.lock = threading.Lock()
        self._due: list[tuple[float, int, M, float]] = []  # (time, order, message, delay): a heap
        self._order = 0
        self.counts = {"sent": 0, "received": 0, "delivered": 0, "lost": 0, "dropped": 0,
                       "undelivered": 0, "refused": 0}
        self._sessions: list[zenoh.Session] = []
        self._declared: list[Any] = []
        self._publishers: dict[str, Any] = {}

    # -- sessions ---------------------------------------------------------------------------------
    def __enter__(self) -> ZenohCarrier[M]:
        try:
            if any(c.sender == self.me for c in self.channels.values()):
                if self._publish_config is None:
                    raise ValueError(f"{self.me} sends on a channel: give its publish session")
                session = self._open(self._publish_config, f"{self.me}'s own vehicle")
                for c in self.channels.values():
                    if c.sender == self.me:
                        self._publishers[c.name] = session.declare_publisher(
                            channel_key(self.fleet, c.name),
                            congestion_control=zenoh.CongestionControl.BLOCK)
                self._declared += self._publishers.values()
            for sender in sorted({c.sender for c in self.incoming()}):
                config = self._subscribe_configs.get(sender)
                if config is None:
                    raise ValueError(f"{self.me} hears {sender}: give a session to its vehicle")
                session = self._open(config, f"{sender}'s vehicle")
                for c in self.incoming():
                    if c.sender == sender:
                        self._declared.append(session.declare_subscriber(
                            channel_key(self.fleet, c.name), self._on_sample))
        except BaseException:
            self.__exit__()
            raise
        return self

    def _open(self, config: zenoh.Config, whose: str) -> zenoh.Session:
        try:
            session = zenoh.open(config)
        except zenoh.ZError as exc:
            raise ChannelUnreachable(f"fleet {self.fleet}: cannot reach {whose} for the "
                                     f"channels ({zenoh_error(exc)})") from None
        self._sessions.append(session)
        return session

    def __exit__(self, *exc: object) -> None:
        for entity in reversed(self._declared):
            try:
                entity.undeclare()
            except Exception:  # already gone with its session
                pass
        self._declared.clear()
        self._publishers.clear()
        for session in self._sessions:
            close_session(session)
        self._sessions.clear()

    def incoming(self) -> list[ChannelSpec]:
        """The channels directed to this vehicle."""
        return [c for c in self.channels.values() if self.me in c.receivers]

    def wait_matched(self, timeout: float) -> bool:
        """Wait (at most ``timeout`` wall s) until every channel this vehicle sends on has a
        subscriber (a message put before a receiver listens is lost, as over the water)."""
        end = time.monotonic() + timeout
        while True:
            if all(p.matching_status.matching for p in self._publishers.values()):
                return True
            if time.monotonic() >= end:
                return False
            time.sleep(0.01)

    # -- the Carrier protocol ---------------------------------------------------------------------
    def send(self, msg: M) -> None:
        """Put a message on its channel (the sender's side); recorded as sent."""
        publisher = self._publishers.get(msg.channel)
        if publisher is None:
            raise ValueError(f"{self.me} does not send on {msg.channel!r} in fleet {self.fleet}")
        publisher.put(to_wire(msg))
        with self.lock:
            self.counts["sent"] += 1
        self.record({"t": msg.sent, "kind": "sent", **fields_of(msg)})

    def deliveries(self, receiver: str, until: float, since: float = -math.inf
                   ) -> list[tuple[float, M]]:
        """The messages due at ``receiver`` (this vehicle) by ``until`` on its clock, each with
        its delivery time, in order; each is given once, and recorded as delivered. One due
        before ``since`` (the receiver's mission had not begun: its modem held it) is
        delivered at ``since``."""
        if receiver != self.me:
            raise ValueError(f"this carrier delivers to {self.me}, not {receiver}")
        due: list[tuple[float, M, float]] = []
        with self.lock:
            while self._due and self._due[0][0] <= until + 1e-9:
                t, _, msg, delay = heapq.heappop(self._due)
                due.append((max(t, since), msg, delay))
            self.counts["delivered"] += len(due)
        for t, msg, delay in due:
            self.record({"t": t, "kind": "delivered", **fields_of(msg), "receiver": self.me,
                         "delay": round(delay, 6)})
        return [(t, msg) for t, msg, _ in due]

    def next_due(self) -> float | None:
        """When the next message received falls due here (None: none is waiting)."""
        with self.lock:
            return self._due[0][0] if self._due else None

    def undelivered(self, t: float, why: str) -> None:
        """This vehicle's run has ended at ``t``: what waits for it is never delivered."""
        with self.lock:
            left, self._due = sorted(self._due), []
            self.counts["undelivered"] += len(left)
        for at, _, msg, _ in left:
            self.record({"t": max(t, at), "kind": "undelivered", **fields_of(msg),
                         "receiver": self.me, "due": round(at, 6), "why": why})

    def pending(self) -> int:
        """Messages received and not yet due."""
        with self.lock:
            return len(self._due)

    def summary(self) -> dict[str, Any]:
        with self.lock:
            return {"fleet": self.fleet, "vehicle": self.me, **self.counts}

    # -- receiving (Zenoh's threads) --------------------------------------------------------------
    def _on_sample(self, sample: zenoh.Sample) -> None:
        try:
            fields = from_wire(payload_text(sample))
            self._check(str(sample.key_expr), fields)
        except ValueError as exc:
            with self.lock:
                self.counts["refused"] += 1
            log.warning("fleet %s: %s refused a message on %s: %s", self.fleet, self.me,
                        sample.key_expr, exc)
            self.record({"t": self.clock(), "kind": "refused", "key": str(sample.key_expr),
                         "why": str(exc)})
            return
        self.receive(self.make(**fields))

    def _check(self, key: str, fields: Mapping[str, Any]) -> None:
        """ValueError unless the message is on a channel of this fleet directed to me, on its
        own key, from the channel's sender, with a message the channel declares."""
        channel = self.channels.get(fields["channel"])
        if channel is None or self.me not in channel.receivers:
            raise ValueError(f"no channel {fields['channel']!r} to {self.me} in this fleet")
        if key != channel_key(self.fleet, channel.name):
            raise ValueError(f"a message of {channel.name} on another key")
        if fields["sender"] != channel.sender:
            raise ValueError(f"{fields['sender']!r} is not the sender of {channel.name} "
                             f"({channel.sender})")
        if fields["message"] not in channel.messages:
            raise ValueError(f"{channel.name} carries no message {fields['message']!r}")

    def receive(self, msg: M) -> float | None:
        """A message arrived now: the channel's model decides its fate; returns its delivery
        time on this vehicle's clock, or None (lost or dropped: recorded at once)."""
        arrived = self.clock()
        fate, at, why = self.judge(msg)
        with self.lock:
            self.counts["received"] += 1
            if at is None:
                self.counts[fate] += 1
            else:
                delay = max(0.0, at - msg.sent)
                heapq.heappush(self._due, (arrived + delay, self._order, msg, delay))
                self._order += 1
        if at is None:
            self.record({"t": arrived, "kind": fate, **fields_of(msg), "receiver": self.me,
                         "why": why})
            return None
        return arrived + delay

    def judge(self, msg: M) -> tuple[str, float | None, str]:
        """The channel model's word on ``msg`` here: (delivered | lost | dropped, the delivery
        time on the sender's clock or None, why). A model that can say why a message was not
        delivered (``judge``, mission/channels.py) is asked that; one that only decides is
        taken to have lost what it does not deliver."""
        model = self.models.get(msg.channel)
        if model is None:
            return "delivered", msg.sent, "no model: at once"
        where = (position_in(msg.data), self.position())
        judge = getattr(model, "judge", None)
        if callable(judge):
            fate = judge(msg, *where)
            return str(fate.fate), fate.at, str(fate.why)
        at = model.decide(msg, *where)
        return ("lost", None, "lost") if at is None else ("delivered", at, "")


def fields_of(msg: MessageFields) -> dict[str, Any]:
    """A message's fields as the channel record writes them (data left out: it may be long)."""
    return {"channel": msg.channel, "message": msg.message, "sender": msg.sender,
            "seq": msg.seq, "sent": round(msg.sent, 6)}
