"""``mcl view``: the mission in a browser, from a finished run log or a live run.

    mcl view RUN.jsonl MISSION.mcl [--tasks FILE] [--port N]
    mcl view --zenoh ENDPOINT MISSION.mcl [--name auv] [--port N]
    mcl view RUNDIR FLEET.mcl [--port N]
    mcl view FLEET.mcl --fleet-vehicle NAME=ENDPOINT ... [--port N]

A fleet's run (the folder ``mcl run FLEET.mcl --log-dir RUNDIR`` wrote) shows every
vehicle's tree under the fleet's, with every vehicle's timeline and the channels' messages
(app/view/fleet.py); with ``--fleet-vehicle`` for each of its vehicles, the same page follows
a fleet's live run over Zenoh (app/view/live_fleet.py).

From a log, it checks the log as ``mcl replay`` does (its lines and digest chain, then every
record against the mission's net: the page shows only a legal run). Live, it follows the
mission status the player publishes over Zenoh (app/view/live.py). Either way it serves the
page on ``http://127.0.0.1:PORT/`` (a free port unless ``--port``) and prints that address as
its first line, until Ctrl-C (live: until a vehicle refuses its credentials, exit 2).
``?t=SECONDS`` opens the page at that instant. What the page
shows: app/view/data.py; the server: app/view/server.py. Exit statuses (docs/EXIT.md): 0 when
stopped, 2 on invalid input (a log that cannot be read or is not a run of the mission, an
option, credentials a live vehicle refuses).
"""

from __future__ import annotations

import argparse
import signal
import sys
import threading
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

from mcl.api import Compiled, compile_file
from mcl.fleet import compile_fleet_file, is_fleet
from mission.exits import Exit

from app import arguments
from app.guard import guarded


def _parser() -> argparse.ArgumentParser:
    from app import zenoh_options

    p = arguments.Parser(prog="mcl view", usage="mcl view RUN.jsonl MISSION.mcl "
                                "[options]\n       mcl view RUNDIR FLEET.mcl [options]"
                                "\n       mcl view --zenoh ENDPOINT MISSION.mcl "
                                "[options]\n       mcl view FLEET.mcl --fleet-vehicle "
                                "NAME=ENDPOINT ... [options]", description="Show a run of a mission in a "
                                "browser: its tree with each block's state, the timeline, the "
                                "track, the proved bounds, the mosaic.")
    p.add_argument("files", nargs="+", metavar="FILE",
                   help="the run log and its mission, or a fleet's log folder and its "
                        "fleet; with --zenoh, the mission alone")
    p.add_argument("--zenoh", metavar="ENDPOINT", help="follow a live run on the vehicle at "
                   "this endpoint (e.g. tcp/127.0.0.1:7447) instead of a log")
    p.add_argument("--fleet-vehicle", action="append", default=[], metavar="NAME=ENDPOINT",
                   help="follow a fleet's live run: where vehicle NAME of the fleet is "
                        "reached (one for each vehicle)")
    p.add_argument("--name", default="auv", help="--zenoh: the vehicle's name in the keys "
                   "(default auv); one view per vehicle of a fleet")
    p.add_argument("--tasks", action="append", default=[], metavar="FILE",
                   help="task library (.tasks), as for the run")
    p.add_argument("--port", type=int, default=0, help="the port on 127.0.0.1 (default: a "
                   "free one)")
    p.add_argument("--debug", action="store_true")
    zenoh_options.add_arguments(p, "observer")
    return p


def main(argv: list[str] | None = None) -> int:
    """``mcl view ARGS`` (``argv``: what follows ``view``)."""
    p = _parser()
    args = p.parse_args(sys.argv[1:] if argv is None else argv)
    wanted = 1 if args.zenoh or args.fleet_vehicle else 2
    if len(args.files) != wanted or (args.zenoh and args.fleet_vehicle):
        p.error("give RUN.jsonl MISSION.mcl, or --zenoh ENDPOINT MISSION.mcl, or FLEET.mcl "
                "--fleet-vehicle NAME=ENDPOINT ...")
    if not 0 <= args.port <= 65535:
        print(f"--port {args.port}: error: not a port (0 to 65535)", file=sys.stderr)
        return Exit.INVALID
    return guarded("view", args.debug, lambda: _view(args))


class Refused(Exception):
    """The log cannot be shown: its one-line reason."""


def load(log: str, mission: str, tasks: list[str]) -> tuple[Compiled, list[dict[str, Any]]]:
    """The mission compiled with the log's parameters, and the log's records once its chain
    holds and every record conforms to the mission's net; Refused otherwise."""
    from diagnostics import Source
    from mcl import parser
    from petri.execution.replay import check
    from petri.execution.runlog import LogError, read_log, verify

    try:
        records = read_log(log)
        verify(records, log)
    except LogError as exc:
        raise Refused(f"{log}:{exc.line or 1}: error: {exc.reason}") from None
    params = records[0].get("params") or {}
    overrides = {name: (parser.parse_value(str(text), "<log header>"),
                        Source(f"{log} header: {name}", str(text)))
                 for name, text in params.items()}
    compiled = compile_file(mission, tasks or None, overrides, require_values=True)
    result = check(compiled.net, records, {})
    if not result.ok:
        raise Refused(f"{log}:{result.line}: error: not a run of {mission}: {result.reason}")
    return compiled, records


