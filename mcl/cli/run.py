"""``mcl``: the operator's command — run a mission, replay its log, check it.

    mcl run MISSION.mcl --vehicle script:FILE.toml [--param k=v ...] [--log run.jsonl]
    mcl replay run.jsonl MISSION.mcl
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
    r.add_argument("--vehicle", default="sim", metavar="KIND:WHERE",
                   help="script:FILE.toml (a scripted vehicle, simulated time)")
    r.add_argument("--log", metavar="FILE", help="run log (JSON Lines); default "
                   "out/runs/MISSION-TIME.jsonl")
    r.add_argument("--max-time", type=float, default=86_400.0, metavar="SECONDS",
                   help="stop a mission that has not ended after this much mission time")
    r.add_argument("--quiet", action="store_true", help="no timeline, only the final status")
    r.add_argument("--no-verify", action="store_true",
                   help="run without verifying first (by default an unverified mission is "
                        "refused)")
    _common(r)
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
    vehicle = _vehicle(args.vehicle)
    name = compiled.mission.name or Path(args.mission).stem
    log_path = Path(args.log) if args.log else Path("out/runs") / (
        f"{Path(args.mission).stem}-{time.strftime('%Y%m%d-%H%M%S')}.jsonl")
    header = {"mission": name, "file": args.mission, "net": net_digest(compiled.net),
              "params": _param_texts(overrides), "tasks": args.tasks,
              "vehicle": args.vehicle}
    player = Player(compiled.net)
    timeline = _Timeline(compiled) if not args.quiet else None
    with RunLog(log_path, header) as log, vehicle:
        player.observers.append(log)
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
    return EXIT_OK if status == "ok" else EXIT_FAIL


def _status_record(outcome: Any) -> Any:
    from petri.player import Record

    return Record(outcome.time, "note", {"note": f"run ended {outcome.status}: "
                                                 f"{outcome.reason}"})


def _vehicle(spec: str) -> Any:
    from vehicle_adapters.inprocess import InProcess
    from vehicle_adapters.scripted import ScriptedVehicle, ScriptError, load_script

    kind, _, where = spec.partition(":")
    if kind == "script":
        if not where:
            raise _Invalid("--vehicle script:FILE.toml needs a file")
        try:
            return InProcess(ScriptedVehicle(load_script(where)))
        except ScriptError as exc:
            raise _Invalid(str(exc)) from None
    if kind == "sim":
        raise _Invalid("the built-in simulated vehicle is not available in this version; "
                       "use --vehicle script:FILE.toml (see docs/VEHICLES.md)")
    raise _Invalid(f"unknown vehicle {spec!r}: use script:FILE.toml")


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
    params = {}
    result = check(compiled.net, records, params)
    if result.ok:
        print(f"{args.log}: conforms to {args.mission}: {result.firings} firings in "
              f"{result.records} records")
        return EXIT_OK
    print(f"{args.log}:{result.line}: not conformant: {result.reason}")
    return EXIT_FAIL


if __name__ == "__main__":
    sys.exit(main())
