"""The fleet's product net: every vehicle's net side by side, joined only by channel places.

A fleet is proved on one place/transition net (docs/METHODS.md, "Fleets: what is proved"):

- every vehicle's places and transitions, renamed ``VEHICLE/...`` (origins kept), except its
  external stop (``Mission.abort``): the product is the fleet left to itself, each vehicle's
  stop being proved on its own (``stop-safe``);
- for each channel, message and receiver a *link*: four places, ``in flight`` / ``empty`` and
  ``mailbox`` / ``mailbox empty`` (each pair holds one token: the net stays 1-safe), and the
  channel's own transitions: ``deliver`` (in flight -> mailbox; a newer delivery overwrites
  an unread one) and, on a LOSSY channel, ``lose`` (in flight -> empty);
- a sender's transition that carries ``Action("send", CHANNEL, (("message", M),))`` puts M in
  flight to every receiver (a second send while one is in flight overwrites it): one copy of
  the transition for each combination of the links' states, so that arcs stay unweighted;
- a receiver's transition waiting for the event ``"CHANNEL.M"`` also takes the mailbox token.

Vehicles never share a transition (a one-way link at 0.5 Hz cannot carry a rendezvous). The
same construction with one vehicle and *arrivals* instead of senders (a message may be put in
the mailbox at any moment) is the vehicle alone against its channels' contract: the
compositional route (mcl/analysis/fleet_compositional.py).
"""

from __future__ import annotations

import itertools
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Protocol

from petri.net import INNER, Action, Net
from petri.semantics import MISSION_ABORT, Semantics

if TYPE_CHECKING:
    from mcl.api import Compiled

SEND = "send"  # the kind of Action a Send(CHANNEL, MESSAGE) task carries


class ChannelSpec(Protocol):
    """What the proof needs of a channel (mcl's compiled ``Channel``)."""

    @property
    def name(self) -> str: ...
    @property
    def sender(self) -> str: ...
    @property
    def receivers(self) -> tuple[str, ...]: ...
    @property
    def lossy(self) -> bool: ...
    @property
    def messages(self) -> tuple[str, ...]: ...


class FleetSpec(Protocol):
    """What the proof needs of a compiled fleet (mcl's ``CompiledFleet``)."""

    @property
    def name(self) -> str: ...
    @property
    def vehicles(self) -> Mapping[str, Compiled]: ...
    @property
    def channels(self) -> Mapping[str, ChannelSpec]: ...


@dataclass(frozen=True)
class Link:
    """One message of one channel on its way to one receiver: its four places."""

    channel: str
    message: str
    receiver: str
    lossy: bool
    flight: int
    empty: int
    mailbox: int
    mailbox_empty: int

    @property
    def event(self) -> str:
        return f"{self.channel}.{self.message}"


@dataclass(frozen=True)
class Step:
    """What a product transition is: a vehicle's own transition (``vehicle``, ``original``:
    its index in that vehicle's net) or a channel's (``kind`` "deliver", "lose" or, when a
    vehicle is proved alone, "arrive"; ``link`` the link it moves)."""

    kind: str  # "vehicle" | "deliver" | "lose" | "arrive"
    vehicle: str | None = None
    original: int = -1
    link: Link | None = None


@dataclass
class Slice:
    """One vehicle inside the product: its own net, its places' indices in the product (the
    product's place ``first + p`` is the vehicle's place ``p``) and its rules."""

    vehicle: str
    net: Net
    first: int
    rules: Semantics

    @property
    def columns(self) -> range:
        return range(self.first, self.first + len(self.net.places))


@dataclass
class FleetNet:
    """The product net of a fleet and how to read it back in each vehicle's terms."""

    name: str
    net: Net
    slices: dict[str, Slice]
    links: list[Link] = field(default_factory=list)
    steps: list[Step] = field(default_factory=list)  # one per product transition

    def vehicle_marking(self, marking: Sequence[int], vehicle: str) -> list[int]:
        """The vehicle's own marking inside a product marking."""
        s = self.slices[vehicle]
        return [int(x) for x in marking[s.first:s.first + len(s.net.places)]]

    def step_text(self, t: int) -> str:
        """A counterexample's line for product transition ``t``: ``uuv mcm.mcl:23:9
        Receive(guide, fix): guide.fix → ok`` or ``channel guide: release lost (to uuv)``."""
        step = self.steps[t]
        if step.link is not None and step.kind != "vehicle":
            ln = step.link
            what = {"deliver": "delivered to", "lose": "lost on its way to",
                    "arrive": "arrives at"}[step.kind]
            return f"channel {ln.channel}: {ln.message} {what} {ln.receiver}"
        assert step.vehicle is not None
        tr = self.slices[step.vehicle].net.transitions[step.original]
        o = tr.origin
        where = f" {o.where()} {o.text}" if o is not None else f" {tr.name}"
        return f"{step.vehicle}{where}: {tr.label or tr.name}"


