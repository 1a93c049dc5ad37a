"""``mcl vehicle``: serve the simulated Ictineu to a player in another process.

    mcl vehicle --zenoh ENDPOINT [--name auv] [--speed 10] [--seed 1] [--inject leak@600] ...
    mcl vehicle --mavlink URL [--speed 10] [--seed 1] [--inject leak@600] ...
    mcl vehicle --world mcm --zenoh ASV_ENDPOINT,UUV_ENDPOINT [--seed 1] [--inject clutter@60]

Over Zenoh the server is :mod:`vehicle.servers.zenoh_server` (docs/ZENOH.md); over MAVLink 2 the
ArduSub-like vehicle of :mod:`vehicle.servers.ardusub` (docs/MAVLINK.md); ``--world mcm``
serves paper 003's ASV and UUV, of one simulated world, each on its own Zenoh endpoint
(:mod:`vehicle.servers.mcm_server`, docs/FLEET_ZENOH.md). Both print ``vehicle auv
ready on ...`` when ready and their summary when stopped (SIGTERM, SIGINT). Its exit statuses
(stopped, invalid input: one line naming the option): docs/EXIT.md.
"""

from __future__ import annotations

import argparse
import dataclasses
import logging
import math
import signal
import sys
import threading
from collections.abc import Sequence
from typing import Any

from mission.exits import Exit

from app import arguments, zenoh_options

LOG_LEVELS = ("DEBUG", "INFO", "WARNING", "ERROR", "CRITICAL")
WORLDS = ("ictineu", "mcm")


def main(argv: Sequence[str] | None = None) -> int:
    """``mcl vehicle ARGS`` (``argv``: what follows ``vehicle``)."""
    args = list(sys.argv[1:] if argv is None else argv)
    if any(a == "--mavlink" or a.startswith("--mavlink=") for a in args):
        return mavlink_main(args)
    return zenoh_main(args)


def fault_argument(text: str) -> tuple[str, float]:
    """``--inject FAULT@SECONDS``: a bad fault is a usage error, not a traceback."""
    from vehicle.control.stack import parse_fault

    try:
        return parse_fault(text)
    except ValueError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None


def _stop_on_signals() -> threading.Event:
    stop = threading.Event()
    for sig in (signal.SIGTERM, signal.SIGINT):
        signal.signal(sig, lambda *_: stop.set())
    return stop


# -- over Zenoh ------------------------------------------------------------------------------------
def _zenoh_parser() -> argparse.ArgumentParser:
    from aal.zenoh import DEFAULT_ENDPOINT

    p = arguments.Parser(
        prog="mcl vehicle", description="Serve the simulated Ictineu over Zenoh.",
        epilog="For an ArduSub-like MAVLink vehicle instead: mcl vehicle --mavlink URL "
               "(see 'mcl vehicle --mavlink URL --help' and docs/MAVLINK.md).")
    p.add_argument("--zenoh", default=DEFAULT_ENDPOINT, metavar="ENDPOINT",
                   help=f"endpoint to listen on (default {DEFAULT_ENDPOINT})")
    p.add_argument("--name", default="auv", help="vehicle name in the keys (default auv)")
    p.add_argument("--speed", type=float, default=10.0, help="times wall time (default 10)")
    p.add_argument("--seed", type=arguments.seed, default=1)
    p.add_argument("--inject", action="append", default=[], metavar="FAULT@SECONDS",
                   help="a fault (the Ictineu's, e.g. leak@600; with --world mcm: "
                        "clutter@S, falsetarget@S, current=VX,VY)")
    p.add_argument("--world", choices=WORLDS, default="ictineu",
                   help="ictineu (default): one simulated Ictineu; mcm: paper 003's ASV and "
                        "UUV in one world, --zenoh ASV_ENDPOINT,UUV_ENDPOINT, --name asv,uuv "
                        "(docs/FLEET_ZENOH.md)")
    p.add_argument("--player-timeout", type=float, default=3.0, metavar="WALL_SECONDS",
                   help="surface after the player has been gone this long (default 3)")
    p.add_argument("--no-wait", action="store_true",
                   help="start the clock at once instead of when a player appears")
    p.add_argument("--scouting", action="store_true",
                   help="also be found by Zenoh's multicast scouting (off by default)")
    p.add_argument("--log-level", default="WARNING")
    p.add_argument("--fleet", metavar="FLEET.mcl", default=None,
                   help="this vehicle is --name of this fleet: with --users or TLS, its player "
                        "may put on the channels it sends on, nobody else (docs/FLEET_ZENOH.md)")
    zenoh_options.add_arguments(p, "vehicle")
    return p


