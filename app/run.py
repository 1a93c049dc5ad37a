"""``mcl run``: run a mission on a vehicle (README, "mcl run").

    mcl run MISSION.mcl [--vehicle KIND[:WHERE]] [--param k=v ...] [--log run.jsonl] ...

It parses the options, builds the vehicle (``app/vehicles/``, one module per kind), calls
:func:`mission.run_mission` (the time bound, the capability check, verification, the run log,
the player and the runner) and prints the timeline and the summary. What it adds as a process:
signals (SIGINT, SIGTERM, SIGHUP abort the mission through its net), the run log's signing
key (``--log-key``: petri/execution/signing.py) and a standard output
that never raises (``app/safe_exit.py``). Every exit but a refusal before the start goes
through the mission's abort, and the run log's last record (``"kind": "end"``) says how and
why the run ended, with its exit status: docs/EXIT.md (the table: ``mission/exits.py``).

The summary lists every event a CATCH handled (``handled: Alarms.leak at 600.1 s (CATCH at line
49) -> DO ended ok``); a mission that handled an alarm and ended ok exits 0, as its author
wrote it (a handler that ends with ``Fail()`` makes it exit 1). While a remote vehicle is
being connected it says ``waiting for the vehicle at ADDRESS (N s)`` on standard error each
second; if none answers, the run is refused before the mission starts ("no vehicle answered
at ADDRESS within N s"), exit 6. A stop from outside (a signal, the time limit, an uncaught
``Link.lost``) runs the mission's ``ON STOP`` handler, if it has one, for at most its proved
bound; a second signal halts it. The summary says how it went (``stop handler (ON STOP) ended
ok at 131.2 s, started at 102.0 s (proved bound 300 s)``). ``--mcap`` and ``--foxglove``, the
run for Foxglove written at its end and served live: ``app/foxglove.py`` (docs/MCAP.md);
``--view HOST:PORT``, mcl view's page of the run served live: ``app/view/run_view.py``.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import sys
import time
import traceback
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING, Any

from diagnostics import file_error
from mcl import values
from mcl.api import Compiled, compile_file, parse_params
from mcl.fleet import is_fleet
from mission.exits import Exit
from mission.limits import mission_bound
from mission.poses import track_of
from mission.progress import TaskProgress
from mission.run import NotVerified, NoVehicle, RunResult, run_mission
from mission.stop_handler import text as stop_text
from mission.vehicle import Vehicle
from petri.execution.runner import MissionClock
from petri.execution.signing import Signer

from app import arguments, fleet_run, fleet_zenoh, foxglove, vehicles
from app.guard import guarded
from app.outputs import OutputError, check_output, unread_pipe
from app.monitor import task_detail
from app.safe_exit import Output, ReportCut, Stops

if TYPE_CHECKING:
    from vehicle.control.stack import IctineuStack

    from app.view.run_view import RunView

STOP_SIGNALS = ("SIGINT", "SIGTERM", "SIGHUP")


def _parser() -> tuple[argparse.ArgumentParser, vehicles.Owned]:
    r = arguments.Parser(prog="mcl run")
    r.add_argument("mission", metavar="MISSION.mcl")
    r.add_argument("--vehicle", default="sim", metavar="KIND[:WHERE]",
                   help=vehicles.help_text())
    r.add_argument("--seed", type=arguments.seed, default=1,
                   help="random seed of the simulated vehicle (0 to 2**64 - 1)")
    r.add_argument("--inject", action="append", default=[], metavar="FAULT@SECONDS",
                   help="a sensor fault at a mission time: leak@600, overtemperature@300, "
                        "overpressure@900, or burial@60 (every seabed line under sand from then on; "
                        "docs/SEABED.md) (simulated vehicle)")
    r.add_argument("--realtime", action="store_true",
                   help="run the simulated vehicle at wall-clock speed")
    r.add_argument("--log", metavar="FILE", help="run log (JSON Lines); default "
                   "out/runs/MISSION-TIME.jsonl")
    fleet_run.add_options(r)  # --log-dir, --loss: a fleet's
    r.add_argument("--max-time", type=_seconds, default=None, metavar="SECONDS",
                   help="abort a mission that has not ended after this much mission time "
                        "(exit 4). Default: the longest the mission can last by its "
                        "timeouts, plus 10 %% and 60 s; 7200 s when its timeouts do not "
                        "bound it (a WHILE loop, a task that waits without a timeout)")
    r.add_argument("--log-key", metavar="FILE", default=None,
                   help="sign every line of the run log with this Ed25519 key (a PEM file: "
                        "openssl genpkey -algorithm ed25519 -out run.key); 'mcl replay --key' "
                        "then refuses a log edited and re-signed without it")
    r.add_argument("--mcap", metavar="FILE", default=None,
                   help="also write the run as an MCAP file for Foxglove, at its end: the "
                        "log, each task's state, the vehicle's poses and track, the camera's "
                        "images (docs/MCAP.md; 'mcl export' makes one from a run log)")
    r.add_argument("--foxglove", metavar="HOST:PORT", default=None, type=foxglove.address,
                   help="serve the run live to Foxglove (its WebSocket protocol, "
                        "foxglove.sdk.v1): the log, each task's state, the vehicle's poses; "
                        "needs the optional extra mcl-auv[foxglove] (docs/MCAP.md)")
    r.add_argument("--view", metavar="HOST:PORT", default=None, type=foxglove.address,
                   help="serve mcl view's page of the run while it goes on, from this "
                        "process, on any vehicle (e.g. 127.0.0.1:8080; port 0: a free one); "
                        "it stops when the run ends (README, 'mcl view')")
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
    fleet_zenoh.add_options(r)  # --as NAME, --fleet-vehicle NAME=ENDPOINT
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


def _check_log(path: Path, option: str = "--log") -> None:
    """The run log's path, checked before the run: its folder is made if missing."""
    if path.is_dir():
        raise OutputError(str(path), option, "is a directory")
    if unread_pipe(path):
        raise OutputError(str(path), option, "a named pipe nobody reads: writing would wait "
                          "for ever")
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise OutputError(str(path), option, f"cannot make its folder: "
                          f"{exc.strerror or exc}") from None
    if not os.access(path.parent, os.W_OK) or (path.exists() and not os.access(path, os.W_OK)):
        raise OutputError(str(path), option, "permission denied")


