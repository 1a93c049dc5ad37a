"""``mcl``: the operator's command — run a mission, replay its log, check it.

    mcl run MISSION.mcl --vehicle script:FILE.toml [--param k=v ...] [--log run.jsonl]
    mcl replay run.jsonl MISSION.mcl
    mcl vehicle --zenoh ENDPOINT [--speed X] [--seed N] [--inject FAULT@S]
    mcl vehicle --mavlink URL [--speed X] ...   (an ArduSub-like MAVLink vehicle)
    mcl monitor --zenoh ENDPOINT     (the operator's live view)
    mcl check MISSION.mcl            (the same as mclc)

Exit status of ``run``: 0 the mission ended ok, 1 it ended fail (or could not end), 2 invalid
input; of ``replay``: 0 the log conforms, 1 it does not, 2 invalid input.
"""

from __future__ import annotations

import argparse
import sys
import time
import traceback
from pathlib import Path
from typing import Any

from .. import values
from ..api import Compiled, compile_file, parse_params
from ..errors import MclError
from . import mclc

EXIT_OK, EXIT_FAIL, EXIT_INVALID, EXIT_INTERNAL = 0, 1, 2, 3


def _common(p: argparse.ArgumentParser) -> None:
    p.add_argument("--tasks", action="append", default=[], metavar="FILE",
                   help="task library (.tasks); default: the mission's USES, else Ictineu")
    p.add_argument("--param", action="append", default=[], metavar="NAME=VALUE",
                   help="a mission parameter (overrides PARAM)")
    p.add_argument("--params", action="append", default=[], metavar="FILE",
                   help="a parameter file: one 'name = value' per line")
    p.add_argument("--debug", action="store_true", help="show tracebacks of internal errors")


def _parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="mcl", description="Run MCL missions and check their logs.")
    sub = p.add_subparsers(dest="command", required=True)
    r = sub.add_parser("run", help="run a mission on a vehicle")
    r.add_argument("mission", metavar="MISSION.mcl")
    r.add_argument("--vehicle", default="sim", metavar="KIND[:WHERE]",
                   help="sim (default: the simulated Ictineu in front of a dam wall) or "
                        "script:FILE.toml (a scripted vehicle) or zenoh:ENDPOINT (a vehicle "
                        "served by 'mcl vehicle', e.g. zenoh:tcp/127.0.0.1:7447) or "
                        "mavlink:URL (an ArduSub-class vehicle, e.g. "
                        "mavlink:udpin:127.0.0.1:14550)")
    r.add_argument("--seed", type=int, default=1, help="random seed of the simulated vehicle")
    r.add_argument("--inject", action="append", default=[], metavar="FAULT@SECONDS",
                   help="a sensor fault at a mission time: leak@600, overtemperature@300, "
                        "overpressure@900 (simulated vehicle)")
    r.add_argument("--realtime", action="store_true",
                   help="run the simulated vehicle at wall-clock speed")
    r.add_argument("--log", metavar="FILE", help="run log (JSON Lines); default "
                   "out/runs/MISSION-TIME.jsonl")
    r.add_argument("--max-time", type=float, default=86_400.0, metavar="SECONDS",
                   help="stop a mission that has not ended after this much mission time")
    r.add_argument("--quiet", action="store_true", help="no timeline, only the final status")
    r.add_argument("--no-verify", action="store_true",
                   help="run without verifying first (by default an unverified mission is "
                        "refused)")
    _common(r)
    from vehicle_adapters import zenoh_security

    z = r.add_argument_group("Zenoh link (--vehicle zenoh:...)")
    z.add_argument("--scouting", action="store_true",
                   help="also find the vehicle by Zenoh's multicast scouting (off by default)")
    zenoh_security.add_arguments(z, "player")
    m = r.add_argument_group("MAVLink link (--vehicle mavlink:...)")
    m.add_argument("--signing-key", metavar="FILE",
                   help="MAVLink 2 signing: the secret key file (default: $MCL_MAVLINK_KEY "
                        "if set, else unsigned)")
    m.add_argument("--require-signing", action="store_true",
                   help="refuse unsigned or wrongly signed messages from the vehicle")
    sub.add_parser("vehicle", help="serve the simulated vehicle over Zenoh or MAVLink: mcl "
                   "vehicle --zenoh ENDPOINT | --mavlink URL [--speed X] [--seed N] "
                   "[--inject FAULT@S]")
    sub.add_parser("monitor", help="watch a mission and its vehicle over Zenoh: mcl monitor "
                   "--zenoh ENDPOINT [--until-end]")
    rp = sub.add_parser("replay", help="check that a run log is a legal run of the mission")
    rp.add_argument("log", metavar="RUN.jsonl")
    rp.add_argument("mission", metavar="MISSION.mcl")
    rp.add_argument("--tasks", action="append", default=[], metavar="FILE")
    rp.add_argument("--debug", action="store_true")
    return p


