"""``mcl run FLEET.mcl --as NAME --vehicle zenoh:ENDPOINT``: one vehicle of a fleet in this
process, its channels over Zenoh, the other vehicles in other processes or on other machines
(docs/FLEET_ZENOH.md).

    mcl vehicle --zenoh tcp/0.0.0.0:7447 --name asv [--fleet mcm.mcl --users ...]
    mcl vehicle --zenoh tcp/0.0.0.0:7448 --name uuv [--fleet mcm.mcl --users ...]
    mcl run mcm.mcl --as asv --vehicle zenoh:tcp/ASV:7447
    mcl run mcm.mcl --as uuv --vehicle zenoh:tcp/UUV:7448 --fleet-vehicle asv=tcp/ASV:7447

The player of vehicle NAME runs its mission on its vehicle over Zenoh (``zenoh_link``), as
``mcl run M.mcl --vehicle zenoh:...`` does, and its channels go over Zenoh
(:class:`vehicle_adapters.zenoh_channels.ZenohCarrier`): a ``Send`` is put through its own
vehicle; a message on a channel to it is heard through the sender's vehicle, which
``--fleet-vehicle SENDER=ENDPOINT`` names (one for each vehicle that sends to NAME). The
channel's model (mission/channels.py, seeded by ``--seed``, ``--loss`` as for a fleet in one
process) decides each message's fate at the receiver, with the sender's position (in the
message) and its own (its navigator's telemetry). The run log (``NAME.jsonl``) and this
vehicle's channel record (``channels-NAME.jsonl``: what it sent, and the fate of what it heard)
go to ``--log-dir``. ``mcl vehicle --fleet FLEET.mcl`` lets only a channel's sender put on it
(docs/ZENOH_SECURITY.md).
"""

from __future__ import annotations

import argparse
import json
import random
import sys
import threading
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

from aal.messages import ActionMessage, Declaration, EventMessage
from aal.zenoh import check_endpoint, fleet_vehicle, keys, payload_text, zenoh_config
from aal.zenoh_security import Security
from diagnostics import file_error
from mcl.analysis.fleet_verification import verify_fleet
from mcl.api import Compiled
from mcl.fleet import CompiledFleet, compile_fleet_file
from mission.capabilities import check_capabilities
from mission.channels import ChannelModel, ChannelRecord, Message
from mission.exits import Exit
from mission.fleet import losses as channel_losses
from mission.run import NotVerified, NoVehicle, RunResult, run_mission
from mission.vehicle import Vehicle
from petri.execution.player import Order
from petri.execution.runner import MissionClock
from petri.execution.signing import Signer
from vehicle_adapters import zenoh_modem as modem
from vehicle_adapters.zenoh_channels import ChannelUnreachable, Position, ZenohCarrier, channel_key
from vehicle_adapters.zenoh_link import ZenohVehicle

from app import zenoh_options
from app.safe_exit import Output, Stops

MATCH_TIMEOUT = 5.0  # wall s: how long a sender waits for its receivers to listen


def add_options(parser: Any) -> None:
    """``--as`` and ``--fleet-vehicle`` (on ``mcl run``)."""
    parser.add_argument("--as", dest="as_", metavar="NAME", default=None,
                        help="a fleet: run only vehicle NAME, on --vehicle zenoh:ENDPOINT, its "
                             "channels over Zenoh (docs/FLEET_ZENOH.md)")
    parser.add_argument("--fleet-vehicle", action="append", default=[],
                        metavar="NAME=ENDPOINT",
                        help="with --as: the Zenoh endpoint of another vehicle of the fleet "
                             "that sends on a channel to this one (repeat it)")


def endpoints(fleet: CompiledFleet, me: str, given: list[str]) -> dict[str, str]:
    """``--fleet-vehicle NAME=ENDPOINT``, checked: each a vehicle of the fleet but ``me``, and
    one for every vehicle that sends to ``me``; an MclError naming the option otherwise."""
    found: dict[str, str] = {}
    for text in given:
        try:
            name, endpoint = fleet_vehicle(text)
        except ValueError as exc:
            raise file_error(fleet.source.name, f"--fleet-vehicle {text[:80]}: {exc}",
                             code="fleet-vehicle") from None
        if name not in fleet.vehicles or name == me:
            raise file_error(fleet.source.name, f"--fleet-vehicle {name}=...: not another "
                             f"vehicle of fleet {fleet.name}", "its vehicles: "
                             + ", ".join(fleet.vehicles), "fleet-vehicle")
        found[name] = endpoint
    missing = sorted({c.sender for c in fleet.channels.values() if me in c.receivers}
                     - set(found))
    if missing:
        raise file_error(fleet.source.name, f"{me} hears {', '.join(missing)} (its channels "
                         "to " + me + "): say where with --fleet-vehicle "
                         f"{missing[0]}=ENDPOINT", "the endpoint its 'mcl vehicle' listens on",
                         "fleet-vehicle")
    return found


