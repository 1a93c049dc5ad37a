"""A fleet run in one process: every vehicle's player on ONE simulated clock, each with its
own simulated vehicle, and the fleet's channels between them.

    from mcl.fleet import compile_fleet_file
    from mission import run_fleet, simulated_vehicle

    fleet = compile_fleet_file("missions/mcm.mcl")
    result = run_fleet(fleet, {name: simulated_vehicle(seed=i + 1)
                               for i, name in enumerate(fleet.vehicles)},
                       loss=0.3, seed=7, log_dir="out/runs/mcm")
    print(result.exit, {name: r.status for name, r in result.runs.items()})

Each vehicle's mission runs through :func:`mission.run_mission`, in a thread of its own, with
its own run log, time bound, stop handler and safe exit. The threads take turns: only one
runs at a time, and the next is always the vehicle whose next happening (a timer of its
player, an event of its simulated vehicle, a message due to it) is earliest, ties in the
fleet's order. So the vehicles share one simulated clock, a message is never delivered to a
vehicle that has already gone past its delivery time, and the same seeds give the same run.

A ``Send`` of a mission goes to its channel (the player's ``sender``), never to the vehicle;
the channel's model (:class:`mission.channels.ChannelModel`) decides its fate; a message due
at a vehicle reaches its player as the event ``CHANNEL.MESSAGE`` with data ``{**payload,
"sent": t}``, and its vehicle's modem, if it has one, hears it. Acoustic silence is not
``Link.lost``.

Each vehicle's run log holds its simulated vehicle's true pose once a second and its header
the scene it moved in (:mod:`mission.poses`), so that the logs alone draw the fleet's tracks.

Every exit is a safe exit for every vehicle: a stop from outside (``stop``: a signal) stops
all, each through its mission's abort; a vehicle whose run fails (its vehicle raised, a bug)
stops the others (their end records say ``how: "fleet"`` and which vehicle); each vehicle's
own time limit aborts it alone. Every log closes with its end record.
"""

from __future__ import annotations

import contextlib
import math
import random
import threading
import time
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from aal.messages import ActionMessage, EventMessage
from diagnostics import MclError
from mcl.analysis.fleet_verification import verify_fleet
from mcl.analysis.verification import verify_mission
from mcl.api import Compiled
from mcl.fleet import CompiledFleet
from petri.execution.player import Order
from petri.execution.signing import Signer

from mission.capabilities import check_capabilities
from mission.channels import (
    ChannelModel,
    ChannelRecord,
    InProcessCarrier,
    Message,
    Position,
)
from mission.exits import Exit
from mission.logwriter import LogUnwritable
from mission.poses import scene_of, track_of
from mission.run import NotVerified, RunResult, Stop, run_mission
from mission.vehicle import Vehicle

PACE_WAIT = 0.2  # wall s: the longest single wait of a fleet paced at wall time



@dataclass(frozen=True)
class FleetResult:
    """What a fleet run did: each vehicle's run, and what crossed the channels."""

    fleet: str
    runs: dict[str, RunResult]  # each vehicle's run, in the fleet's order
    channels: dict[str, dict[str, Any]]  # each channel's counts and median delay
    record: Path | None  # the channel record (None: none was written)
    record_failure: str = ""  # why the channel record is incomplete ("": it is whole)

    @property
    def exit(self) -> int:
        """The fleet's exit status: the worst of its vehicles' (docs/EXIT.md)."""
        return max((r.exit for r in self.runs.values()), default=int(Exit.OK))

    @property
    def time(self) -> float:
        """Mission time when the last vehicle's run ended."""
        return max((r.time for r in self.runs.values()), default=0.0)