def main(argv: list[str] | None = None) -> int:
    args_list = sys.argv[1:] if argv is None else argv
    if args_list and args_list[0] == "check":
        return mclc.main(args_list[1:])
    if args_list and args_list[0] == "monitor":
        from .monitor import main as monitor_main

        return monitor_main(args_list[1:])
    if args_list and args_list[0] == "vehicle":
        from vehicle_adapters.serve import main as vehicle_main

        return vehicle_main(args_list[1:])
    args = _parser().parse_args(args_list)
    try:
        if args.command == "run":
            return _run(args)
        return _replay(args)
    except MclError as exc:
        print(exc.format(), file=sys.stderr)
        return EXIT_INVALID
    except _Invalid as exc:
        print(f"mcl {args.command}: error: {exc}", file=sys.stderr)
        return EXIT_INVALID
    except Exception as exc:  # a bug of ours: say so plainly
        if args.debug:
            traceback.print_exc()
        print(f"mcl {args.command}: internal error: {type(exc).__name__}: {exc}\n"
              "  hint: this is a bug in mcl; rerun with --debug and report it", file=sys.stderr)
        return EXIT_INTERNAL


class _Invalid(Exception):
    """Invalid input that is not MCL source (a vehicle file, a log)."""


def _param_texts(overrides: dict[str, Any]) -> dict[str, str]:
    return {name: values.to_text(value) for name, (value, _) in overrides.items()}


def _compile(mission: str, tasks: list[str], overrides: dict[str, Any]) -> Compiled:
    return compile_file(mission, tasks or None, overrides, require_values=True)


def _run(args: argparse.Namespace) -> int:
    from petri.player import Player
    from petri.runlog import RunLog, net_digest
    from petri.runner import run

    overrides = parse_params(args.param, args.params)
    compiled = _compile(args.mission, args.tasks, overrides)
    for d in compiled.warnings:
        print(d.format(), file=sys.stderr)
    if not args.no_verify:
        verdict = mclc._verify(compiled, "auto")
        if not verdict.ok:
            failed = [r for r in verdict.results if not r.holds and r.severity == "error"]
            print(f"{args.mission}: not verified ({', '.join(r.name for r in failed)}): "
                  "refusing to run it\n  hint: see 'mclc " + args.mission + "'; --no-verify "
                  "runs it anyway", file=sys.stderr)
            return EXIT_FAIL
    vehicle, stack = _vehicle(args)
    name = compiled.mission.name or Path(args.mission).stem
    log_path = Path(args.log) if args.log else Path("out/runs") / (
        f"{Path(args.mission).stem}-{time.strftime('%Y%m%d-%H%M%S')}.jsonl")
    header = {"mission": name, "file": args.mission, "net": net_digest(compiled.net),
              "params": _param_texts(overrides), "tasks": args.tasks,
              "vehicle": args.vehicle, "seed": args.seed, "inject": args.inject}
    player = Player(compiled.net)
    timeline = _Timeline(compiled) if not args.quiet else None
    with RunLog(log_path, header) as log, vehicle:
        player.observers.append(log)
        publish = getattr(vehicle, "publish_status", None)
        if publish is not None:  # observers of the mission: mcl monitor
            from petri.status import MissionStatus

            player.observers.append(MissionStatus(player, name, getattr(vehicle, "run", ""),
                                                  publish))
        if timeline:
            player.observers.append(timeline)
        outcome = run(player, vehicle, name, max_time=args.max_time)
        if outcome.status in ("stuck", "timeout"):
            log(_status_record(outcome))
    status = outcome.status
    print(f"{args.mission}: mission {name} ended {status.upper()} after {outcome.time:.1f} s "
          f"of mission time ({player.fired} firings)"
          + (f": {outcome.reason}" if outcome.reason else ""))
    print(f"  run log: {log_path}")
    summary = getattr(vehicle, "summary", None)
    if summary is not None:  # what went over a MAVLink link
        print("  link: " + ", ".join(f"{k} {v}" for k, v in summary().items()
                                     if v is not None))
    if stack is not None:
        _report_survey(stack, log_path, name)
    return EXIT_OK if status == "ok" else EXIT_FAIL


def _status_record(outcome: Any) -> Any:
    from petri.player import Record

    return Record(outcome.time, "note", {"note": f"run ended {outcome.status}: "
                                                 f"{outcome.reason}"})