def _warn_late_faults(compiled: Compiled, injected: list[str], limit: float | None) -> None:
    """A warning for each ``--inject`` fault set after the mission must have ended (its proved
    worst case, or ``--max-time``): it would never happen."""
    if not injected:
        return
    bound = mission_bound(compiled)
    for item in injected:
        kind, _, at = item.partition("@")
        when = float(at)  # checked by the vehicle's kind already
        if bound is not None and when > bound:
            print(f"mcl run: warning: --inject {item}: the mission ends by {bound:g} s at the "
                  f"latest (proved from its timeouts), so the {kind} never happens",
                  file=sys.stderr)
        elif limit is not None and when > limit:
            print(f"mcl run: warning: --inject {item}: after --max-time {limit:g}, so the "
                  f"{kind} never happens", file=sys.stderr)


def _param_texts(overrides: dict[str, Any]) -> dict[str, str]:
    return {name: values.to_text(value) for name, (value, _) in overrides.items()}


def _run(args: argparse.Namespace, owned: vehicles.Owned) -> int:
    if is_fleet(args.mission):  # several vehicles and their channels: app/fleet_run.py
        if args.view is not None:
            raise file_error("--view", "--view: not for a fleet (one mission's run only)",
                             "follow a fleet's run with mcl view FLEET.mcl --fleet-vehicle "
                             "NAME=ENDPOINT ...", "fleet-option")
        if args.log_dir:
            _check_log(Path(args.log_dir) / "channels.jsonl", "--log-dir")
        signer = Signer.load(args.log_key) if args.log_key is not None else None
        if args.as_ is not None:  # one of them here, its channels over Zenoh
            return fleet_zenoh.run(args, signer, _Timeline, fleet_run.losses)
        if args.fleet_vehicle:
            raise file_error(args.mission, "--fleet-vehicle: only with --as NAME (one "
                             "vehicle of the fleet over Zenoh)", "add --as NAME, or leave "
                             "--fleet-vehicle out to run the fleet in one process",
                             "fleet-option")
        return fleet_run.run(args, signer, _Timeline)
    if args.loss or args.log_dir or args.as_ is not None or args.fleet_vehicle:
        option = ("--loss" if args.loss else "--log-dir" if args.log_dir
                  else "--as" if args.as_ is not None else "--fleet-vehicle")
        raise file_error(args.mission, f"{option}: only for a fleet, and this file is a single "
                         "mission", f"leave {option} out (a fleet file starts with FLEET)",
                         "fleet-option")
    _check_log(Path(args.log) if args.log else Path("out/runs/MISSION.jsonl"))
    if args.mcap is not None:
        check_output(args.mcap, "--mcap")
    signer = Signer.load(args.log_key) if args.log_key is not None else None
    overrides = parse_params(args.param, args.params)
    compiled = compile_file(args.mission, args.tasks or None, overrides, require_values=True)
    for d in compiled.warnings:
        print(d.format(), file=sys.stderr)
    chosen = vehicles.build(args, owned)
    _warn_late_faults(compiled, args.inject, args.max_time)
    log_path = Path(args.log) if args.log else Path("out/runs") / (
        f"{Path(args.mission).stem}-{time.strftime('%Y%m%d-%H%M%S')}.jsonl")
    beside = _beside(log_path)
    header = {"file": args.mission, "params": _param_texts(overrides), "tasks": args.tasks,
              "vehicle": args.vehicle, "seed": args.seed, "inject": args.inject}
    clock = MissionClock()
    out = Output()
    view = _view(args, compiled, chosen)  # before Foxglove's: a refusal leaves nothing open
    try:
        live = foxglove.serve(args.foxglove, compiled, chosen.stack, header)
    except BaseException:
        if view is not None:
            view.close()
        raise
    stops = Stops(STOP_SIGNALS)
    try:
        if chosen.stack is not None and not args.no_images and beside:  # the camera's images
            from mosaic.hook import attach  # here for start-up speed: only a sim run needs it

            attach(chosen.stack, log_path)  # its worker process: after every refusal above
        return _run_and_report(args, compiled, chosen, log_path, header, clock, out, stops,
                               signer, [live] if live is not None else [])
    finally:
        try:
            if view is not None:  # an open page sees the end first (app/view/run_view.py)
                view.close()
        except ReportCut as cut:  # a signal while it waited: the server stopped all the same
            _warn(cut.line())
        stops.restore()
        if live is not None:
            live.close(chosen.stack.survey if chosen.stack is not None else None)
        if chosen.stack is not None and chosen.stack.images is not None:
            from mosaic.hook import detach  # here for start-up speed, as attach

            detach(chosen.stack)  # the camera's worker process ends with the run, always