class SharedClock:
    """One simulated clock for a fleet's threads: one runs at a time, the one whose next
    happening is earliest (ties: the fleet's order); a thread not yet at its vehicle waits
    for it, so that the start is the same whatever the threads' speed."""

    def __init__(self, names: list[str], speed: float | None = None) -> None:
        self.speed = speed  # the clock at this many times wall time (None: as fast as it can)
        self.wall0 = time.monotonic()  # the wall time of mission time 0
        self.cond = threading.Condition()
        self.order = {name: i for i, name in enumerate(names)}
        self.state = {name: "new" for name in names}  # new | waiting | running | gone
        self.wants: dict[str, Callable[[], float]] = {}
        self.holder: str | None = None

    def wait_turn(self, name: str, wanted: Callable[[], float]) -> None:
        """``name`` waits until its next happening, ``wanted()``, is the fleet's earliest."""
        with self.cond:
            self.state[name], self.wants[name] = "waiting", wanted
            if self.holder == name:
                self.holder = None
            self.pick()
            while self.holder != name:
                self.cond.wait()
            self.state[name] = "running"

    def leave(self, name: str) -> None:
        """``name``'s run is over (or never started): it takes no more turns."""
        with self.cond:
            self.state[name] = "gone"
            if self.holder == name:
                self.holder = None
            self.pick()

    def active(self, name: str) -> bool:
        with self.cond:
            return self.state[name] != "gone"

    def paced(self, target: float) -> float:
        """How far mission time may go towards ``target`` now: all of it, unless the clock
        is paced at wall time (``speed``); then it waits at most ``PACE_WAIT`` wall seconds,
        so that the runner holding the turn looks at a stop often."""
        if not self.speed:
            return target
        ahead = target / self.speed - (time.monotonic() - self.wall0)
        if ahead <= 0:
            return target
        time.sleep(min(ahead, PACE_WAIT))
        return min(target, (time.monotonic() - self.wall0) * self.speed)

    def pick(self) -> None:
        """Give the turn to the earliest waiting vehicle, once every vehicle has arrived."""
        if self.holder is not None or "new" in self.state.values():
            return
        waiting = [n for n, s in self.state.items() if s == "waiting"]
        if waiting:
            self.holder = min(waiting, key=lambda n: (self.wants[n](), self.order[n]))
            self.cond.notify_all()


class FleetAdapter:
    """One vehicle of the fleet as its runner sees it: its own adapter, with its turns on
    the shared clock and the messages due to it given as events."""

    simulated = True

    def __init__(self, name: str, inner: Any, clock: SharedClock, carrier: InProcessCarrier,
                 senders: list[str], modem: Any = None) -> None:
        self.name, self.inner, self.clock, self.carrier = name, inner, clock, carrier
        self.senders = senders  # the vehicles that send on a channel to this one
        self.modem = modem
        self.seq = 0  # the events given to the runner, renumbered in order
        # when its simulated vehicle next raises an event (None: it cannot say; its runner's
        # wait is then its next happening)
        self.peek: Callable[[], float | None] | None = getattr(
            getattr(inner, "stack", None), "next_time", None)

    def __enter__(self) -> FleetAdapter:
        self.inner.__enter__()
        self.clock.wait_turn(self.name, lambda: -math.inf)  # start in the fleet's order
        return self

    def __exit__(self, *exc: object) -> None:
        try:
            self.inner.__exit__(*exc)
        finally:
            self.carrier.undelivered(self.name, self.inner.now(), f"{self.name}'s run ended")
            self.clock.leave(self.name)

    def now(self) -> float:
        return float(self.inner.now())

    def send(self, action: ActionMessage) -> None:
        self.inner.send(action)

    def next_time(self, until: float) -> float:
        """This vehicle's next happening: ``until``, its vehicle's next event, a message."""
        times = [until]
        nxt = self.peek() if self.peek is not None else None
        if nxt is not None:
            times.append(nxt)
        due = self.carrier.next_due(self.name)
        if due is not None:
            times.append(due)
        return min(times)

    def receive(self, until: float) -> list[EventMessage]:
        self.clock.wait_turn(self.name, lambda: self.next_time(until))
        reached = self.clock.paced(self.next_time(until))
        events = [self.renumbered(e) for e in self.inner.receive(reached)]
        for at, msg in self.carrier.deliveries(self.name, self.inner.now()):
            data = {**msg.data, "sent": msg.sent}
            events.append(self.renumbered(EventMessage(0, at, msg.channel, msg.message, data)))
            if self.modem is not None:
                self.modem.heard(msg.channel, msg.message, data, at)
        return events

    def renumbered(self, event: EventMessage) -> EventMessage:
        self.seq += 1
        return EventMessage(self.seq, event.t, event.source, event.name, event.data)

    def idle(self) -> bool:
        """Nothing will come: its vehicle is idle, no message is in flight to it and no
        vehicle that sends to it is still running."""
        return (bool(self.inner.idle()) and self.carrier.next_due(self.name) is None
                and not any(self.clock.active(s) for s in self.senders if s != self.name))

    def confirm_off(self, names: list[str], timeout: float) -> str:
        check = getattr(self.inner, "confirm_off", None)
        return "not confirmed: this link cannot say" if check is None else str(
            check(names, timeout))

    def progress(self) -> dict[str, Any]:
        progress = getattr(self.inner, "progress", None)
        return progress() if callable(progress) else {}