def _vehicle(args: argparse.Namespace) -> tuple[Any, Any]:
    """The adapter, and the simulated stack behind it (None for a scripted vehicle)."""
    from vehicle_adapters.inprocess import InProcess
    from vehicle_adapters.scripted import ScriptedVehicle, ScriptError, load_script

    kind, _, where = args.vehicle.partition(":")
    speed = 1.0 if args.realtime else None
    for options, link in ((("user", "password_file", "tls_ca", "tls_cert", "tls_key",
                            "scouting"), "zenoh"),
                          (("signing_key", "require_signing"), "mavlink")):
        given = [o for o in options if getattr(args, o, None)]
        if given and kind != link:
            raise _Invalid(f"--{given[0].replace('_', '-')} is for --vehicle {link}:...; "
                           f"this run's vehicle is {args.vehicle!r}")
    if kind == "script":
        if not where:
            raise _Invalid("--vehicle script:FILE.toml needs a file")
        if args.inject:
            raise _Invalid("--inject is for the simulated vehicle; a scripted vehicle takes "
                           "[[at]] events in its file")
        try:
            return InProcess(ScriptedVehicle(load_script(where)), speed=speed), None
        except ScriptError as exc:
            raise _Invalid(str(exc)) from None
    if kind == "sim" and not where:
        from vehicle.stack import IctineuStack, StackConfig, parse_fault

        try:
            faults = [parse_fault(item) for item in args.inject]
        except ValueError as exc:
            raise _Invalid(f"--inject {exc}") from None
        stack = IctineuStack(StackConfig(seed=args.seed, faults=faults))
        return InProcess(stack, speed=speed), stack
    if kind == "zenoh":
        from vehicle_adapters.zenoh_link import DEFAULT_ENDPOINT, ZenohVehicle

        if args.inject:
            raise _Invalid("--inject is for the vehicle process: "
                           "mcl vehicle --zenoh ENDPOINT --inject FAULT@SECONDS")
        from vehicle_adapters import zenoh_security

        try:
            security = zenoh_security.from_args(args, "player")
        except ValueError as exc:
            raise _Invalid(str(exc)) from None
        return ZenohVehicle(where or DEFAULT_ENDPOINT, "auv", security=security,
                            scouting=args.scouting), None
    if kind == "mavlink":
        from vehicle_adapters.mavlink_link import DEFAULT_URL, MavlinkVehicle
        from vehicle_adapters.signing import SigningError, load_key

        if args.inject:
            raise _Invalid("--inject is for the vehicle process: "
                           "mcl vehicle --mavlink URL --inject FAULT@SECONDS")
        try:
            key = load_key(args.signing_key)
        except SigningError as exc:
            raise _Invalid(str(exc)) from None
        return MavlinkVehicle(where or DEFAULT_URL, signing_key=key,
                              require_signing=args.require_signing), None
    raise _Invalid(f"unknown vehicle {args.vehicle!r}: use sim, script:FILE.toml, "
                   "zenoh:ENDPOINT or mavlink:URL")


def _report_survey(stack: Any, log_path: Path, name: str) -> None:
    """The simulated run's figures against ground truth, and the trajectory plot."""
    s = stack.survey.summary()
    plot = log_path.with_suffix(".svg")
    plot.write_text(stack.survey.svg(name), encoding="utf-8")
    print(f"  path {s['path_length_m']} m; wall imaged {s['wall_area_imaged_m2']} m² in "
          f"{s['images']} images, {100 * s['share_seen_twice']:.0f} % of it in two or more")
    print(f"  navigator error {s['navigator_rms_m']} m RMS (USBL fixes {s['usbl_fixes']}, "
          f"{s['usbl_rejected']} rejected); wall tracker error {s['wall_distance_rms_m']} m "
          f"and {s['wall_heading_rms_deg']} deg RMS during the survey")
    print(f"  trajectory plot: {plot}")


class _Timeline:
    """Prints what happens as it happens: time, task, action or event, source line."""

    def __init__(self, compiled: Compiled):
        self.compiled = compiled

    def __call__(self, record: Any) -> None:
        d = record.data
        t = f"{record.t:9.1f} s"
        if record.kind == "action":
            params = ", ".join(f"{k}={_short(v)}" for k, v in d["params"].items())
            print(f"{t}  {d['task']:<22} → {d['action']} {d['behaviour']}"
                  + (f"({params})" if params else ""), flush=True)
        elif record.kind == "event":
            print(f"{t}  {'':<22} ← {d['event']}", flush=True)
        elif record.kind == "ignored":
            print(f"{t}  {'':<22} ← {d['event']} (ignored: {d['reason']})", flush=True)
        elif record.kind == "fire" and d["cause"] not in ("immediate",) and d["line"]:
            pass
        elif record.kind == "note":
            print(f"{t}  note: {d['note']}", flush=True)
        elif record.kind == "status" and d["status"] in ("ok", "fail"):
            print(f"{t}  mission ends {d['status'].upper()}", flush=True)


def _short(value: Any) -> str:
    text = f"{value:g}" if isinstance(value, float) else str(value)
    return text if len(text) <= 30 else text[:27] + "..."


def _replay(args: argparse.Namespace) -> int:
    from petri.replay import check
    from petri.runlog import LogError, read_log

    from .. import parser

    try:
        records = read_log(args.log)
    except LogError as exc:
        print(f"{exc}\n  not conformant: the log cannot be read whole", file=sys.stderr)
        return EXIT_FAIL
    header = records[0]
    from ..errors import Source

    overrides = {name: (parser.parse_value(text, "<log header>"),
                        Source(f"{args.log} header: {name}", text))
                 for name, text in (header.get("params") or {}).items()}
    compiled = _compile(args.mission, args.tasks or header.get("tasks") or [], overrides)
    params: dict[str, Any] = {}
    result = check(compiled.net, records, params)
    if result.ok:
        print(f"{args.log}: conforms to {args.mission}: {result.firings} firings in "
              f"{result.records} records")
        return EXIT_OK
    print(f"{args.log}:{result.line}: not conformant: {result.reason}")
    return EXIT_FAIL


if __name__ == "__main__":
    sys.exit(main())