def _view(args: argparse.Namespace, compiled: Compiled, chosen: Vehicle) -> RunView | None:
    """``--view``: mcl view's page of the run, served from now on (None without it)."""
    if args.view is None:
        return None
    from app.view.run_view import RunView  # here for start-up speed: only --view needs it

    view = RunView(args.view, compiled, chosen, args.vehicle.partition(":")[0])
    print(f"mcl run: serving the view at {view.url}", file=sys.stderr, flush=True)
    return view


def _run_and_report(args: argparse.Namespace, compiled: Compiled, chosen: Vehicle,
                    log_path: Path, header: dict[str, Any], clock: MissionClock, out: Output,
                    stops: Stops, signer: Signer | None,
                    watchers: list[Callable[[Any], None]]) -> int:
    """Run the mission, then report on it; what goes wrong in the report (a full disk, its
    folder removed, a signal) never changes the exit status the end record says."""
    try:
        result = run_mission(
            compiled, chosen, log=log_path, header=header, max_time=args.max_time,
            stop=stops.request, verify=not args.no_verify, clock=clock, end_note=out.note,
            observers=[*watchers, *([] if args.quiet else [_Timeline(
                compiled, clock, out, getattr(chosen.adapter, "progress", None))])],
            during=stops,
            waiting=_waiting, signer=signer, track=track_of(chosen))
    except NoVehicle as exc:  # refused before the start: nothing was sent
        print(f"mcl run: {exc}\n  run log: {log_path}", file=sys.stderr)
        return Exit.NO_VEHICLE
    except NotVerified as exc:
        print(f"{args.mission}: not verified ({', '.join(exc.failed)}): refusing to run it\n"
              f"  hint: see 'mclc {args.mission}'; --no-verify runs it anyway", file=sys.stderr)
        return Exit.FAILED
    if result.unwritten is not None:  # the end record's last possible stand-in
        _stand_in(log_path, result)
    try:
        _summary(args.mission, result, chosen, out, log_path)
        if args.mcap is not None:
            foxglove.write_at_end(Path(args.mcap), chosen.stack, log_path, out.say, _warn)
    except ReportCut as cut:
        _warn(cut.line())
    except Exception as exc:  # noqa: BLE001 - the run has ended: its status stands
        if args.debug:
            traceback.print_exc()
        _warn(f"mcl run: the report after the run failed: {type(exc).__name__}: {exc} "
              "(the run log's end record stands)")
    return result.exit


