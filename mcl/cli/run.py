"""``mcl``: the operator's command — run a mission, replay its log, check it.

    mcl run MISSION.mcl --vehicle script:FILE.toml [--param k=v ...] [--log run.jsonl]
    mcl replay run.jsonl MISSION.mcl
    mcl vehicle --zenoh ENDPOINT [--speed X] [--seed N] [--inject FAULT@S]
    mcl vehicle --mavlink URL [--speed X] ...   (an ArduSub-like MAVLink vehicle)
    mcl monitor --zenoh ENDPOINT     (the operator's live view)
    mcl check MISSION.mcl            (the same as mclc)

Exit status of ``run`` (README, "mcl run"): 0 the mission ended ok; 1 it ended fail (a task
failed, an alarm, ``Link.lost``); 2 invalid input, or a mission the vehicle cannot run
(refused before the first action); 3 an internal error (a bug); 4 stopped at ``--max-time``
or stuck (nothing could happen any more); 5 stopped by an error of the vehicle or its
adapter; 128 + N stopped by signal N (130 SIGINT, 143 SIGTERM, 129 SIGHUP). Every exit but 2
before the start goes through the mission's abort: every behaviour on is disabled and the run
log's last record (``"kind": "end"``) says how and why the run ended. Of ``replay``: 0 the
log conforms, 1 it does not, 2 invalid input.
"""

from __future__ import annotations

import argparse
import math
import os
import signal
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
EXIT_STOPPED, EXIT_VEHICLE = 4, 5  # run: --max-time or stuck; an error of the vehicle
STOP_SIGNALS = ("SIGINT", "SIGTERM", "SIGHUP")


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
                        "overpressure@900, or burial@60 (every seabed line under sand from then on; "
                        "docs/SEABED.md) (simulated vehicle)")
    r.add_argument("--realtime", action="store_true",
                   help="run the simulated vehicle at wall-clock speed")
    r.add_argument("--log", metavar="FILE", help="run log (JSON Lines); default "
                   "out/runs/MISSION-TIME.jsonl")
    r.add_argument("--max-time", type=_seconds, default=None, metavar="SECONDS",
                   help="abort a mission that has not ended after this much mission time "
                        "(exit 4). Default: the longest the mission can last by its "
                        "timeouts, plus 10 %% and 60 s; 7200 s when its timeouts do not "
                        "bound it (a WHILE loop, a task that waits without a timeout)")
    r.add_argument("--quiet", action="store_true", help="no timeline, only the final status")
    r.add_argument("--no-images", action="store_true",
                   help="simulated vehicle: do not render and keep the camera's images, so no "
                        "photomosaic is made (a faster run; the camera still counts its images)")
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
    sub.add_parser("mosaic", help="make the photomosaic and coverage map of a run's images: "
                   "mcl mosaic RUN.jsonl [--scale MM_PER_PX]")
    rp = sub.add_parser("replay", help="check that a run log is a legal run of the mission")
    rp.add_argument("log", metavar="RUN.jsonl")
    rp.add_argument("mission", metavar="MISSION.mcl")
    rp.add_argument("--tasks", action="append", default=[], metavar="FILE")
    rp.add_argument("--debug", action="store_true")
    return p


def main(argv: list[str] | None = None) -> int:
    """The command; a closed standard output (``mcl ... | head -1``) ends it quietly."""
    try:
        return _command(argv)
    except BrokenPipeError:
        mclc.stdout_closed()
        return EXIT_OK