def models(fleet: CompiledFleet, loss: float | dict[str, float], seed: int
           ) -> dict[str, ChannelModel]:
    """Each channel's model as a fleet run in one process makes it (mission/fleet.py): one
    random stream per channel, drawn in the fleet's order from ``seed``, so that the same seed
    gives the same fates in one process and across processes (for a channel to one
    receiver)."""
    by_channel = channel_losses(fleet, loss)
    rng = random.Random(seed)
    return {name: ChannelModel(c, by_channel[name], random.Random(rng.getrandbits(64)))
            for name, c in fleet.channels.items()}


def sent_keys(path: str, name: str) -> tuple[str, ...]:
    """``mcl vehicle --fleet FLEET.mcl --name NAME``: the keys of the channels NAME sends on,
    the ones its player may put on (docs/ZENOH_SECURITY.md); an MclError if the file is not
    a fleet or has no vehicle NAME."""
    fleet = compile_fleet_file(path)
    if name not in fleet.vehicles:
        raise file_error(path, f"--name {name}: fleet {fleet.name} has no vehicle {name!r}",
                         "its vehicles: " + ", ".join(fleet.vehicles), "fleet-vehicle")
    return tuple(channel_key(fleet.name, c.name) for c in fleet.sends(name))


class Member:
    """One vehicle of a fleet as its runner sees it: its Zenoh vehicle, with the messages
    due to it given as events ``CHANNEL.MESSAGE`` (data: the payload and ``sent``)."""

    def __init__(self, name: str, inner: ZenohVehicle) -> None:
        self.name, self.inner = name, inner
        self.carrier: ZenohCarrier[Message]  # given once made (it asks this one's position)
        self.seq = 0  # the events given to the runner, renumbered in order
        self.lock = threading.Lock()
        self.where: Position | None = None  # the navigator's last position
        self.navigator: Any = None
        self.began: float | None = None  # its clock at the first receive: the mission runs

    def __enter__(self) -> Member:
        self.inner.__enter__()
        if self.inner.session is not None:
            self.navigator = self.inner.session.declare_subscriber(
                f"{keys(self.name)['telemetry']}/navigator", self.on_navigator)
        return self

    def __exit__(self, *exc: object) -> None:
        if self.navigator is not None:
            try:
                self.navigator.undeclare()
            except Exception:  # already gone with the session
                pass
        self.carrier.undelivered(self.inner.now(), f"{self.name}'s run ended")
        self.inner.__exit__(*exc)

    def on_navigator(self, sample: Any) -> None:
        try:
            d = json.loads(payload_text(sample))
            where = (float(d["x"]), float(d["y"]), float(d["z"]))
        except (ValueError, KeyError, TypeError):
            return
        with self.lock:
            self.where = where

    def position(self) -> Position | None:
        with self.lock:
            return self.where

    def now(self) -> float:
        return float(self.inner.now())

    def send(self, action: ActionMessage) -> None:
        self.inner.send(action)

    def receive(self, until: float) -> list[EventMessage]:
        due = self.carrier.next_due()
        events = [self.renumbered(e) for e in self.inner.receive(
            until if due is None else min(until, due))]
        if self.began is None:  # the runner asks only once the mission has started
            self.began = self.inner.now()
        for at, msg in self.carrier.deliveries(self.name, self.inner.now(), self.began):
            data = {**msg.data, "sent": msg.sent}
            if self.inner.session is not None and not self.inner.lost:
                # its vehicle's modem hears it (the UUV's fix) before the player acts on it
                modem.heard(self.inner.session, self.name, msg.channel, msg.message, data, at)
            events.append(self.renumbered(EventMessage(0, at, msg.channel, msg.message, data)))
        return events

    def renumbered(self, event: EventMessage) -> EventMessage:
        self.seq += 1
        return EventMessage(self.seq, event.t, event.source, event.name, event.data)

    def idle(self) -> bool:
        return False  # a remote vehicle, and other vehicles, may always say something

    def confirm_off(self, names: list[str], timeout: float) -> str:
        return self.inner.confirm_off(names, timeout)

    def progress(self) -> dict[str, Any]:
        return self.inner.progress()