def zenoh_main(argv: list[str]) -> int:
    import zenoh

    from aal.zenoh import zenoh_error
    from vehicle.servers import zenoh_server

    p = _zenoh_parser()
    args = p.parse_args(argv)
    try:
        security = zenoh_options.from_args(args, "vehicle")
    except ValueError as exc:
        p.error(str(exc))
    try:
        args.inject = faults_of(args.world, args.inject)
    except ValueError as exc:
        p.error(f"argument --inject: {exc}")
    problem = _zenoh_problem(args)
    if problem:
        print(problem, file=sys.stderr)
        return Exit.INVALID
    if args.world == "mcm":
        return mcm_main(args, security)
    if args.fleet is not None:  # the channels its player may put on (app/fleet_zenoh.py)
        from app.fleet_zenoh import sent_keys  # start-up speed: it compiles the fleet
        from diagnostics import MclError

        try:
            security = dataclasses.replace(security, channels=sent_keys(args.fleet, args.name))
        except MclError as exc:  # not a fleet, no such vehicle: file:line:col and a hint
            print(exc.format(), file=sys.stderr)
            return Exit.INVALID
    logging.basicConfig(level=args.log_level.upper(),
                        format="%(asctime)s vehicle %(levelname)s %(message)s")
    stop = _stop_on_signals()
    ready = threading.Event()
    server = zenoh_server.VehicleServer(
        args.zenoh, args.name, args.speed, args.seed, args.inject, stop, args.player_timeout,
        wait_for_player=not args.no_wait, ready=ready, security=security,
        scouting=args.scouting)

    _announce(ready, f"vehicle {args.name} ready on {args.zenoh}")
    try:
        server.run()
    except zenoh.ZError as exc:
        print(f"--zenoh {args.zenoh}: error: {zenoh_error(exc)}", file=sys.stderr)
        return Exit.INVALID
    print(stopped(args.name, server), flush=True)
    return Exit.OK


def faults_of(world: str, given: list[str]) -> list[tuple[str, Any]]:
    """``--inject`` for the world served; ValueError saying what to write."""
    if world == "mcm":
        from vehicle.control.mcm_stack import parse_mcm_fault  # start-up speed: numpy

        return [parse_mcm_fault(text) for text in given]
    from vehicle.control.stack import parse_fault

    return [parse_fault(text) for text in given]


def world_names(args: argparse.Namespace) -> list[str]:
    """The names of paper 003's two vehicles: ``--name ASV,UUV``, default asv,uuv (the
    vehicles of missions/mcm.mcl)."""
    return args.name.split(",") if args.name != "auv" else ["asv", "uuv"]