@dataclass
class FleetStop:
    """Why the whole fleet stops: a stop from outside, or a vehicle that failed."""

    outside: Callable[[], Stop | str | None] | None
    failed: Stop | None = None
    lock: threading.Lock = field(default_factory=threading.Lock)

    def fail(self, name: str, why: str) -> None:
        with self.lock:
            if self.failed is None:
                self.failed = Stop(f"the fleet was stopped: {name} {why}", how="fleet")

    def request(self) -> Stop | str | None:
        asked = self.outside() if self.outside is not None else None
        return asked if asked is not None else self.failed


def where_of(vehicle: Vehicle) -> Callable[[], Position | None]:
    """Where ``vehicle`` is now: its modem says, else its simulated stack's true pose."""
    if vehicle.modem is not None:
        return vehicle.modem.position
    robot = getattr(vehicle.stack, "robot", None)
    if robot is None:
        return lambda: None
    return lambda: (float(robot.state.x), float(robot.state.y), float(robot.state.z))


def losses(fleet: CompiledFleet, loss: float | Mapping[str, float]) -> dict[str, float]:
    """Each channel's loss probability: one for every channel, or by channel (others 0)."""
    if isinstance(loss, Mapping):
        unknown = sorted(set(loss) - set(fleet.channels))
        if unknown:
            raise MclError(f"--loss {unknown[0]}=...: fleet {fleet.name} has no channel "
                           f"{unknown[0]!r}", hint="its channels: "
                           + ", ".join(fleet.channels), code="fleet-loss")
        return {name: float(loss.get(name, 0.0)) for name in fleet.channels}
    return {name: float(loss) for name in fleet.channels}


def run_fleet(fleet: CompiledFleet, vehicles: Mapping[str, Vehicle], *, loss: float |
              Mapping[str, float] = 0.0, seed: int = 1, log_dir: str | Path | None = None,
              header: Mapping[str, Any] | None = None,
              headers: Mapping[str, Mapping[str, Any]] | None = None,
              max_time: float | None = None,
              stop: Callable[[], Stop | str | None] | None = None, verify: bool = True,
              observers: Mapping[str, list[Callable[[Any], None]]] | None = None,
              signer: Signer | None = None,
              during: contextlib.AbstractContextManager[Any] | None = None,
              speed: float | None = None) -> FleetResult:
    """Run every vehicle of ``fleet`` to its end on ``vehicles`` (by name), one simulated
    clock for all (this module's doc). ``loss``: the loss probability of every LOSSY channel,
    or by channel name; ``seed``: the channels' random stream; ``log_dir``: a run log per
    vehicle (``NAME.jsonl``) and the channel record (``channels.jsonl``) go there;
    ``header``: what every vehicle's log header says, ``headers``: what one vehicle's says
    besides (its own seed), by name;
    ``observers``: each vehicle's extra observers (a timeline); ``speed``: the one clock
    runs at this many times wall time (1.0: ``--realtime``; None: as fast as it can); the
    rest as :func:`mission.run_mission`. Raises :class:`NotVerified` (a vehicle's mission not verified
    alone with its receptions as environment events, or a fleet property proved false; one
    the proof leaves undecided does not stop the run) or a capability refusal before
    anything runs."""
    names = list(fleet.vehicles)
    missing = [n for n in names if n not in vehicles]
    if missing:
        raise MclError(f"no vehicle given for {missing[0]} of fleet {fleet.name}",
                       code="fleet-vehicle")
    wall = [n for n in names if not getattr(vehicles[n].adapter, "simulated", False)]
    if wall:
        raise MclError(f"vehicle {wall[0]} of fleet {fleet.name} is not simulated: a fleet "
                       "in one process runs on simulated vehicles, on one simulated clock",
                       code="fleet-vehicle")
    by_channel = losses(fleet, loss)
    for name in names:  # refuse before anything is written or sent
        check_before(fleet.vehicles[name], vehicles[name], verify, list(fleet.channels))
    if verify:  # the fleet as a whole: a property proved false is refused
        fails = [r.name for r in verify_fleet(fleet).results
                 if r.status == "fails" and r.severity == "error"]
        if fails:
            raise NotVerified([f"fleet {fleet.name}: {name}" for name in fails])
    folder = Path(log_dir) if log_dir is not None else None
    record = open_record(folder / "channels.jsonl", fleet, seed, by_channel) \
        if folder is not None else None
    rng = random.Random(seed)
    models = {name: ChannelModel(c, by_channel[name], random.Random(rng.getrandbits(64)))
              for name, c in fleet.channels.items()}
    places = {name: where_of(vehicles[name]) for name in names}
    carrier = InProcessCarrier(fleet.channels, models, lambda n: places[n](), record)
    clock = SharedClock(names, speed)
    stops = FleetStop(stop)
    runs: dict[str, RunResult] = {}
    errors: dict[str, BaseException] = {}

    def one(name: str) -> None:
        try:
            about = {**(header or {}), **(headers or {}).get(name, {})}
            runs[name] = run_vehicle(name, fleet, vehicles[name], clock, carrier, stops,
                                     folder, about, max_time, observers, signer)
            if runs[name].status == "error":
                stops.fail(name, f"failed: {runs[name].reason}")
        except BaseException as exc:  # noqa: BLE001 - the others stop safely, then it goes on
            errors[name] = exc
            stops.fail(name, f"failed: {type(exc).__name__}: {exc}")
        finally:
            clock.leave(name)

    with during if during is not None else contextlib.nullcontext():
        threads = [threading.Thread(target=one, args=(n,), name=f"fleet-{n}", daemon=True)
                   for n in names]
        for thread in threads:
            thread.start()
        for thread in threads:
            while thread.is_alive():
                thread.join(0.2)  # the main thread stays free for signal handlers
        end = max((r.time for r in runs.values()), default=0.0)  # (still ``during``: a
        for name in names:  # signal now is a request nobody reads, not an interruption)
            carrier.undelivered(name, end, "the fleet's run ended")
        if record is not None:
            record.close(end, "every vehicle's run ended")
    if errors:
        raise next(iter(errors.values()))
    return FleetResult(fleet.name, {n: runs[n] for n in names}, carrier.summary(),
                       record.path if record is not None else None,
                       record.failure if record is not None else "")