def _command(argv: list[str] | None) -> int:
    args_list = sys.argv[1:] if argv is None else argv
    if args_list and args_list[0] == "check":
        return mclc.main(args_list[1:])
    if args_list and args_list[0] == "monitor":
        from .monitor import main as monitor_main

        return monitor_main(args_list[1:])
    if args_list and args_list[0] == "mosaic":  # the photomosaic of a run (docs/MOSAIC.md)
        from mosaic.cli import main as mosaic_main

        return mosaic_main(args_list[1:])
    if args_list and args_list[0] == "vehicle":
        from vehicle_adapters.serve import main as vehicle_main

        return vehicle_main(args_list[1:])
    args = _parser().parse_args(args_list)
    try:
        if args.command == "run":
            return _run(args)
        return _replay(args)
    except KeyboardInterrupt:  # Ctrl-C before the mission started (or after it ended)
        print(f"mcl {args.command}: interrupted", file=sys.stderr)
        return 128 + signal.SIGINT
    except MclError as exc:
        print(exc.format(), file=sys.stderr)
        return EXIT_INVALID
    except _Invalid as exc:
        print(exc if exc.verbatim else _error_line(str(exc)), file=sys.stderr)
        return EXIT_INVALID
    except mclc.OutputError as exc:
        print(exc, file=sys.stderr)
        return EXIT_INVALID
    except BrokenPipeError:
        raise
    except Exception as exc:  # a bug of ours: say so plainly
        if args.debug:
            traceback.print_exc()
        print(f"mcl {args.command}: internal error: {type(exc).__name__}: {exc}\n"
              "  hint: this is a bug in mcl; rerun with --debug and report it", file=sys.stderr)
        return EXIT_INTERNAL


class _Invalid(Exception):
    """Invalid input that is not MCL source (a vehicle file, a log). ``verbatim``: the message
    is the whole line (it starts with the option or file it is about)."""

    def __init__(self, message: str, verbatim: bool = False):
        super().__init__(message)
        self.verbatim = verbatim


def _error_line(message: str) -> str:
    """``NAME: error: what``, NAME the option or file the message starts with
    (``--inject leak@: ...``, ``v.toml: no such file``, ``--user is for ...``)."""
    first, newline, more = message.partition("\n")
    if ": error:" in first:
        return message
    head, colon, rest = first.partition(": ")
    if colon and (head.startswith("--") or " " not in head):
        return f"{head}: error: {rest}{newline}{more}"
    option, _, rest = first.partition(" ")
    return f"{option}: error: {rest}{newline}{more}"


def _seconds(text: str) -> float:
    """--max-time: a positive, finite number of seconds."""
    try:
        value = float(text)
    except ValueError:
        value = math.nan
    if not (math.isfinite(value) and value > 0):
        raise argparse.ArgumentTypeError(f"{text!r} is not a positive number of seconds")
    return value


def _check_log(path: Path) -> None:
    """The run log's path, checked before the run: its folder is made if missing."""
    if path.is_dir():
        raise mclc.OutputError(str(path), "--log", "is a directory")
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise mclc.OutputError(str(path), "--log", f"cannot make its folder: "
                               f"{exc.strerror or exc}") from None
    if not os.access(path.parent, os.W_OK) or (path.exists() and not os.access(path, os.W_OK)):
        raise mclc.OutputError(str(path), "--log", "permission denied")


def _param_texts(overrides: dict[str, Any]) -> dict[str, str]:
    return {name: values.to_text(value) for name, (value, _) in overrides.items()}


def _compile(mission: str, tasks: list[str], overrides: dict[str, Any]) -> Compiled:
    return compile_file(mission, tasks or None, overrides, require_values=True)