def _view(args: argparse.Namespace) -> int:
    from app.view.data import mission_data, page_data, pictures
    from app.view.live import LiveRun, follow
    from app.view.server import Provider, ViewServer

    stop = threading.Event()
    found: dict[str, Path] = {}
    refused: Callable[[], str] = str  # why a live vehicle refused the view ("": none did)
    followers: list[threading.Thread] = []  # the threads that follow live vehicles over Zenoh
    if args.zenoh:
        problem = _zenoh_problem(args)
        if problem:
            print(problem, file=sys.stderr)
            return Exit.INVALID
        from app import zenoh_options

        try:
            security = zenoh_options.from_args(args, "observer")
        except ValueError as exc:
            print(f"mcl view: error: {exc}", file=sys.stderr)
            return Exit.INVALID
        live = LiveRun(mission_data(compile_file(args.files[0], args.tasks or None)),
                       args.name, args.zenoh)
        provider: Provider = live.data
        refused = lambda: live.refused  # noqa: E731
        followers.append(threading.Thread(target=follow, args=(live, args.zenoh, security, stop,
                                                               threading.Event()),
                                          name="mcl-view-zenoh", daemon=True))
        what = f"live from {args.zenoh}"
    elif args.fleet_vehicle:
        live_fleet = _live_fleet(args, stop, followers)
        if isinstance(live_fleet, str):
            print(live_fleet, file=sys.stderr)
            return Exit.INVALID
        provider, refused = live_fleet.data, live_fleet.refused
        what = f"live from {len(live_fleet.runs)} vehicles"
    elif Path(args.files[0]).is_dir() or is_fleet(args.files[1]):
        from app.view.fleet import fleet_data, load_fleet  # as above: for start-up speed

        fleet, logs, record = load_fleet(args.files[0], args.files[1])
        whole = fleet_data(fleet, logs, record, Path(args.files[0]))
        provider, found = (lambda: whole), {}
        what = f"{len(logs)} vehicles' logs"
    else:
        try:
            compiled, records = load(args.files[0], args.files[1], args.tasks)
        except Refused as exc:
            print(exc, file=sys.stderr)
            return Exit.INVALID
        data = page_data(compiled, records, Path(args.files[0]))
        provider, found = (lambda: data), pictures(Path(args.files[0]))
        what = f"{len(records)} records"
    try:
        server = ViewServer(provider, found, args.port)
    except OSError as exc:
        print(f"--port {args.port}: error: cannot serve on it ({exc.strerror})",
              file=sys.stderr)
        return Exit.INVALID
    for sig in (signal.SIGTERM, signal.SIGINT):
        signal.signal(sig, lambda *_: stop.set())
    server.start()
    for thread in followers:
        thread.start()
    print(f"mcl view: {server.url} ({provider()['mission']}, {what}; Ctrl-C to stop)",
          flush=True)
    try:
        while not stop.wait(0.5) and not refused():
            pass
    finally:
        stop.set()
        server.shutdown()
        server.server_close()
        _join(followers)
    if refused():  # wrong credentials: one line, exit 2
        print(refused(), file=sys.stderr)
        return Exit.INVALID
    return Exit.OK


def _zenoh_problem(args: argparse.Namespace) -> str | None:
    from aal.zenoh import option_error

    return option_error(args.zenoh, args.name)


FOLLOWERS_JOIN = 15.0  # seconds for the followers to leave Zenoh after ``stop`` (a session
#                       being opened finishes its attempt first)


def _join(followers: list[threading.Thread]) -> None:
    """Wait for the followers to close their sessions: an interpreter that exits while a thread
    is inside Zenoh's native code aborts ("FATAL: exception not rethrown", exit -6) instead
    of returning the view's exit status."""
    deadline = time.monotonic() + FOLLOWERS_JOIN
    for thread in followers:
        if thread.ident is not None:
            thread.join(max(0.0, deadline - time.monotonic()))


def _live_fleet(args: argparse.Namespace, stop: threading.Event,
                followers: list[threading.Thread]) -> Any:
    """The fleet's live run, followed on ``followers`` (threads, not yet started) until
    ``stop``; or the one line saying what is wrong with the options."""
    from app import zenoh_options
    from app.monitor_fleet import fleet_vehicles
    from app.view.live import follow
    from app.view.live_fleet import LiveFleet, follow_channels

    endpoints = fleet_vehicles(args.fleet_vehicle)
    if isinstance(endpoints, str):
        return endpoints
    fleet = compile_fleet_file(args.files[0], require_values=True)
    unknown = [name for name in endpoints if name not in fleet.vehicles]
    missing = [name for name in fleet.vehicles if name not in endpoints]
    if unknown or missing:
        what = (f"fleet {fleet.name} has no vehicle '{unknown[0]}'" if unknown else
                f"say where vehicle {missing[0]} is (--fleet-vehicle {missing[0]}=ENDPOINT)")
        return (f"{args.files[0]}:1:1: error: --fleet-vehicle: {what}; its vehicles: "
                f"{', '.join(fleet.vehicles)}")
    securities = {}
    for endpoint in dict.fromkeys(endpoints.values()):
        try:
            securities[endpoint] = zenoh_options.from_args(
                argparse.Namespace(**{**vars(args), "zenoh": endpoint}), "observer")
        except ValueError as exc:
            return f"mcl view: error: {exc}"
    live = LiveFleet(fleet, endpoints)
    for name, run in live.runs.items():
        followers.append(threading.Thread(
            target=follow, args=(run, run.endpoint, securities[run.endpoint], stop,
                                 threading.Event()), name=f"mcl-view-{name}", daemon=True))
    followers.append(threading.Thread(
        target=follow_channels, args=(live, list(securities), securities, stop,
                                      threading.Event()), name="mcl-view-channels", daemon=True))
    return live
