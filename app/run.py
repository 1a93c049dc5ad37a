"""``mcl run``: run a mission on a vehicle (README, "mcl run").

    mcl run MISSION.mcl [--vehicle KIND[:WHERE]] [--param k=v ...] [--log run.jsonl] ...

The kinds of vehicle and their options: ``app/vehicles/`` (one module each). Exit status: 0
the mission ended ok; 1 it ended fail (a task failed, an alarm, ``Link.lost``) or it is not
verified; 2 invalid input, or a mission the vehicle cannot run (refused before the first
action); 3 an internal error (a bug); 4 stopped at ``--max-time`` or stuck (nothing could
happen any more); 5 stopped by an error of the vehicle or its adapter; 128 + N stopped by
signal N (130 SIGINT, 143 SIGTERM, 129 SIGHUP). Every exit but 2 before the start goes through
the mission's abort: every behaviour on is disabled and the run log's last record (``"kind":
"end"``) says how and why the run ended.
"""

from __future__ import annotations

import argparse
import math
import os
import sys
import time
from pathlib import Path
from typing import TYPE_CHECKING, Any

from diagnostics import MclError
from mcl import values
from mcl.api import Compiled, compile_file, parse_params
from mcl.analysis.verification import verify_mission

from app import vehicles
from app.guard import guarded
from app.mclc import OutputError

if TYPE_CHECKING:
    from vehicle.control.stack import IctineuStack

EXIT_OK, EXIT_FAIL, EXIT_INVALID, EXIT_INTERNAL = 0, 1, 2, 3
EXIT_STOPPED, EXIT_VEHICLE = 4, 5  # run: --max-time or stuck; an error of the vehicle
STOP_SIGNALS = ("SIGINT", "SIGTERM", "SIGHUP")


def _parser() -> tuple[argparse.ArgumentParser, vehicles.Owned]:
    r = argparse.ArgumentParser(prog="mcl run")
    r.add_argument("mission", metavar="MISSION.mcl")
    r.add_argument("--vehicle", default="sim", metavar="KIND[:WHERE]",
                   help=vehicles.help_text())
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
    r.add_argument("--tasks", action="append", default=[], metavar="FILE",
                   help="task library (.tasks); default: the mission's USES, else Ictineu")
    r.add_argument("--param", action="append", default=[], metavar="NAME=VALUE",
                   help="a mission parameter (overrides PARAM)")
    r.add_argument("--params", action="append", default=[], metavar="FILE",
                   help="a parameter file: one 'name = value' per line")
    r.add_argument("--debug", action="store_true", help="show tracebacks of internal errors")
    owned = vehicles.add_options(r)  # each kind's options, in a group of its own
    return r, owned


def main(argv: list[str] | None = None) -> int:
    """``mcl run ARGS`` (``argv``: what follows ``run``)."""
    parser, owned = _parser()
    args = parser.parse_args(sys.argv[1:] if argv is None else argv)
    return guarded("run", args.debug, lambda: _run(args, owned))


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
        raise OutputError(str(path), "--log", "is a directory")
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise OutputError(str(path), "--log", f"cannot make its folder: "
                          f"{exc.strerror or exc}") from None
    if not os.access(path.parent, os.W_OK) or (path.exists() and not os.access(path, os.W_OK)):
        raise OutputError(str(path), "--log", "permission denied")


def _param_texts(overrides: dict[str, Any]) -> dict[str, str]:
    return {name: values.to_text(value) for name, (value, _) in overrides.items()}


def _run(args: argparse.Namespace, owned: vehicles.Owned) -> int:
    from petri.execution.player import Player
    from petri.execution.runlog import RunLog, net_digest
    from petri.execution.runner import MissionClock, run

    from app import safe_exit

    _check_log(Path(args.log) if args.log else Path("out/runs/MISSION.jsonl"))
    overrides = parse_params(args.param, args.params)
    compiled = compile_file(args.mission, args.tasks or None, overrides, require_values=True)
    for d in compiled.warnings:
        print(d.format(), file=sys.stderr)
    max_time, limit_why = safe_exit.max_time(compiled, args.max_time)
    chosen = vehicles.build(args, owned)
    vehicle, stack, declares = chosen.adapter, chosen.stack, chosen.declares
    said = declares.declaration() if declares is not None else None
    if said is not None:  # known before connecting: refuse now
        safe_exit.check_capabilities(compiled, said)
    if not args.no_verify:
        verdict = verify_mission(compiled, "auto")
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
                if declares is not None and not (chosen.link and chosen.link.lost):
                    said = declares.declaration()  # a remote vehicle's own word, once connected
                    if said is not None:
                        safe_exit.check_capabilities(compiled, said)
                player.observers.append(log)
                player.observers.append(lambda r: last_t.__setitem__(0, r.t))
                if chosen.status is not None:  # observers of the mission: mcl monitor
                    from petri.execution.status import MissionStatus

                    player.observers.append(MissionStatus(
                        player, name, chosen.status.run, chosen.status.publish_status,
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
        if chosen.link is not None and chosen.link.lost:
            why += f" (Link.lost: {chosen.link.lost_reason or 'the link was lost'})"
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
    if chosen.summary is not None:  # what went over a MAVLink link
        out.say("  link: " + ", ".join(f"{k} {v}" for k, v in chosen.summary.summary().items()
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


def _report_survey(stack: IctineuStack, log_path: Path, name: str, out: Any) -> None:
    """The simulated run's figures against ground truth, and the trajectory plot."""
    s = stack.survey.summary()
    plot = log_path.with_suffix(".svg")
    plot.write_text(stack.survey.svg(name), encoding="utf-8")
    seabed = stack.seabed
    # the wall lines only for a run that saw the wall (not a seabed run, nor a dive)
    wall = s["wall_area_imaged_m2"] > 0 or not math.isnan(s["wall_distance_rms_m"])
    if wall:
        out.say(f"  path {s['path_length_m']} m; wall imaged {s['wall_area_imaged_m2']} m² in "
                f"{s['images']} images, {100 * s['share_seen_twice']:.0f} % of it in two or more")
    else:
        out.say(f"  path {s['path_length_m']} m")
    out.say(f"  navigator error {s['navigator_rms_m']} m RMS (USBL fixes {s['usbl_fixes']}, "
            f"{s['usbl_rejected']} rejected)" + (
                f"; wall tracker error {s['wall_distance_rms_m']} m and "
                f"{s['wall_heading_rms_deg']} deg RMS during the survey" if wall else ""))
    out.say(f"  trajectory plot: {plot}")
    if seabed.report():  # the seabed trackers' figures: docs/SEABED.md
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


if __name__ == "__main__":
    sys.exit(main())