def product(fleet: FleetSpec) -> FleetNet:
    """The fleet's product net (the module's doc)."""
    return _build(fleet, list(fleet.vehicles), arrivals=False)


def alone(fleet: FleetSpec, vehicle: str) -> FleetNet:
    """``vehicle`` alone against its channels' contract: its receptions' mailboxes may be
    filled at any moment (``arrive``), its sends go nowhere."""
    return _build(fleet, [vehicle], arrivals=True)


def _build(fleet: FleetSpec, vehicles: list[str], arrivals: bool) -> FleetNet:
    net = Net(fleet.name if not arrivals else f"{fleet.name}/{vehicles[0]}")
    slices: dict[str, Slice] = {}
    for v in vehicles:
        own = fleet.vehicles[v].net
        slices[v] = Slice(v, own, len(net.places), Semantics(own))
        for place in own.places:
            net.add_place(f"{v}/{place.name}", tuple(f"{v}/{b}" for b in place.behaviours),
                          place.origin, place.role)
        for p, n in own.initial.items():
            net.initial[slices[v].first + p] = n
        for b, dofs in own.dofs.items():
            net.dofs[f"{v}/{b}"] = dofs
    fnet = FleetNet(fleet.name, net, slices)
    for ch in fleet.channels.values():
        for message in ch.messages:
            for r in ch.receivers:
                if r in slices:
                    fnet.links.append(_link(net, ch, message, r))
    by_event = {(ln.receiver, ln.event): ln for ln in fnet.links}
    by_send: dict[tuple[str, str], list[Link]] = {}
    for ln in fnet.links:
        by_send.setdefault((ln.channel, ln.message), []).append(ln)
    for v, s in slices.items():
        for t, tr in enumerate(s.net.transitions):
            if tr.event == MISSION_ABORT:
                continue
            ins = [s.first + p for p, w in tr.inputs for _ in range(w)]
            outs = [s.first + p for p, w in tr.outputs for _ in range(w)]
            got = by_event.get((v, tr.event)) if tr.event is not None else None
            if got is not None:
                ins, outs = ins + [got.mailbox], outs + [got.mailbox_empty]
            sent = [] if arrivals else [ln for a in tr.actions if a.kind == SEND
                                        for ln in by_send.get((a.behaviour, _message(a)), [])]
            for full in itertools.product((False, True), repeat=len(sent)):
                extra_in = [ln.flight if f else ln.empty for ln, f in zip(sent, full)]
                net.add_transition(f"{v}/{tr.name}" + _variant(sent, full), ins + extra_in,
                                   outs + [ln.flight for ln in sent], actions=tr.actions,
                                   event=tr.event, timer=tr.timer, origin=tr.origin,
                                   label=tr.label)
                fnet.steps.append(Step("vehicle", v, t, got))
    for ln in fnet.links:
        _channel_transitions(fnet, ln, arrivals)
    return fnet


def _link(net: Net, ch: ChannelSpec, message: str, receiver: str) -> Link:
    base = f"channel {ch.name}.{message}→{receiver}"
    flight = net.add_place(f"{base} in flight", role=INNER)
    empty = net.add_place(f"{base} empty", role=INNER)
    mailbox = net.add_place(f"{base} mailbox", role=INNER)
    mailbox_empty = net.add_place(f"{base} mailbox empty", role=INNER)
    net.initial[empty] = 1
    net.initial[mailbox_empty] = 1
    return Link(ch.name, message, receiver, ch.lossy, flight, empty, mailbox, mailbox_empty)


def _channel_transitions(fnet: FleetNet, ln: Link, arrivals: bool) -> None:
    net, base = fnet.net, f"channel {ln.channel}.{ln.message}→{ln.receiver}"
    if arrivals:
        net.add_transition(f"{base}.arrive", [ln.mailbox_empty], [ln.mailbox],
                           label=f"{ln.message} arrives")
        fnet.steps.append(Step("arrive", link=ln))
        return
    net.add_transition(f"{base}.deliver", [ln.flight, ln.mailbox_empty],
                       [ln.empty, ln.mailbox], label=f"{ln.message} delivered")
    fnet.steps.append(Step("deliver", link=ln))
    net.add_transition(f"{base}.deliver.over", [ln.flight, ln.mailbox], [ln.empty, ln.mailbox],
                       label=f"{ln.message} delivered over an unread one")
    fnet.steps.append(Step("deliver", link=ln))
    if ln.lossy:
        net.add_transition(f"{base}.lose", [ln.flight], [ln.empty],
                           label=f"{ln.message} lost")
        fnet.steps.append(Step("lose", link=ln))


def _message(action: Action) -> str:
    """The message a send action carries."""
    return str(dict(action.params).get("message", ""))


def _variant(sent: list[Link], full: tuple[bool, ...]) -> str:
    """A send's copy's name suffix: which links already held a message in flight."""
    over = [ln.receiver for ln, f in zip(sent, full) if f]
    return f".over({','.join(over)})" if over else ""