def mcm_main(args: argparse.Namespace, security: Any) -> int:
    """``mcl vehicle --world mcm``: paper 003's ASV and UUV, one world, two endpoints."""
    import zenoh

    from aal.zenoh import zenoh_error
    from vehicle.servers.mcm_server import McmServer

    endpoints, names = args.zenoh.split(","), world_names(args)
    if len(endpoints) != 2 or len(names) != 2 or len(set(names)) != 2:
        print(f"--zenoh {args.zenoh}: error: --world mcm serves two vehicles: give "
              "--zenoh ASV_ENDPOINT,UUV_ENDPOINT (and --name ASV,UUV, default asv,uuv)",
              file=sys.stderr)
        return Exit.INVALID
    secured: dict[str, Any] = {name: security for name in names}
    if args.fleet is not None:  # the channels each player may put on (app/fleet_zenoh.py)
        from app.fleet_zenoh import sent_keys  # start-up speed: it compiles the fleet
        from diagnostics import MclError

        try:
            secured = {n: dataclasses.replace(security, channels=sent_keys(args.fleet, n))
                       for n in names}
        except MclError as exc:
            print(exc.format(), file=sys.stderr)
            return Exit.INVALID
    logging.basicConfig(level=args.log_level.upper(),
                        format="%(asctime)s vehicle %(levelname)s %(message)s")
    stop, ready = _stop_on_signals(), threading.Event()
    world = McmServer(endpoints, names, args.speed, args.seed, args.inject, stop=stop,
                      player_timeout=args.player_timeout, wait_for_player=not args.no_wait,
                      ready=ready, security=secured, scouting=args.scouting)
    _announce(ready, "\n".join(f"vehicle {n} ready on {e}"
                               for n, e in zip(names, endpoints, strict=True)))
    try:
        world.run()
    except zenoh.ZError as exc:
        print(f"--zenoh {args.zenoh}: error: {zenoh_error(exc)}", file=sys.stderr)
        return Exit.INVALID
    for server in world.servers:  # and its figures against the simulated ground truth
        print(stopped(server.name, server), flush=True)
        for what, figure in server.stack.figures().items():
            print(f"  {what}: {figure}", flush=True)
    return Exit.OK


def stopped(name: str, server: Any) -> str:
    """What the Zenoh vehicle says when it stops: its simulated time, the actions it took,
    the stale ones and the invalid ones it dropped (no run id, not an action), and the
    behaviours still on."""
    on = sorted(b.name for b in server.stack.behaviours.values() if b.active)
    return (f"vehicle {name} stopped after {server.stack.t:.1f} s of simulated time "
            f"({server.actions} actions, {server.stale} stale, {server.dropped} invalid "
            f"dropped)\n  behaviours on at exit: {', '.join(on) or 'none'}")


def _zenoh_problem(args: argparse.Namespace) -> str | None:
    """An option that parses but means nothing: one line naming it (exit 2), else None."""
    from aal.zenoh import option_error

    served = (zip(args.zenoh.split(","), world_names(args), strict=False)
              if args.world == "mcm" else [(args.zenoh, args.name)])
    for endpoint, name in served:
        if problem := option_error(endpoint, name):
            return problem
    for option, value in (("--speed", args.speed), ("--player-timeout", args.player_timeout)):
        if not (math.isfinite(value) and value > 0):
            return f"{option} {value:g}: error: must be a positive number"
    if args.speed > arguments.MAX_SPEED:  # 1e308 fired every timer at once
        return f"--speed {args.speed:g}: error: must be at most {arguments.MAX_SPEED:g}"
    if args.log_level.upper() not in LOG_LEVELS:
        return (f"--log-level {args.log_level}: error: use DEBUG, INFO, WARNING, ERROR or "
                "CRITICAL")
    return None