def run(args: argparse.Namespace, signer: Signer | None, timeline: Callable[..., Any],
        loss: Callable[[CompiledFleet, Any], float | dict[str, float]] | None = None) -> int:
    """``mcl run FLEET.mcl --as NAME ...`` (options parsed by app/run.py); ``timeline``:
    makes the mission's timeline, ``timeline(compiled, clock, out, progress)``; ``loss``:
    reads ``--loss`` for the fleet (app/fleet_run.py; None: no loss)."""
    fleet, me, endpoint = checked(args)
    others = endpoints(fleet, me, args.fleet_vehicle)
    compiled = fleet.vehicles[me]
    for d in compiled.warnings:
        print(d.format(), file=sys.stderr)
    if not args.no_verify:  # the fleet as a whole, as in one process (mission/fleet.py)
        fails = [r.name for r in verify_fleet(fleet).results
                 if r.status == "fails" and r.severity == "error"]
        if fails:
            print(f"{args.mission}: fleet {fleet.name} not verified ({', '.join(fails)}): "
                  f"refusing to run it\n  hint: see 'mclc {args.mission}'; --no-verify runs "
                  "it anyway", file=sys.stderr)
            return Exit.FAILED
    player = security(args, endpoint, "player")
    folder = Path(args.log_dir) if args.log_dir else Path("out/runs") / (
        f"{Path(args.mission).stem}-{me}-{time.strftime('%Y%m%d-%H%M%S')}")
    by_channel = loss(fleet, args.loss) if loss is not None else 0.0
    record = ChannelRecord(folder / f"channels-{me}.jsonl", {
        "fleet": fleet.name, "as": me, "seed": args.seed,
        "loss": channel_losses(fleet, by_channel), "channels": {
            c.name: {"sender": c.sender, "receivers": list(c.receivers),
                     "delay": [c.delay_min, c.delay_max], "interval": c.interval,
                     "lossy": c.lossy} for c in fleet.channels.values()}})
    zv = ZenohVehicle(endpoint, me, security=player, scouting=args.scouting)
    member = Member(me, zv)
    carrier: ZenohCarrier[Message] = ZenohCarrier(
        fleet.name, me, fleet.channels, make=Message,
        models={n: m for n, m in models(fleet, by_channel, args.seed).items()
                if me in fleet.channels[n].receivers},
        clock=zv.now, position=member.position,
        record=lambda line: record.write(rounded(line)),
        publish=zenoh_config(endpoint, connect=True, security=player, role="player"),
        subscribe={s: zenoh_config(e, "client", connect=True, role="observer",
                                   security=security(args, e, "observer"))
                   for s, e in others.items()})
    member.carrier = carrier
    out = Output()
    try:
        with carrier:
            if fleet.sends(me) and not carrier.wait_matched(MATCH_TIMEOUT):
                print(f"mcl run: warning: {me}: no receiver listens yet on "
                      + ", ".join(c.name for c in fleet.sends(me))
                      + f" after {MATCH_TIMEOUT:g} s: what is sent before they do is lost",
                      file=sys.stderr)
            result = play(args, compiled, member, zv, endpoint, folder, signer, timeline,
                          out, fleet)
    except ChannelUnreachable as exc:
        print(f"mcl run: {exc}", file=sys.stderr)
        return Exit.NO_VEHICLE
    finally:
        record.close(zv.now(), f"{me}'s run ended")
    if isinstance(result, int):
        return result
    report(args.mission, me, result, carrier, record.path, zv, out)
    return result.exit


def checked(args: argparse.Namespace) -> tuple[CompiledFleet, str, str]:
    """The fleet, the vehicle ``--as`` names and its endpoint; an MclError naming the option
    that does not fit."""
    if not args.vehicle.startswith("zenoh:"):
        raise file_error(args.mission, f"--as {args.as_}: one vehicle of a fleet runs on a vehicle "
                         f"over Zenoh, not on --vehicle {args.vehicle}",
                         "give --vehicle zenoh:ENDPOINT (its 'mcl vehicle --name "
                         f"{args.as_}'), or leave --as out to run the fleet in one process",
                         "fleet-as")
    if args.log is not None:
        raise file_error(args.mission, "--log: a fleet's vehicle writes its run log and its "
                         "channel record", "give a folder with --log-dir DIR", "fleet-log")
    for option in ("param", "params", "tasks", "inject"):
        if getattr(args, option, None):
            raise file_error(args.mission, f"--{option}: not for a fleet (each VEHICLE says "
                             "its own USES and PARAM)", "leave it out", "fleet-option")
    fleet = compile_fleet_file(args.mission, require_values=True)
    if args.as_ not in fleet.vehicles:
        raise file_error(args.mission, f"--as {args.as_}: fleet {fleet.name} has no vehicle "
                         f"{args.as_!r}", "its vehicles: " + ", ".join(fleet.vehicles),
                         "fleet-as")
    try:
        endpoint = check_endpoint(args.vehicle.partition(":")[2])
    except ValueError as exc:
        raise file_error(args.mission, f"--vehicle {args.vehicle}: {exc}",
                         code="fleet-as") from None
    return fleet, args.as_, endpoint