def _beside(log_path: Path) -> bool:
    """Whether files may go beside the run log (its images, its plots): not beside a device
    or a FIFO (``--log /dev/null`` writes no ``/dev/null.svg``)."""
    return not log_path.exists() or log_path.is_file()


def _stand_in(log_path: Path, result: RunResult) -> None:
    """The end record the run log could not take, on standard error: its last stand-in."""
    _warn(f"mcl run: {result.log_failure}: {log_path} is incomplete; its end record: "
          f"{json.dumps(result.unwritten, default=str, separators=(',', ':'))}")


def _warn(line: str) -> None:
    """A line on standard error, never raising (it may be closed or full too)."""
    try:
        print(line, file=sys.stderr, flush=True)
    except (OSError, ValueError):
        pass


def _waiting(where: str, seconds: float) -> None:
    """Progress while the vehicle is connected (standard error)."""
    try:
        print(f"mcl run: waiting for the vehicle at {where} ({seconds:.0f} s)", file=sys.stderr,
              flush=True)
    except (OSError, ValueError):  # a closed standard error: the run goes on
        pass


def _summary(mission: str, result: RunResult, chosen: Vehicle, out: Output,
             log_path: Path) -> None:
    """How the run ended, where its log is, and what the vehicle kind adds (the link's
    figures, the simulated survey and its mosaic)."""
    shown = {"timeout": "STOPPED AT THE TIME LIMIT", "stuck": "STUCK", "stopped": "STOPPED",
             "error": "STOPPED BY AN ERROR", "zeno": "STOPPED: NO TIME PASSED"}.get(result.status, result.status.upper())
    vehicle_clock = ""
    if result.vehicle_clock is not None:  # the vehicle's clock did not start with the mission
        start, end = result.vehicle_clock
        vehicle_clock = f" (vehicle clock {start:.1f} -> {end:.1f} s)"
    out.say(f"{mission}: mission {result.mission} ended {shown} after {result.time:.1f} s "
            f"of mission time{vehicle_clock} ({result.firings} firings)"
            + (f": {result.reason}" if result.reason else ""))
    for handled in result.handled:  # what the mission's CATCH blocks caught
        out.say(f"  handled: {handled.text()}")
    if result.stop_handler is not None:  # the mission's ON STOP, after a stop from outside
        out.say(f"  {stop_text(result.stop_handler)}")
    if result.status not in ("ok", "fail") or result.switched_off:
        out.say(f"  switched off: {', '.join(result.switched_off) or 'nothing was on'}; "
                f"{result.confirmed}")
    out.say(f"  run log: {log_path}" + (f" (incomplete: {result.log_failure})"
                                        if result.log_failure else ""))
    if chosen.summary is not None:  # what went over a MAVLink link
        out.say("  link: " + ", ".join(f"{k} {v}" for k, v in chosen.summary.summary().items()
                                       if v is not None))
    if chosen.stack is not None and result.status != "stopped":
        _report_survey(chosen.stack, log_path, result.mission, out)
        from mosaic.hook import report  # here for start-up speed: only a simulated run needs it

        report(chosen.stack, log_path, out.say)
    if result.status == "error":
        print(f"mcl run: the run was stopped by an error of the vehicle: {result.reason}",
              file=sys.stderr)


