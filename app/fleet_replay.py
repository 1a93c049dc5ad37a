"""``mcl replay DIR FLEET.mcl``: check a fleet's run logs together (docs/FLEET_RUN.md).

``DIR`` is the folder ``mcl run FLEET.mcl --log-dir DIR`` wrote: one run log per vehicle
(``NAME.jsonl``) and the channel record (``channels.jsonl``). Each vehicle's log is checked
alone against its own net as ``mcl replay`` checks any run log (its chain and signatures, its
header, every record, its end record); then the channel record's chain, and the record
against the fleet and the logs (:mod:`mission.fleet_evidence`): every Send has its ``sent``
line, every delivery follows its send within the channel's DELAY range and is in the
receiver's log, no message got that was not delivered, losses only on LOSSY channels, drops
only within EVERY. Exit 0: all conform; 1: one does not (the first named, at its line); 2:
invalid input.
"""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

from mcl.fleet import CompiledFleet, compile_fleet_file
from mission.exits import Exit
from mission.fleet_evidence import RecordProblem, problem, read_record
from mission.fleet_evidence_apart import is_apart, problem_apart, read_records

RECORD = "channels.jsonl"


def replay(args: argparse.Namespace) -> int:
    """Check the fleet's logs in ``args.log`` (a folder) against ``args.mission``."""
    from mission.evidence import end_problem, header_problem  # here for start-up speed
    from petri.execution.replay import check
    from petri.execution.runlog import LogError, read_log, verify
    from petri.execution.signing import load_public

    folder = Path(args.log)
    fleet = compile_fleet_file(args.mission, require_values=True)
    if not folder.is_dir():
        raise RecordProblem(folder, None, "not a folder: a fleet's logs are a folder "
                            "(mcl run FLEET.mcl --log-dir DIR)", invalid=True)
    key = load_public(args.key) if args.key is not None else None
    logs: dict[str, list[dict[str, Any]]] = {}
    told: list[str] = []
    for name, compiled in fleet.vehicles.items():
        path = folder / f"{name}.jsonl"
        if not path.is_file():
            raise RecordProblem(path, None, f"no run log of vehicle {name}", invalid=True)
        try:
            records = read_log(path)
            established = verify(records, path, key)
        except LogError as exc:
            raise RecordProblem(path, exc.line, exc.reason, exc.invalid) from None
        why = header_problem(records[0], compiled) or fleet_header(records[0], fleet, name)
        if why is not None:
            raise RecordProblem(path, 1, why)
        result = check(compiled.net, records, {})
        if not result.ok:
            raise RecordProblem(path, result.line, result.reason)
        why = end_problem(records[0], records[-1], records, compiled)
        if why is not None:
            raise RecordProblem(path, records[-1]["_line"], why)
        logs[name] = records
        told.append(f"{name} {result.firings} firings in {result.records} records")
    if is_apart(folder, list(fleet.vehicles)):  # run apart over Zenoh: a record each
        return replay_apart(args, fleet, folder, logs, told, established)
    record_path = folder / RECORD
    if not record_path.is_file():
        raise RecordProblem(record_path, None, "no channel record", invalid=True)
    record = read_record(record_path)
    wrong = problem(fleet, record, record_path, logs)
    if wrong is not None:
        raise wrong
    kinds = [r["kind"] for r in record]
    print(f"{folder}: fleet {fleet.name} conforms to {args.mission}: {'; '.join(told)}; "
          f"channels: {kinds.count('sent')} sent, {kinds.count('delivered')} delivered, "
          f"{kinds.count('lost')} lost, {kinds.count('dropped')} dropped; logs: {established}")
    return Exit.OK


def fleet_header(header: dict[str, Any], fleet: CompiledFleet, name: str) -> str | None:
    """Why a vehicle's log header is not one of this fleet's runs (None: it is)."""
    if header.get("fleet") != fleet.name or header.get("as") != name:
        return (f"the log is not of vehicle {name} of fleet {fleet.name} (its header says "
                f"{str(header.get('as'))[:40]!r} of {str(header.get('fleet'))[:40]!r})")
    return None


def replay_apart(args: argparse.Namespace, fleet: CompiledFleet, folder: Path,
                 logs: dict[str, list[dict[str, Any]]], told: list[str], established: str
                 ) -> int:
    """The logs of a fleet run apart, each vehicle with its own channel record
    (mission/fleet_evidence_apart.py, docs/FLEET_ZENOH.md)."""
    wrong = problem_apart(fleet, folder, logs)
    if wrong is not None:
        raise wrong
    kinds = [r["kind"] for rec in read_records(folder, fleet.name, list(logs)).values()
             for r in rec]
    print(f"{folder}: fleet {fleet.name} (run apart) conforms to {args.mission}: "
          f"{'; '.join(told)}; channels: {kinds.count('sent')} sent, "
          f"{kinds.count('delivered')} delivered, {kinds.count('lost')} lost, "
          f"{kinds.count('dropped')} dropped, {kinds.count('refused')} refused; logs: "
          f"{established}")
    return Exit.OK