def security(args: argparse.Namespace, endpoint: str, role: str) -> Security:
    """The credentials of this player toward ``endpoint`` (its own vehicle's, or a sender's
    vehicle's), from the security options; an MclError naming the option."""
    try:
        return zenoh_options.from_args(
            argparse.Namespace(**{**vars(args), "vehicle": f"zenoh:{endpoint}"}), role)
    except ValueError as exc:
        raise file_error(args.mission, str(exc), code="zenoh-security") from None


def rounded(line: dict[str, Any]) -> dict[str, Any]:
    return {k: round(v, 6) if isinstance(v, float) else v for k, v in line.items()}


class Declares:
    """The vehicle's own word on what it can do, checked against the mission with the fleet's
    channels taken out (they carry Send and Receive, not the vehicle); it then says None, so
    that run_mission does not check again without them."""

    def __init__(self, zv: ZenohVehicle, compiled: Compiled, channels: list[str]) -> None:
        self.zv, self.compiled, self.channels = zv, compiled, channels

    def declaration(self) -> Declaration | None:
        said = self.zv.declaration()
        if said is not None:
            check_capabilities(self.compiled, said, self.channels)
        return None


def play(args: argparse.Namespace, compiled: Compiled, member: Member, zv: ZenohVehicle,
         endpoint: str, folder: Path, signer: Signer | None, timeline: Callable[..., Any],
         out: Output, fleet: CompiledFleet) -> RunResult | int:
    """The mission run on ``member`` (its signals, its timeline); an exit status when it was
    refused before it started."""
    seq = iter(range(1 << 62))

    clock = MissionClock()

    def send(order: Order) -> None:
        t = clock.vehicle(order.t)  # the vehicle's clock at the Send, as its log says it
        where = member.position()
        message = str(order.params.get("message", ""))
        data: dict[str, Any] = {"position": list(where)} if where is not None else {}
        if zv.session is not None:  # what its vehicle's modem says the message carries
            data.update(modem.payload(zv.session, member.name, order.behaviour, message, t))
        member.carrier.send(Message(order.behaviour, message, member.name, next(seq), t, data))

    chosen = Vehicle(member, declares=Declares(zv, compiled, list(fleet.channels)), link=zv, status=zv,
                     where=f"zenoh:{endpoint}")
    header = {"file": args.mission, "vehicle": args.vehicle, "seed": args.seed,
              "fleet": fleet.name, "as": member.name}
    stops = Stops(("SIGINT", "SIGTERM", "SIGHUP"))
    try:
        return run_mission(
            compiled, chosen, log=folder / f"{member.name}.jsonl", header=header,
            max_time=args.max_time, stop=stops.request, verify=not args.no_verify,
            clock=clock, end_note=out.note, during=stops, signer=signer, sender=send,
            observers=[] if args.quiet else [timeline(compiled, clock, out, zv.progress)],
            waiting=lambda where, s: print(f"mcl run: waiting for the vehicle at {where} "
                                           f"({s:.0f} s)", file=sys.stderr, flush=True))
    except NoVehicle as exc:
        print(f"mcl run: {exc}", file=sys.stderr)
        return Exit.NO_VEHICLE
    except NotVerified as exc:
        print(f"{args.mission}: {member.name} not verified ({', '.join(exc.failed)}): "
              f"refusing to run it\n  hint: see 'mclc {args.mission}'; --no-verify runs it "
              "anyway", file=sys.stderr)
        return Exit.FAILED
    finally:
        stops.restore()


def report(mission: str, me: str, result: RunResult, carrier: ZenohCarrier[Message],
           record: Path, zv: ZenohVehicle, out: Output) -> None:
    """How the run ended, its log, and what crossed its channels."""
    out.say(f"{mission}: {me}: mission {result.mission} ended {result.status.upper()} after "
            f"{result.time:.1f} s of mission time ({result.firings} firings)"
            + (f": {result.reason}" if result.reason else ""))
    if result.status not in ("ok", "fail") or result.switched_off:
        out.say(f"  switched off: {', '.join(result.switched_off) or 'nothing was on'}; "
                f"{result.confirmed}")
    out.say(f"  run log: {result.log}")
    c = carrier.summary()
    out.say(f"  channels: sent {c['sent']}; heard {c['received']}: delivered "
            f"{c['delivered']}, lost {c['lost']}, dropped {c['dropped']}, undelivered "
            f"{c['undelivered']}, refused {c['refused']}")
    out.say(f"  channel record: {record}")
    out.say(f"  link: {zv.sent} actions sent, {zv.received} events received"
            + (f", lost: {zv.lost_reason}" if zv.lost else ""))