def _report_survey(stack: IctineuStack, log_path: Path, name: str, out: Any) -> None:
    """The simulated run's figures against ground truth, and the trajectory plot."""
    s = stack.survey.summary()
    plot = _plot(log_path.with_suffix(".svg"), lambda: stack.survey.svg(name), log_path)
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
        lines = _plot(log_path.with_suffix(".seabed.svg"), lambda: seabed.svg(name), log_path)
        out.say(f"  line plot: {lines}")


def _plot(path: Path, svg: Callable[[], str], log_path: Path) -> str:
    """Write a plot beside the run log; where it is, or why it is not."""
    if not _beside(log_path):
        return "not written (the run log is not a file)"
    try:
        path.write_text(svg(), encoding="utf-8")
    except OSError as exc:
        return f"not written: {exc.strerror or exc} ({path})"
    return str(path)


PROGRESS_EVERY = 60.0  # mission s between two progress lines of a long task


class _Timeline:
    """Prints what happens as it happens: mission time (and the vehicle's clock beside it
    when it differs), task, action or event. While a task runs longer than
    ``PROGRESS_EVERY`` s, a progress line every ``PROGRESS_EVERY`` s of mission time (its
    waypoint k of n, metres to go, time left of its bound: mission/progress.py), so that a
    long survey does not leave the timeline silent. Never raises (a closed stdout is
    dropped)."""

    def __init__(self, compiled: Compiled, clock: Any, out: Any,
                 progress: Callable[[], dict[str, Any]] | None = None):
        self.compiled = compiled
        self.clock = clock
        self.out = out
        self.tasks = TaskProgress(compiled.net, progress)
        self.last = 0.0  # mission time of the last line printed

    def when(self, t: float) -> str:
        """Mission time ``t`` as the timeline prints it, the vehicle's clock beside it."""
        text = f"{t:9.1f} s"
        if self.clock.origin:
            text += f" [vehicle {self.clock.vehicle(t):9.1f} s]"
        return text

    def tick(self, t: float) -> None:
        """Mission time ``t`` passed (the runner's round): progress of the long tasks."""
        if self.out.closed or t - self.last < PROGRESS_EVERY:
            return
        long = [r for r in self.tasks.report(t) if t - r["since"] >= PROGRESS_EVERY
                and ("bound" in r or "progress" in r)]  # not a watcher of the whole mission
        if long:
            self.last = t
        for running in long:
            self.out.say(f"{self.when(t)}  {running['task']:<22} … "
                         f"{task_detail(running, t)}")

    def __call__(self, record: Any) -> None:
        self.tasks(record)
        if self.out.closed:
            return
        d = record.data
        t = self.when(record.t)
        if record.kind in ("action", "event", "ignored", "note"):
            self.last = record.t
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