def _run(args: argparse.Namespace) -> int:
    from petri.player import Player
    from petri.runlog import RunLog, net_digest
    from petri.runner import MissionClock, run

    from . import safe_exit

    _check_log(Path(args.log) if args.log else Path("out/runs/MISSION.jsonl"))
    overrides = parse_params(args.param, args.params)
    compiled = _compile(args.mission, args.tasks, overrides)
    for d in compiled.warnings:
        print(d.format(), file=sys.stderr)
    max_time, limit_why = safe_exit.max_time(compiled, args.max_time)
    vehicle, stack = _vehicle(args)
    declared = getattr(vehicle, "declaration", None)
    if declared is not None and declared() is not None:  # known before connecting: refuse now
        safe_exit.check_capabilities(compiled, declared())
    if not args.no_verify:
        verdict = mclc._verify(compiled, "auto")
        if not verdict.ok:
            failed = [r for r in verdict.results if not r.holds and r.severity == "error"]
            print(f"{args.mission}: not verified ({', '.join(r.name for r in failed)}): "
                  "refusing to run it\n  hint: see 'mclc " + args.mission + "'; --no-verify "
                  "runs it anyway", file=sys.stderr)
            return EXIT_FAIL
    name = compiled.mission.name or Path(args.mission).stem
    log_path = Path(args.log) if args.log else Path("out/runs") / (
        f"{Path(args.mission).stem}-{time.strftime('%Y%m%d-%H%M%S')}.jsonl")
    header = {"mission": name, "file": args.mission, "net": net_digest(compiled.net),
              "params": _param_texts(overrides), "tasks": args.tasks,
              "vehicle": args.vehicle, "seed": args.seed, "inject": args.inject,
              "max_time": max_time, "time": "mission time: 0 at the mission's start"}
    if stack is not None and not args.no_images:  # the camera's images, beside the log
        from mosaic.hook import attach

        attach(stack, log_path)
    player = Player(compiled.net)
    clock = MissionClock()
    out = safe_exit.Output()
    timeline = _Timeline(compiled, clock, out) if not args.quiet else None
    stops = safe_exit.Stops(STOP_SIGNALS)
    last_t = [0.0]  # the mission time of the last record (an end record never goes back)
    with stops, RunLog(log_path, header) as log:
        try:
            with vehicle:
                if declared is not None and not getattr(vehicle, "lost", False):
                    said = declared()  # a remote vehicle's own word, once connected
                    if said is not None:
                        safe_exit.check_capabilities(compiled, said)
                player.observers.append(log)
                player.observers.append(lambda r: last_t.__setitem__(0, r.t))
                publish = getattr(vehicle, "publish_status", None)
                if publish is not None:  # observers of the mission: mcl monitor
                    from petri.status import MissionStatus

                    player.observers.append(MissionStatus(
                        player, name, getattr(vehicle, "run", ""), publish,
                        vehicle_time=clock.vehicle))
                if timeline:
                    player.observers.append(timeline)
                outcome = run(player, vehicle, name, max_time=max_time, stop=stops.reason,
                              clock=clock)
        except MclError as exc:  # refused, or a vehicle that cannot be reached: nothing sent
            first = exc.diagnostics[0].message if exc.diagnostics else str(exc)
            log.end(last_t[0], "refused", first, exit=EXIT_INVALID, status=player.status)
            raise
        except Exception as exc:  # a bug of ours: the log still says how the run ended
            log.end(last_t[0], "error", f"internal error: {type(exc).__name__}: {exc}",
                    exit=EXIT_INTERNAL, status=player.status)
            raise
        code = _exit_status(outcome, stops.signal)
        how = {"ok": "ok", "fail": "fail", "timeout": "time limit", "stuck": "stuck",
               "stopped": "signal", "error": "error"}.get(outcome.status, outcome.status)
        why = outcome.reason or ("the mission ended " + outcome.status.upper())
        if getattr(vehicle, "lost", False):
            why += f" (Link.lost: {getattr(vehicle, 'lost_reason', '') or 'the link was lost'})"
        if out.closed:
            why += "; standard output was closed during the run (the timeline stopped)"
        log.end(max(outcome.time, last_t[0]), how, why, exit=code, status=player.status,
                vehicle_t=round(clock.vehicle(outcome.time), 6),
                switched_off=outcome.switched_off, confirmed=outcome.confirmed,
                limit=max_time, limit_from=limit_why)
    shown = {"timeout": "STOPPED AT THE TIME LIMIT", "stuck": "STUCK", "stopped": "STOPPED",
             "error": "STOPPED BY AN ERROR"}.get(outcome.status, outcome.status.upper())
    vehicle_clock = ""
    if clock.origin:  # the vehicle's clock did not start with the mission
        vehicle_clock = (f" (vehicle clock {clock.vehicle(0.0):.1f} -> "
                         f"{clock.vehicle(outcome.time):.1f} s)")
    out.say(f"{args.mission}: mission {name} ended {shown} after {outcome.time:.1f} s "
            f"of mission time{vehicle_clock} ({player.fired} firings)"
            + (f": {outcome.reason}" if outcome.reason else ""))
    if outcome.status not in ("ok", "fail") or outcome.switched_off:
        out.say(f"  switched off: {', '.join(outcome.switched_off) or 'nothing was on'}; "
                f"{outcome.confirmed}")
    out.say(f"  run log: {log_path}")
    summary = getattr(vehicle, "summary", None)
    if summary is not None:  # what went over a MAVLink link
        out.say("  link: " + ", ".join(f"{k} {v}" for k, v in summary().items()
                                       if v is not None))
    if stack is not None and outcome.status != "stopped":
        _report_survey(stack, log_path, name, out)
        from mosaic.hook import report

        report(stack, log_path, out.say)
    if outcome.status == "error":
        print(f"mcl run: the run was stopped by an error of the vehicle: {outcome.reason}",
              file=sys.stderr)
    return code