def open_record(path: Path, fleet: CompiledFleet, seed: int, loss: dict[str, float]
                ) -> ChannelRecord:
    """The channel record, its header written: the fleet, the seed, the losses and the
    channels' declarations; one that cannot be written is :class:`LogUnwritable`."""
    try:
        return ChannelRecord(path, {
            "fleet": fleet.name, "seed": seed, "loss": loss, "channels": {
                c.name: {"sender": c.sender, "receivers": list(c.receivers),
                         "delay": [c.delay_min, c.delay_max], "interval": c.interval,
                         "lossy": c.lossy} for c in fleet.channels.values()}})
    except OSError as exc:
        raise LogUnwritable(path, exc) from None


def check_before(compiled: Compiled, vehicle: Vehicle, verify: bool,
                 channels: list[str]) -> None:
    """A vehicle's mission is refused before the fleet starts: not within what its vehicle
    declares, or not verified (with its receptions as environment events)."""
    said = vehicle.declares.declaration() if vehicle.declares is not None else None
    if said is not None:
        check_capabilities(compiled, said, channels)
    if verify:
        verdict = verify_mission(compiled, "auto")
        if not verdict.ok:
            raise NotVerified([f"{compiled.name}: {r.name}" for r in verdict.results
                               if not r.holds and r.severity == "error"])


def run_vehicle(name: str, fleet: CompiledFleet, vehicle: Vehicle, clock: SharedClock,
                carrier: InProcessCarrier, stops: FleetStop, folder: Path | None,
                header: Mapping[str, Any] | None, max_time: float | None,
                observers: Mapping[str, list[Callable[[Any], None]]] | None,
                signer: Signer | None) -> RunResult:
    """One vehicle's run, on its turns of the shared clock."""
    senders = [c.sender for c in fleet.channels.values() if name in c.receivers]
    adapter = FleetAdapter(name, vehicle.adapter, clock, carrier, senders, vehicle.modem)
    counter = iter(range(1 << 62))

    def send(order: Order) -> None:
        t = adapter.now()
        message = str(order.params.get("message", ""))
        data = (vehicle.modem.payload(order.behaviour, message, t)
                if vehicle.modem is not None else {})
        carrier.send(Message(order.behaviour, message, name, next(counter), t, dict(data)))

    wrapped = Vehicle(adapter, stack=vehicle.stack, declares=None, link=vehicle.link,
                      status=vehicle.status, summary=vehicle.summary, where=vehicle.where,
                      modem=vehicle.modem)
    scene = scene_of(vehicle)  # what it moves in, and its poses: mcl view's plan
    about = {**(header or {}), "fleet": fleet.name, "as": name,
             **({"scene": scene} if scene is not None else {})}
    log = folder / f"{name}.jsonl" if folder is not None else None
    return run_mission(fleet.vehicles[name], wrapped, log=log, header=about,
                       max_time=max_time, stop=stops.request, verify=False,
                       observers=(observers or {}).get(name, []), signer=signer, sender=send,
                       track=track_of(vehicle))