# -- over MAVLink 2 --------------------------------------------------------------------------------
def _mavlink_parser() -> argparse.ArgumentParser:
    from aal.signing import ENV_KEY

    p = arguments.Parser(
        prog="mcl vehicle",
        description="Serve the simulated Ictineu as an ArduSub-like MAVLink 2 vehicle.")
    p.add_argument("--mavlink", required=True, metavar="URL",
                   help="udpout:HOST:PORT, udpin:HOST:PORT, tcp:HOST:PORT or tcpin:HOST:PORT")
    p.add_argument("--speed", type=float, default=10.0, help="times wall time (default 10)")
    p.add_argument("--seed", type=arguments.seed, default=1)
    p.add_argument("--inject", action="append", default=[], type=fault_argument,
                   metavar="FAULT@SECONDS")
    p.add_argument("--gcs-timeout", type=float, default=3.0, metavar="WALL_SECONDS",
                   help="ground-station failsafe after this long without its heartbeat "
                        "(default 3)")
    p.add_argument("--pilot-timeout", type=float, default=3.0, metavar="WALL_SECONDS",
                   help="pilot-input failsafe after this long without MANUAL_CONTROL while "
                        "armed (default 3)")
    p.add_argument("--no-wait", action="store_true",
                   help="start the clock at once instead of at the first GCS heartbeat")
    p.add_argument("--signing-key", metavar="FILE",
                   help=f"MAVLink 2 signing key or passphrase (default ${ENV_KEY})")
    p.add_argument("--require-signing", action="store_true",
                   help="reject unsigned messages (needs a key)")
    p.add_argument("--log-level", default="WARNING")
    return p


def mavlink_main(argv: list[str]) -> int:
    from aal import signing
    from vehicle.servers import ardusub

    args = _mavlink_parser().parse_args(argv)
    try:
        url = ardusub.check_url(args.mavlink)
        if not (args.speed > 0 and math.isfinite(args.speed)):
            raise ValueError(f"--speed {args.speed}: must be a positive number")
        if args.speed > arguments.MAX_SPEED:  # 1e308 fired every timer at once
            raise ValueError(f"--speed {args.speed:g}: must be at most "
                             f"{arguments.MAX_SPEED:g}")
        key = signing.load_key(args.signing_key)
        if args.require_signing and key is None:
            raise ValueError(f"--require-signing needs a key: --signing-key FILE or "
                             f"${signing.ENV_KEY}")
        for option, value in (("--gcs-timeout", args.gcs_timeout),
                              ("--pilot-timeout", args.pilot_timeout)):
            if not (value > 0 and math.isfinite(value)):
                raise ValueError(f"{option} {value}: must be a positive number of seconds")
        if args.log_level.upper() not in LOG_LEVELS:
            raise ValueError(f"--log-level {args.log_level}: use DEBUG, INFO, WARNING, ERROR "
                             "or CRITICAL")
    except (ValueError, signing.SigningError) as exc:
        print(f"mcl vehicle: error: {exc}", file=sys.stderr)
        return Exit.INVALID
    logging.basicConfig(level=args.log_level.upper(),
                        format="%(asctime)s vehicle %(levelname)s %(message)s")
    stop, ready = _stop_on_signals(), threading.Event()
    vehicle = ardusub.ArduSubVehicle(
        url, speed=args.speed, seed=args.seed, faults=args.inject,
        gcs_timeout=args.gcs_timeout, pilot_timeout=args.pilot_timeout,
        wait_for_gcs=not args.no_wait, signing_key=key, require_signing=args.require_signing,
        stop=stop, ready=ready)
    _announce(ready, f"vehicle auv ready on {url}")
    try:
        vehicle.run()
    except signing.SigningError as exc:  # e.g. a signing state it cannot write
        print(f"mcl vehicle: error: {exc}", file=sys.stderr)
        return Exit.INVALID
    except OSError as exc:
        print(f"mcl vehicle: error: {args.mavlink}: {exc}", file=sys.stderr)
        return Exit.INVALID
    print("\n".join(vehicle.summary()), flush=True)
    return Exit.OK


def _announce(ready: threading.Event, line: str) -> None:
    """Print ``line`` once the vehicle is ready, from a thread of its own; a closed standard
    output (``mcl vehicle ... | head -1``) does not stop the vehicle nor print a traceback."""
    def announce() -> None:
        ready.wait()
        try:
            print(line, flush=True)
        except (OSError, ValueError):  # standard output closed: keep serving
            pass

    threading.Thread(target=announce, name="announce", daemon=True).start()


if __name__ == "__main__":
    sys.exit(main())