def _exit_status(outcome: Any, signum: int | None) -> int:
    if outcome.status == "stopped" and signum is not None:
        return 128 + signum
    return {"ok": EXIT_OK, "fail": EXIT_FAIL, "timeout": EXIT_STOPPED, "stuck": EXIT_STOPPED,
            "stopped": EXIT_STOPPED, "error": EXIT_VEHICLE}.get(outcome.status, EXIT_FAIL)


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
            script = load_script(where)
            declaration = _script_declaration(script, where)
            return InProcess(ScriptedVehicle(script), speed=speed,
                             declaration=declaration), None
        except ScriptError as exc:
            if exc.place is not None:  # file:line:col: error: ..., its line and a hint
                from ..errors import Diagnostic, Span

                file, line, col = exc.place
                text = script.text.split("\n")
                raise MclError(Diagnostic(
                    "error", str(exc).split(": error: ", 1)[1].split("\n")[0],
                    Span(file, line, col), exc.hint,
                    text[line - 1] if 0 < line <= len(text) else "",
                    "script-unknown-name")) from None
            raise _Invalid(str(exc)) from None
    if kind == "sim" and not where:
        from vehicle.stack import IctineuStack, StackConfig, parse_fault

        try:
            faults = [parse_fault(item) for item in args.inject]
        except ValueError as exc:
            raise _Invalid(f"--inject {exc}") from None
        from vehicle_adapters import capabilities

        stack = IctineuStack(StackConfig(seed=args.seed, faults=faults))
        return InProcess(stack, speed=speed, declaration=capabilities.simulated(
            "sim (the simulated Ictineu)")), stack
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
        from vehicle_adapters.zenoh_link import check_endpoint

        try:
            endpoint = check_endpoint(where or DEFAULT_ENDPOINT)
        except ValueError as exc:
            raise _Invalid(f"--vehicle {args.vehicle}: error: {exc}", verbatim=True) from None
        return ZenohVehicle(endpoint, "auv", security=security,
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
    raise _Invalid(f"--vehicle {args.vehicle}: unknown kind of vehicle: use sim, "
                   "script:FILE.toml, zenoh:ENDPOINT or mavlink:URL")


def _script_declaration(script: Any, where: str) -> Any:
    """A scripted vehicle's declaration: the behaviour statements of its ``tasks`` libraries;
    the script's own names are checked against them (ScriptError at their line)."""
    from vehicle_adapters.aal import Declaration
    from vehicle_adapters.capabilities import behaviour_statements
    from vehicle_adapters.scripted import ScriptError, check_script

    from .. import tasklib
    from ..errors import read_source

    texts = []
    for library in script.tasks:
        try:
            source = (tasklib._shipped(f"{library}.tasks") if tasklib.is_shipped(library)
                      else read_source(library))
        except MclError as exc:
            raise ScriptError(f"{where}: tasks: {exc.format()}") from None
        texts.append(behaviour_statements(source.text))
    declaration = Declaration(f"script:{where}", f"{where} (tasks = {script.tasks})",
                              "".join(texts))
    from .safe_exit import declared_behaviours

    have = declared_behaviours(declaration).behaviours
    check_script(script, {name: b.events for name, b in have.items()})
    return declaration


def _report_survey(stack: Any, log_path: Path, name: str, out: Any) -> None:
    """The simulated run's figures against ground truth, and the trajectory plot."""
    s = stack.survey.summary()
    plot = log_path.with_suffix(".svg")
    plot.write_text(stack.survey.svg(name), encoding="utf-8")
    out.say(f"  path {s['path_length_m']} m; wall imaged {s['wall_area_imaged_m2']} m² in "
            f"{s['images']} images, {100 * s['share_seen_twice']:.0f} % of it in two or more")
    out.say(f"  navigator error {s['navigator_rms_m']} m RMS (USBL fixes {s['usbl_fixes']}, "
            f"{s['usbl_rejected']} rejected); wall tracker error {s['wall_distance_rms_m']} m "
            f"and {s['wall_heading_rms_deg']} deg RMS during the survey")
    out.say(f"  trajectory plot: {plot}")
    seabed = getattr(stack, "seabed", None)
    if seabed is not None and seabed.report():  # the seabed trackers' figures: docs/SEABED.md
        seabed.finish(stack.t)
        for line in seabed.report():
            out.say(line)
        lines_plot = log_path.with_suffix(".seabed.svg")
        lines_plot.write_text(seabed.svg(name), encoding="utf-8")
        out.say(f"  line plot: {lines_plot}")


class _Timeline:
    """Prints what happens as it happens: mission time (and the vehicle's clock beside it
    when it differs), task, action or event. Never raises (a closed stdout is dropped)."""

    def __init__(self, compiled: Compiled, clock: Any, out: Any):
        self.compiled = compiled
        self.clock = clock
        self.out = out

    def __call__(self, record: Any) -> None:
        if self.out.closed:
            return
        d = record.data
        t = f"{record.t:9.1f} s"
        if self.clock.origin:
            t += f" [vehicle {self.clock.vehicle(record.t):9.1f} s]"
        say = self.out.say
        if record.kind == "action":
            params = ", ".join(f"{k}={_short(v)}" for k, v in d["params"].items())
            say(f"{t}  {d['task']:<22} → {d['action']} {d['behaviour']}"
                + (f"({params})" if params else ""))
        elif record.kind == "event":
            say(f"{t}  {'':<22} ← {d['event']}")
        elif record.kind == "ignored":
            say(f"{t}  {'':<22} ← {d['event']} (ignored: {d['reason']})")
        elif record.kind == "note":
            say(f"{t}  note: {d['note']}")
        elif record.kind == "status" and d["status"] in ("ok", "fail"):
            say(f"{t}  mission ends {d['status'].upper()}")


def _short(value: Any) -> str:
    text = f"{value:g}" if isinstance(value, float) else str(value)
    return text if len(text) <= 30 else text[:27] + "..."


def _replay(args: argparse.Namespace) -> int:
    from petri.replay import check
    from petri.runlog import LogError, read_log, verify

    from .. import parser
    from ..errors import Source

    try:
        records = read_log(args.log)
    except LogError as exc:
        if exc.line is None:  # the file itself: missing, a directory, unreadable
            print(f"{args.log}: error: {exc.reason}\n  hint: mcl replay RUN.jsonl "
                  "MISSION.mcl takes the run log "
                  "'mcl run' wrote", file=sys.stderr)
            return EXIT_INVALID
        print(f"{args.log}:{exc.line}: not conformant: {exc.reason}")
        return EXIT_FAIL
    header = records[0]
    params: dict[str, Any] = header.get("params") or {}
    tasks: list[Any] = header.get("tasks") or []
    if not isinstance(params, dict) or not isinstance(tasks, list):
        params, tasks = {}, []  # verify() below names line 1
    overrides = {name: (parser.parse_value(str(text), "<log header>"),
                        Source(f"{args.log} header: {name}", str(text)))
                 for name, text in params.items()}
    compiled = _compile(args.mission, args.tasks or [str(t) for t in tasks], overrides)
    try:
        verify(records, args.log)  # the digest chain, time, the end record
    except LogError as exc:
        print(f"{args.log}:{exc.line}: not conformant: {exc.reason}")
        return EXIT_FAIL
    result = check(compiled.net, records, {})
    if result.ok:
        print(f"{args.log}: conforms to {args.mission}: {result.firings} firings in "
              f"{result.records} records")
        return EXIT_OK
    print(f"{args.log}:{result.line}: not conformant: {result.reason}")
    return EXIT_FAIL


if __name__ == "__main__":
    sys.exit(main())
