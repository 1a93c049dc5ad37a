"""``mcl run FLEET.mcl``: a fleet's vehicles in one process, on one simulated clock
(docs/FLEET_RUN.md).

    mcl run FLEET.mcl [--loss P | --loss CHANNEL=P ...] [--seed N] [--log-dir DIR]
                      [--max-time SECONDS] [--realtime] [--mcap FILE] [--quiet]
                      [--no-verify]

Every vehicle of the fleet runs its mission on a simulated vehicle of its own (vehicle ``i``,
in the fleet's order, gets the seed ``N + i``, the vehicles of one simulated world ``N``, and
its log's header says its own seed, with the fleet's as ``fleet_seed``; the one its task library names in
:data:`SIMULATORS`, else the simulated Ictineu); the channels between them lose, drop and
delay messages as :class:`mission.channels.ChannelModel` says, seeded by ``N``. It prints
each vehicle's timeline (its name before each line), then each vehicle's end, its run log,
and each channel's figures: sent, delivered, lost, dropped, undelivered and the median delay.
The exit status is the worst of the vehicles' (docs/EXIT.md). Signals stop every vehicle
through its mission's abort, as for one mission.
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

from diagnostics import MclError, file_error
from mcl.fleet import CompiledFleet, compile_fleet_file
from mission.exits import Exit
from mission.fleet import FleetResult, run_fleet
from mission.mcap_channels import track_of_poses
from mission.mcap_export import Track, track_of_survey
from mission.mcm_vehicles import mcm_vehicles
from mission.run import NotVerified
from mission.vehicle import Vehicle
from petri.execution.runner import MissionClock
from petri.execution.signing import Signer

from app.outputs import check_output
from app.safe_exit import Output, ReportCut, Stops
from app.vehicles.kind import Invalid

SEEDS = 2**64  # vehicle i's seed is (N + i) mod 2**64 (unless a world's: N)
# a task library's file stem -> the simulated vehicle that has its behaviours (seed -> vehicle);
# a vehicle whose library is not here runs on the simulated Ictineu
SIMULATORS: dict[str, Callable[[int], Vehicle]] = {}
# task libraries whose vehicles share one simulated world, built together: (seed, the
# --inject faults) -> a vehicle per library stem (paper 003's ASV and UUV: docs/MCM.md)
WORLDS: dict[tuple[str, ...], Callable[[int, list[str]], dict[str, Vehicle]]] = {
    ("asv", "uuv"): mcm_vehicles,
}


def add_options(parser: argparse.ArgumentParser) -> None:
    """The options of ``mcl run`` that only a fleet takes."""
    parser.add_argument("--log-dir", metavar="DIR", default=None,
                        help="a fleet: the folder of its run logs (one per vehicle) and its "
                             "channel record; default out/runs/FLEET-TIME "
                             "(docs/FLEET_RUN.md)")
    parser.add_argument("--loss", action="append", default=[], type=loss_option,
                        metavar="P|CHANNEL=P",
                        help="a fleet: the probability that a message on a LOSSY channel is "
                             "lost, for every channel or for one (repeat it); default 0")


def loss_option(text: str) -> tuple[str | None, float]:
    """``--loss P`` or ``--loss CHANNEL=P``: a probability from 0 to 1, for every LOSSY
    channel or for the one named."""
    channel, _, value = text.rpartition("=")
    try:
        p = float(value)
    except ValueError:
        p = math.nan
    if not 0.0 <= p <= 1.0:
        raise argparse.ArgumentTypeError(f"{text[:40]!r}: the loss is a probability from 0 "
                                         "to 1 (e.g. --loss 0.3 or --loss guide=0.3)")
    if channel == "" and "=" in text:
        raise argparse.ArgumentTypeError(f"{text[:40]!r}: name the channel before '='")
    return (channel or None), p


def losses(fleet: CompiledFleet, given: list[tuple[str | None, float]]
           ) -> float | dict[str, float]:
    """What ``--loss`` says for ``fleet``: one probability, or one per channel (the others
    0). A channel the fleet has not got, or one that is not LOSSY, is refused (exit 2)."""
    if not given:
        return 0.0
    every = [p for name, p in given if name is None]
    named = {name: p for name, p in given if name is not None}
    if every and named:
        raise file_error("--loss", "--loss P and --loss CHANNEL=P together: give one or the "
                         "other", "e.g. --loss 0.3, or --loss guide=0.3", "fleet-loss")
    for name in named:
        channel = fleet.channels.get(name)
        if channel is None:
            raise file_error("--loss", f"--loss {name}=...: fleet {fleet.name} has no channel "
                             f"{name!r}", "its channels: " + ", ".join(fleet.channels),
                             "fleet-loss")
        if not channel.lossy:
            raise file_error("--loss", f"--loss {name}=...: channel {name} is not LOSSY, so "
                             "it loses nothing", f"declare it LOSSY at {channel.origin.where()}"
                             " to run it with losses", "fleet-loss")
    if every and not any(c.lossy for c in fleet.channels.values()) and every[-1] > 0:
        print(f"mcl run: warning: --loss {every[-1]:g}: no channel of fleet {fleet.name} is "
              "LOSSY, so nothing is lost", file=sys.stderr)
    return every[-1] if every else named


def vehicles_for(fleet: CompiledFleet, seed: int, inject: list[str] | None = None
                 ) -> dict[str, Vehicle]:
    """A simulated vehicle for each of the fleet's vehicles (this module's doc): those whose
    libraries make one of :data:`WORLDS` are built together, in one world, with the
    ``--inject`` faults (a bad one, or faults with no such world: exit 2)."""
    from mission.simulated import simulated_vehicle  # here for start-up speed

    chosen: dict[str, Vehicle] = {}
    for build, owner in worlds_of(fleet):
        try:
            built = build(seed, list(inject or []))
        except ValueError as exc:  # as for one vehicle: --inject FAULT: error: ...
            raise Invalid(f"--inject {exc} (docs/MCM.md)") from None
        chosen.update({owner[stem]: v for stem, v in built.items()})
    if inject and not chosen:
        raise Invalid("--inject: not for this fleet: its vehicles share no simulated world "
                      "that takes faults (docs/MCM.md); leave it out")
    own = seeds_for(fleet, seed)
    for name, compiled in fleet.vehicles.items():
        if name in chosen:
            continue
        stems = [Path(u.library).stem for u in compiled.mission.uses]
        make = next((SIMULATORS[s] for s in stems if s in SIMULATORS), None)
        chosen[name] = make(own[name]) if make is not None else simulated_vehicle(seed=own[name])
    return chosen


def worlds_of(fleet: CompiledFleet
              ) -> list[tuple[Callable[[int, list[str]], dict[str, Vehicle]], dict[str, str]]]:
    """The simulated worlds (:data:`WORLDS`) the fleet's vehicles make, each with its
    builder and which vehicle has each of its libraries (stem -> vehicle's name)."""
    stems = {name: [Path(u.library).stem for u in compiled.mission.uses]
             for name, compiled in fleet.vehicles.items()}
    found = []
    for together, build in WORLDS.items():
        owner = {stem: name for name, own in stems.items() for stem in own if stem in together}
        if set(owner) == set(together):
            found.append((build, owner))
    return found


def seeds_for(fleet: CompiledFleet, seed: int) -> dict[str, int]:
    """Each vehicle's own seed, which its log's header says: the fleet's ``seed`` for the
    vehicles of a simulated world (built together from it), ``seed + i`` (mod 2**64) for
    vehicle ``i`` of the fleet's order otherwise."""
    together = {name for _, owner in worlds_of(fleet) for name in owner.values()}
    return {name: seed if name in together else (seed + i) % SEEDS
            for i, name in enumerate(fleet.vehicles)}


def run(args: argparse.Namespace, signer: Signer | None, timeline: Callable[..., Any]) -> int:
    """``mcl run FLEET.mcl ...`` (options already parsed by app/run.py); ``timeline``: makes
    one mission's timeline, ``timeline(compiled, clock, out)`` (app/run.py's)."""
    if args.vehicle != "sim":
        raise file_error("--vehicle", f"--vehicle {args.vehicle}: a fleet runs in one process "
                         "on simulated vehicles", "leave --vehicle out", "fleet-vehicle")
    if args.log is not None:
        raise file_error("--log", "--log: a fleet writes one run log per vehicle and a "
                         "channel record", "give a folder with --log-dir DIR", "fleet-log")
    for option in ("param", "params", "tasks"):
        if getattr(args, option):
            raise file_error(f"--{option}", f"--{option}: not for a fleet (each VEHICLE says "
                             "its own USES and PARAM)", "leave it out", "fleet-option")
    if args.foxglove:
        raise file_error("--foxglove", "--foxglove: not for a fleet yet (one mission's run "
                         "only)", "leave it out", "fleet-option")
    if args.mcap is not None:
        check_output(args.mcap, "--mcap")
    fleet = compile_fleet_file(args.mission, require_values=True)
    for d in fleet.warnings:
        print(d.format(), file=sys.stderr)
    loss = losses(fleet, args.loss)
    folder = Path(args.log_dir) if args.log_dir else Path("out/runs") / (
        f"{Path(args.mission).stem}-{time.strftime('%Y%m%d-%H%M%S')}")
    out = Output()
    width = max(len(n) for n in fleet.vehicles)
    timelines: dict[str, list[Callable[[Any], None]]] = {}
    if not args.quiet:
        timelines = {name: [timeline(compiled, MissionClock(), Named(out, name, width))]
                     for name, compiled in fleet.vehicles.items()}
    header = {"file": args.mission, "vehicle": "sim", "fleet_seed": args.seed,
              "inject": args.inject}
    own = {name: {"seed": s} for name, s in seeds_for(fleet, args.seed).items()}
    stops = Stops(("SIGINT", "SIGTERM", "SIGHUP"))
    try:
        vehicles = vehicles_for(fleet, args.seed, args.inject)
        result = run_fleet(fleet, vehicles, loss=loss, seed=args.seed,
                           log_dir=folder, header=header, headers=own,
                           max_time=args.max_time,
                           stop=stops.request, verify=not args.no_verify,
                           observers=timelines, signer=signer, during=stops,
                           speed=1.0 if args.realtime else None)
    except NotVerified as exc:
        stops.restore()
        print(f"{args.mission}: not verified ({', '.join(exc.failed)}): refusing to run it\n"
              f"  hint: see 'mclc {args.mission}'; --no-verify runs it anyway", file=sys.stderr)
        return Exit.FAILED
    except BaseException:
        stops.restore()
        raise
    try:  # a signal now only cuts the report short: the end records stand
        summary(args.mission, fleet, result, out, vehicles)
        if args.mcap is not None:
            write_mcap(Path(args.mcap), result, vehicles, out)
    except ReportCut as cut:
        print(cut.line(), file=sys.stderr)
    finally:
        stops.restore()
    return result.exit


def write_mcap(path: Path, result: FleetResult, vehicles: dict[str, Vehicle], out: Output
               ) -> None:
    """``--mcap``: the fleet's run as one MCAP file, from its logs and channel record once
    written: each vehicle under ``/NAME`` with its simulated track, the channels under
    ``/channel/NAME`` (docs/MCAP.md); why not, on one line."""
    from app.export import export_fleet  # here for start-up speed: only a run that asks

    logs = [r.log for r in result.runs.values() if r.log is not None]
    try:
        written = export_fleet([Path(log) for log in logs], path, images=False,
                               record=result.record, tracks=tracks_of(vehicles))
    except MclError as exc:
        print(f"mcl run: --mcap {path}: not written: {exc.format().splitlines()[0]}",
              file=sys.stderr)
        return
    out.say(f"  mcap: {written.line()}")


def tracks_of(vehicles: dict[str, Vehicle]) -> dict[str, Track]:
    """Each simulated vehicle's track, by name: the simulated Ictineu's survey, or the true
    poses a vehicle of paper 003 keeps; none for a vehicle that keeps neither."""
    tracks = {}
    for name, vehicle in vehicles.items():
        survey = getattr(vehicle.stack, "survey", None)
        poses = getattr(vehicle.modem, "track", None)
        if survey is not None:
            tracks[name] = track_of_survey(survey)
        elif isinstance(poses, list):
            tracks[name] = track_of_poses(poses)
    return tracks


class Named:
    """An output that puts a vehicle's name before each line of its timeline."""

    def __init__(self, out: Output, name: str, width: int) -> None:
        self.out, self.name, self.width = out, name, width

    @property
    def closed(self) -> bool:
        return self.out.closed

    def say(self, text: str) -> None:
        self.out.say(f"{self.name:<{self.width}} {text}")


def summary(mission: str, fleet: CompiledFleet, result: FleetResult, out: Output,
            vehicles: dict[str, Vehicle] | None = None) -> None:
    """Each vehicle's end, its figures (a vehicle that sums itself up: paper 003's against
    ground truth, docs/MCM.md) and run log, then each channel's figures."""
    out.say(f"{mission}: fleet {fleet.name}, {len(result.runs)} vehicles, ended after "
            f"{result.time:.1f} s of mission time")
    for name, r in result.runs.items():
        out.say(f"  {name}: mission {r.mission} ended {r.status.upper()} after {r.time:.1f} s "
                f"({r.firings} firings)" + (f": {r.reason}" if r.reason else ""))
        if r.status not in ("ok", "fail") or r.switched_off:
            out.say(f"    switched off: {', '.join(r.switched_off) or 'nothing was on'}; "
                    f"{r.confirmed}")
        sums = (vehicles or {}).get(name)
        for key, value in (sums.summary.summary() if sums and sums.summary else {}).items():
            out.say(f"    {key}: {value}")
        out.say(f"    run log: {r.log}")
    for name, c in result.channels.items():
        spec = fleet.channels[name]
        delay = c["median_delay"]
        out.say(f"  channel {name} ({spec.sender} -> {', '.join(spec.receivers)}): sent "
                f"{c['sent']}, delivered {c['delivered']}, lost {c['lost']}, dropped "
                f"{c['dropped']}, undelivered {c['undelivered']}; median delay "
                + (f"{delay:.2f} s" if delay is not None else "-"))
    out.say(f"  channel record: {result.record}" + (f" (incomplete: {result.record_failure})"
                                                     if result.record_failure else ""))
