"""The fleet's product net: every vehicle's net side by side, joined only by channel places.

A fleet is proved on one place/transition net (docs/METHODS.md, "Fleets: what is proved"):

- every vehicle's places and transitions, renamed ``VEHICLE/...`` (origins kept), except its
  external stop (``Mission.abort``): the product is the fleet left to itself, each vehicle's
  stop being proved on its own (``stop-safe``);
- for each channel, message and receiver a *link*: two places, ``in flight`` / ``empty``
  (one token between them: the net stays 1-safe);
- a sender's transition that carries ``Action("send", CHANNEL, (("message", M),))`` puts M in
  flight to every receiver (a second send while one is in flight overwrites it): one copy of
  the transition for each combination of the links' states, so that arcs stay unweighted;
- a delivery is what the player makes of it at run time (mission/fleet.py hands it to the
  player as the event ``"CHANNEL.M"``): heard by a Receive waiting for it at that moment —
  the Receive's ``ok`` transition also takes the message from flight — or *ignored* when none
  waits (``ignore``: in flight -> empty, enabled only while no Receive of it waits, read from
  a complement place of each waiting place); on a LOSSY channel, or one with an EVERY
  (a message closer than that to the previous one is dropped at run time), ``lose``
  empties it at any time.

Vehicles never share a transition (a one-way link at 0.5 Hz cannot carry a rendezvous). The
same construction with one vehicle and *arrivals* instead of senders (a message may come at
any moment) is the vehicle alone against its channels' contract: the
compositional route (mcl/analysis/fleet_compositional.py).
"""

from __future__ import annotations

import itertools
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

from petri.net import INNER, Action, Net
from petri.semantics import MISSION_ABORT, Semantics

if TYPE_CHECKING:
    from mcl.fleet import Channel, CompiledFleet

SEND = "send"  # the kind of Action a Send(CHANNEL, MESSAGE) task carries




@dataclass(frozen=True)
class Link:
    """One message of one channel on its way to one receiver: its two places, and the
    receiver's places where a Receive of it waits (``waiting``, in the product)."""

    channel: str
    message: str
    receiver: str
    lossy: bool
    flight: int
    empty: int
    waiting: tuple[int, ...] = ()
    interval: float = 0.0  # EVERY: a message closer than this to the previous is dropped

    @property
    def event(self) -> str:
        return f"{self.channel}.{self.message}"


@dataclass(frozen=True)
class Step:
    """What a product transition is: a vehicle's own transition (``vehicle``, ``original``:
    its index in that vehicle's net; ``link``: the message a Receive hears) or a channel's
    (``kind`` "ignore", "lose" or, when a vehicle is proved alone, "arrive"; ``link`` the
    link it moves)."""

    kind: str  # "vehicle" | "ignore" | "lose" | "arrive"
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
            lost = ("lost on its way to" if ln.lossy else
                    f"dropped (closer than EVERY {ln.interval:g} s to the previous one) for")
            what = {"ignore": f"reaches {ln.receiver}, where no Receive waits: ignored",
                    "lose": f"{lost} {ln.receiver}",
                    "arrive": f"on its way to {ln.receiver}"}[step.kind]
            return f"channel {ln.channel}: {ln.message} {what}"
        assert step.vehicle is not None
        tr = self.slices[step.vehicle].net.transitions[step.original]
        o = tr.origin
        where = f" {o.where()} {o.text}" if o is not None else f" {tr.name}"
        heard = f" (delivered: {step.link.event})" if step.link is not None else ""
        return f"{step.vehicle}{where}: {tr.label or tr.name}{heard}"


def product(fleet: CompiledFleet) -> FleetNet:
    """The fleet's product net (the module's doc)."""
    return _build(fleet, list(fleet.vehicles), arrivals=False)


def alone(fleet: CompiledFleet, vehicle: str) -> FleetNet:
    """``vehicle`` alone against its channels' contract: any message to it may be on its
    way at any moment (``arrive``), its sends go nowhere."""
    return _build(fleet, [vehicle], arrivals=True)


