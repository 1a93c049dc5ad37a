"""``mclc FLEET.mcl``: compile a fleet and verify each vehicle's mission.

Every vehicle's mission passes every single-vehicle property of ``mclc`` with its receptions
(``CHANNEL.MESSAGE``) as events of its environment: each may come at any time, or never,
exactly as a behaviour's event (docs/LANGUAGE.md, "Fleets"). The text report lists each
vehicle's properties under its name; the JSON report is the fleet's, with one report per
vehicle (the shape of a single mission's) under ``vehicles``.

In a fleet, ``--param VEHICLE.NAME=VALUE`` gives a vehicle's parameter; each vehicle's task
library is its own ``USES`` (``--tasks`` is refused), and the net outputs (``--dot``, ...)
take one mission's net (refused too).
"""

from __future__ import annotations

import argparse
from typing import Any

from diagnostics import MclError, Source, Span, read_source
from mcl.api import parse_params
from mcl.fleet import CompiledFleet, Params, compile_fleet_source

from app.fleet_proof import prove_fleet, vehicle_method
from app.mission_report import SEVERITY, verify_and_report
from mission.exits import Exit

NET_OUTPUTS = (("dot", "--dot"), ("dot_tasks", "--dot-tasks"), ("pnml", "--pnml"),
               ("net_json", "--net-json"), ("graphml", "--graphml"))


def check_fleet(path: str | Source, args: argparse.Namespace, fmt: str
                ) -> tuple[Exit, dict[str, Any]]:
    """Compile the fleet at ``path`` (or read already: a pipe is read once) and verify each
    vehicle: the worst status and the report."""
    source = path if isinstance(path, Source) else read_source(path)
    path = source.name
    _refuse_single_mission_options(path, args)
    fleet = compile_fleet_source(source, fleet_params(args.param), require_values=False)
    report = fleet_summary(fleet)
    if fmt == "text":
        n, c = len(fleet.vehicles), len(fleet.channels)
        print(f"{path}: fleet {fleet.name}: {n} vehicle{'s' * (n != 1)}, "
              f"{c} channel{'s' * (c != 1)}")
    status = Exit.OK
    each = argparse.Namespace(**{**vars(args), "method": vehicle_method(args.method)})
    for name, compiled in fleet.vehicles.items():
        one, vehicle_report = verify_and_report(
            compiled, each, fmt, title=f"vehicle {name}" + (
                f": mission {compiled.mission.name}" if compiled.mission.name else ""),
            part=name)
        vehicle_report["vehicle"] = name
        report["vehicles"].append(vehicle_report)
        status = max(status, one, key=SEVERITY.index)
    if not args.no_verify:  # the fleet's own properties (app/fleet_proof.py)
        one, report["fleet_properties"] = prove_fleet(fleet, args, fmt)
        status = max(status, one, key=SEVERITY.index)
    report["status"] = _status(status)
    return status, report


def _status(status: Exit) -> str:
    return {Exit.OK: "verified", Exit.FAILED: "property-fails",
            Exit.UNDECIDED: "undecided"}.get(status, "compiled")


def fleet_summary(fleet: CompiledFleet) -> dict[str, Any]:
    """What a fleet is: its channels (times in seconds) and, filled in by the caller, one
    report per vehicle."""
    return {"file": fleet.source.name, "fleet": fleet.name, "status": "compiled",
            "channels": [{"channel": c.name, "from": c.sender, "to": list(c.receivers),
                          "link": c.link, "delay": [c.delay_min, c.delay_max],
                          "every": c.interval, "lossy": c.lossy,
                          "messages": list(c.messages), "line": c.origin.line,
                          "col": c.origin.col} for c in fleet.channels.values()],
            "vehicles": []}


def fleet_params(assignments: list[str]) -> Params:
    """``--param VEHICLE.NAME=VALUE`` strings into each vehicle's parameter values."""
    out: Params = {}
    for item in assignments:
        vehicle, dot, rest = item.partition(".")
        if not dot or not vehicle.isidentifier() or "=" in vehicle:
            origin = Source(f"--param {item}", item)
            raise MclError(origin.diagnostic(
                "error", f"in a fleet, a parameter belongs to a vehicle: got {item!r}",
                origin.span(1, 1), "write --param VEHICLE.NAME=VALUE, e.g. --param "
                "uuv.depth=2m", "bad-param"))
        out.setdefault(vehicle, {}).update(parse_params([rest]))
    return out


def _refuse_single_mission_options(path: str, args: argparse.Namespace) -> None:
    """Options that take one mission's library, parameter file or net."""
    given = [option for attr, option in NET_OUTPUTS if getattr(args, attr, None)]
    if args.tasks:
        given.append("--tasks")
    if args.params:
        given.append("--params")
    if given:
        raise MclError(f"{given[0]} takes a single mission, and this file is a fleet",
                       span=Span.of_file(path),
                       hint="each VEHICLE names its task library with USES; give a vehicle's "
                            "parameter as --param VEHICLE.NAME=VALUE",
                       code="fleet-option")