def _build(fleet: CompiledFleet, vehicles: list[str], arrivals: bool) -> FleetNet:
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
                    fnet.links.append(_link(net, ch, message, r, slices[r]))
    not_waiting = {p: net.add_place(f"{net.places[p].name} (not waiting)", role=INNER)
                   for p in sorted({p for ln in fnet.links for p in ln.waiting})}
    for p, bar in not_waiting.items():
        net.initial[bar] = 1 - net.initial.get(p, 0)
    by_event = {(ln.receiver, ln.event): ln for ln in fnet.links}
    by_send: dict[tuple[str, str], list[Link]] = {}
    for ln in fnet.links:
        by_send.setdefault((ln.channel, ln.message), []).append(ln)
    for v, s in slices.items():
        for t, tr in enumerate(s.net.transitions):
            if tr.event == MISSION_ABORT:
                continue
            ins, outs = _arcs(s, t, not_waiting)
            got = by_event.get((v, tr.event)) if tr.event is not None else None
            if got is not None:
                ins, outs = ins + [got.flight], outs + [got.empty]
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
        _channel_transitions(fnet, ln, arrivals, [not_waiting[p] for p in ln.waiting])
    return fnet


def _arcs(s: Slice, t: int, not_waiting: dict[int, int]) -> tuple[list[int], list[int]]:
    """A vehicle transition's arcs in the product, with the complement of each waiting place
    it empties (an output) or fills (an input)."""
    tr = s.net.transitions[t]
    ins = [s.first + p for p, w in tr.inputs for _ in range(w)]
    outs = [s.first + p for p, w in tr.outputs for _ in range(w)]
    for p in set(ins) - set(outs):
        if p in not_waiting:
            outs.append(not_waiting[p])
    for p in set(outs) - set(ins):
        if p in not_waiting:
            ins.append(not_waiting[p])
    return ins, outs


def _link(net: Net, ch: Channel, message: str, receiver: str, s: Slice) -> Link:
    base = f"channel {ch.name}.{message}→{receiver}"
    flight = net.add_place(f"{base} in flight", role=INNER)
    empty = net.add_place(f"{base} empty", role=INNER)
    net.initial[empty] = 1
    event = f"{ch.name}.{message}"
    waiting = tuple(sorted({s.first + p for tr in s.net.transitions if tr.event == event
                            for p, _ in tr.inputs}))
    return Link(ch.name, message, receiver, ch.lossy, flight, empty, waiting, ch.interval)


def _channel_transitions(fnet: FleetNet, ln: Link, arrivals: bool, idle: list[int]) -> None:
    """``ignore`` (read: no Receive of it waits), ``lose`` on a LOSSY channel, and when the
    vehicle is alone ``arrive``."""
    net, base = fnet.net, f"channel {ln.channel}.{ln.message}→{ln.receiver}"
    if arrivals:
        net.add_transition(f"{base}.arrive", [ln.empty], [ln.flight],
                           label=f"{ln.message} on its way")
        fnet.steps.append(Step("arrive", link=ln))
    net.add_transition(f"{base}.ignore", [ln.flight, *idle], [ln.empty, *idle],
                       label=f"{ln.message} ignored")
    fnet.steps.append(Step("ignore", link=ln))
    if ln.lossy or ln.interval > 0:  # lost, or dropped as too close to the previous one
        net.add_transition(f"{base}.lose", [ln.flight], [ln.empty],
                           label=f"{ln.message} {'lost' if ln.lossy else 'dropped'}")
        fnet.steps.append(Step("lose", link=ln))


def _message(action: Action) -> str:
    """The message a send action carries."""
    return str(dict(action.params).get("message", ""))


def _variant(sent: list[Link], full: tuple[bool, ...]) -> str:
    """A send's copy's name suffix: which links already held a message in flight."""
    over = [ln.receiver for ln, f in zip(sent, full) if f]
    return f".over({','.join(over)})" if over else ""
