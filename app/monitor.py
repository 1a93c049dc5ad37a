"""``mcl monitor``: the operator's live view of a mission and its vehicle, over Zenoh.

    mcl monitor --zenoh tcp/127.0.0.1:7447 [--name auv] [--until-end] [--plain]

It connects as an observer (it only reads): the player's mission status
(``mcl/<v>/mission/status``, asked for once at start so that a monitor started mid-mission
sees it at once), the vehicle's telemetry (``mcl/<v>/telemetry/*``) and both sides'
liveliness tokens (``mcl/<v>/alive/**``). On a terminal it redraws one screen in place a few
times a second (progress, not a log scroll); otherwise (``--plain``, a pipe, a file) it prints
one line whenever the mission's state changes.

Its exit statuses (docs/EXIT.md): OK on Ctrl-C or when the mission ended OK (``--until-end``),
FAILED when it ended FAIL or the vehicle was lost (``--until-end``: the player's word comes
through the vehicle), INVALID on invalid options, UNDECIDED when ``--timeout`` ran out first.
"""

from __future__ import annotations

import argparse
import json
import math
import shutil
import signal
import sys
import threading
import time
from collections.abc import Sequence
from typing import TYPE_CHECKING, Any, TextIO

from aal.zenoh_observer import SessionRefused
from diagnostics import MclError
from mission.exits import Exit
from app import arguments, zenoh_options
from app.monitor_fleet import (Watched, fleet_vehicles, follow, monitor_fleet, open_session,
                               refused)

if TYPE_CHECKING:
    from mission.foxglove_live import LiveView

REFRESH = 0.25  # wall s between redraws


class View:
    """What the monitor knows; updated from Zenoh's threads, read by the drawing loop."""

    def __init__(self, vehicle: str, endpoint: str):
        self.vehicle = vehicle
        self.endpoint = endpoint
        self.lock = threading.Lock()
        self.status: dict[str, Any] | None = None
        self.telemetry: dict[str, dict[str, Any]] = {}
        self.vehicle_alive: bool | None = None  # None: not seen yet
        self.players: set[str] = set()
        self.changed = threading.Event()
        self.forward: Any = None  # a live view (--foxglove) told what is heard, or None

    def on_status(self, payload: bytes) -> None:
        if self.forward is not None:
            self.forward.remote_status(payload)
        try:
            status = json.loads(payload)
            if not isinstance(status, dict) or status.get("v") != 1:
                return
        except ValueError:
            return
        with self.lock:
            if (self.status is None or status.get("run") != self.status.get("run")
                    or status.get("t", 0) >= self.status.get("t", 0)):
                self.status = status
        self.changed.set()

    def on_telemetry(self, stream: str, payload: bytes) -> None:
        if self.forward is not None and stream == "navigator":
            self.forward.remote_pose(payload)
        try:
            data = json.loads(payload)
        except ValueError:
            return
        if isinstance(data, dict):
            with self.lock:
                self.telemetry[stream] = data

    def on_alive(self, key: str, present: bool) -> None:
        with self.lock:
            if key.endswith("/alive/vehicle"):
                self.vehicle_alive = present
            elif "/alive/player/" in key:
                run = key.rpartition("/")[2]
                if present:
                    self.players.add(run)
                else:
                    self.players.discard(run)
        self.changed.set()

    def ended(self) -> str | None:
        with self.lock:
            status = self.status.get("status") if self.status else None
        return status if status in ("ok", "fail") else None

    # -- rendering -------------------------------------------------------------------------------
    def screen(self, width: int = 80) -> list[str]:
        """The full-screen view, one string per line, each cut at ``width`` columns (the
        terminal's: a longer line would wrap and break the redraw in place)."""
        with self.lock:
            st, tel = self.status, dict(self.telemetry)
            alive, players = self.vehicle_alive, len(self.players)
        clock = tel.get("clock", {})
        vstate = {None: "not seen", True: "alive", False: "LOST"}[alive]
        lines = [f"mcl monitor · vehicle {self.vehicle} @ {self.endpoint}",
                 f"vehicle {vstate}"
                 + (f" · clock {clock.get('t', 0):.1f} s at {clock.get('speed', 0):g}× wall"
                    if clock else "")
                 + f" · player {'present' if players else 'absent'}", ""]
        if st is None:
            lines.append("mission: none reported yet (waiting for a player)")
        else:
            done, total = int(st.get("done", 0)), int(st.get("total", 0))
            t = mission_time(st, clock)
            lines.append(f"mission {st.get('mission', '?')}  {mission_state(st, alive)}"
                         f"  t = {t:.1f} s{vehicle_time_beside(st, t)}"
                         f"  ({st.get('fired', 0)} firings)")
            lines.append(f"  {bar(done, total, 30)} {done}/{total} tasks done")
            running = [r for r in st.get("running") or [] if isinstance(r, dict)]
            lines.append("  running: " + ("" if running else "—"))
            lines.extend(f"    {task_text(r, t)}" for r in running)
            lines.append("  behaviours on: " + (", ".join(st.get("behaviours") or []) or "—"))
            ev, ac = st.get("last_event"), st.get("last_action")
            if ev:
                lines.append(f"  last event:  {ev['event']} at {ev['t']:.1f} s")
            if ac:
                lines.append(f"  last action: {ac['action']} {ac['behaviour']} at {ac['t']:.1f} s"
                             f" ({ac.get('task', '')})")
        nav, wall, beh = tel.get("navigator"), tel.get("wall"), tel.get("behaviours")
        lines.append("")
        if nav:
            lines.append(f"navigator  x {nav['x']:7.2f}  y {nav['y']:7.2f}  z {nav['z']:6.2f} m"
                         f"  yaw {_deg(nav['yaw']):6.1f}°  u {nav['u']:5.2f} m/s")
        if wall:
            lines.append("wall       " + (f"distance {wall['distance']:.2f} m  heading "
                                         f"{_deg(wall['heading']):.1f}°" if wall.get("detected")
                                         else "not tracked"))
        if beh:
            lines.append("vehicle    active: " + (", ".join(beh.get("active") or []) or "—")
                         + ("  FAILSAFE" if beh.get("failsafe") else "")
                         + f"  (actions {beh.get('actions', 0)}, events {beh.get('events', 0)},"
                           f" dropped {beh.get('dropped', 0)}, stale {beh.get('stale', 0)})")
        return [line[:width] for line in lines]

    def line(self) -> str:
        """One line: the mission's state (for --plain)."""
        with self.lock:
            st = self.status
            alive = self.vehicle_alive
        vstate = {None: "vehicle not seen", True: "vehicle alive", False: "vehicle LOST"}[alive]
        if st is None:
            return f"{vstate}; no mission yet"
        t = float(st.get("t", 0))
        running = ", ".join(task_text(r, t) for r in st.get("running") or []
                            if isinstance(r, dict)) or "—"
        return (f"{t:8.1f} s{vehicle_time_beside(st, t)}  "
                f"{st.get('mission', '?')} "
                f"{mission_state(st, alive)}  {st.get('done', 0)}/{st.get('total', 0)} "
                f"tasks done  running: {running}  ({vstate})")


def mission_state(status: dict[str, Any], alive: bool | None) -> str:
    """The mission's state as the monitor shows it: the player's word, but LOST for a
    mission still running on a vehicle that is lost (its end cannot be known from here)."""
    state = str(status.get("status")).upper()
    return "LOST" if alive is False and state == "RUNNING" else state


def task_text(running: dict[str, Any], t: float) -> str:
    """One running task: its call, how far along (waypoint k of n, metres to go), how long it
    has run and the time left of its bound: ``WallInspect@39:13 (waypoint 12/82, 96.3 m to
    go; 240 s, 1377 s left of 3600 s)``."""
    parts: list[str] = []
    progress = running.get("progress")
    if isinstance(progress, dict):
        if "waypoint" in progress and "of" in progress:
            parts.append(f"waypoint {progress['waypoint']}/{progress['of']}")
        if isinstance(progress.get("to_go"), (int, float)):
            parts.append(f"{progress['to_go']:g} m to go")
    timing = [f"{max(0.0, t - float(running.get('since', t))):.0f} s"]
    bound, since = running.get("bound"), running.get("since")
    if isinstance(bound, (int, float)) and isinstance(since, (int, float)):
        left = max(0.0, since + bound - t)
        timing.append(f"{left:.0f} s left of {bound:g} s")
    detail = ", ".join(parts) + ("; " if parts else "") + ", ".join(timing)
    return f"{running.get('task', '?')} ({detail})"


def task_detail(running: dict[str, Any], t: float) -> str:
    """:func:`task_text` without the call: ``waypoint 12/82, 96.3 m to go; 240 s, ...``."""
    return task_text(running, t).partition(" (")[2][:-1]


def mission_time(status: dict[str, Any], clock: dict[str, Any]) -> float:
    """Mission time now: the status's, plus the vehicle clock's progress since (while the
    mission runs and the vehicle's clock is known)."""
    t = float(status.get("t", 0))
    if status.get("status") == "running" and clock and "clock" in status:
        t += max(0.0, float(clock.get("t", 0)) - float(status["clock"]))
    return t


def vehicle_time_beside(status: dict[str, Any], t: float) -> str:
    """The vehicle's clock at mission time ``t``, when it differs from mission time."""
    try:
        offset = float(status.get("clock", status.get("t", 0))) - float(status.get("t", 0))
    except (TypeError, ValueError):
        return ""
    return f" (vehicle {t + offset:.1f} s)" if abs(offset) >= 0.05 else ""


def bar(done: int, total: int, width: int) -> str:
    filled = round(width * done / total) if total else 0
    return "[" + "#" * filled + "." * (width - filled) + "]"


def _deg(radians: Any) -> float:
    import math

    return math.degrees(float(radians or 0.0))


def watch(view: Watched, until_end: bool, timeout: float | None, plain: bool,
          out: TextIO, stop: threading.Event) -> int:
    """The drawing loop: bounded by ``stop``, the mission's end (``until_end``) and
    ``timeout`` wall seconds."""
    deadline = time.monotonic() + timeout if timeout else None
    last_line = ""
    while not stop.is_set():
        # the end is judged before the frame is drawn, so that the last frame shows it (a
        # status that comes between would otherwise end the watch on a frame without it)
        ended, alive = view.ended(), view.vehicle_alive
        if plain:
            line = view.line()
            if line != last_line:
                print(line, file=out, flush=True)
                last_line = line
        else:
            width = shutil.get_terminal_size().columns  # the terminal's, as it is now
            out.write("\x1b[H\x1b[J" + "\n".join(view.screen(width)) + "\n")
            out.flush()
        if until_end and ended:
            print(f"mission ended {ended.upper()}", file=out, flush=True)
            return Exit.OK if ended == "ok" else Exit.FAILED
        if until_end and alive is False:  # the player's word comes through it
            print("vehicle lost: the mission's end cannot be known from here", file=out,
                  flush=True)
            return Exit.FAILED
        if deadline is not None and time.monotonic() >= deadline:
            print(f"mcl monitor: --timeout of {timeout:g} s reached", file=sys.stderr)
            return Exit.UNDECIDED
        view.changed.wait(REFRESH)
        view.changed.clear()
    return Exit.OK


def _check_options(args: argparse.Namespace) -> str | None:
    from aal.zenoh import option_error

    if args.timeout is not None and not (math.isfinite(args.timeout) and args.timeout > 0):
        return f"--timeout {args.timeout:g}: error: must be a positive number of seconds"
    if args.fleet_vehicle:
        if args.foxglove:
            return "--foxglove: error: not with --fleet-vehicle (it serves one vehicle)"
        vehicles = fleet_vehicles(args.fleet_vehicle)
        if isinstance(vehicles, str):
            return vehicles
        for endpoint in vehicles.values():  # the security options, for each endpoint
            try:
                zenoh_options.from_args(
                    argparse.Namespace(**{**vars(args), "zenoh": endpoint}), "observer")
            except ValueError as exc:
                return f"mcl monitor: error: {exc}"
    return option_error(args.zenoh, args.name)


def main(argv: Sequence[str] | None = None) -> int:
    from aal.zenoh import DEFAULT_ENDPOINT

    p = arguments.Parser(prog="mcl monitor",
                                description="Watch a mission and its vehicle over Zenoh.")
    p.add_argument("--zenoh", default=DEFAULT_ENDPOINT, metavar="ENDPOINT",
                   help=f"the vehicle's endpoint (default {DEFAULT_ENDPOINT})")
    p.add_argument("--name", default="auv", help="vehicle name in the keys (default auv)")
    p.add_argument("--until-end", action="store_true",
                   help="exit when the mission ends: status 0 if OK, 1 if FAIL or if the "
                        "vehicle is lost")
    p.add_argument("--timeout", type=float, metavar="SECONDS",
                   help="give up after this many wall seconds (exit 4: no verdict)")
    p.add_argument("--plain", action="store_true",
                   help="one line per change instead of a screen (default when not a terminal)")
    p.add_argument("--scouting", action="store_true",
                   help="also find the vehicle by Zenoh's multicast scouting (off by default)")
    p.add_argument("--foxglove", metavar="HOST:PORT", default=None,
                   help="also serve what the monitor hears to Foxglove (its WebSocket "
                        "protocol, foxglove.sdk.v1): the mission's status and the navigator's "
                        "pose; needs the optional extra mcl-auv[foxglove] (docs/MCAP.md)")
    p.add_argument("--fleet-vehicle", action="append", default=[], metavar="NAME=ENDPOINT",
                   help="watch every vehicle of a fleet, each at its endpoint (repeat it; "
                        "instead of --zenoh and --name), and the messages on the fleet's "
                        "channels (docs/FLEET_ZENOH.md)")
    zenoh_options.add_arguments(p, "observer")
    args = p.parse_args(argv)
    try:
        security = zenoh_options.from_args(args, "observer")
    except ValueError as exc:
        p.error(str(exc))
    problem = _check_options(args)
    if problem:  # one line naming the option
        print(problem, file=sys.stderr)
        return Exit.INVALID
    live = _live(args.foxglove)
    if isinstance(live, str):
        print(live, file=sys.stderr)
        return Exit.INVALID
    try:
        return _monitor(args, security, live)
    finally:
        if live is not None:
            live.close()


def _live(where: str | None) -> LiveView | str | None:
    """The live view of ``--foxglove`` (None without it), or why not, on one line."""
    if where is None:
        return None
    from mission.foxglove_live import LiveView, address  # start-up speed: only --foxglove

    try:
        live = LiveView(*address(where), {}, [])
    except ValueError as exc:
        return f"mcl monitor: --foxglove: {exc}"
    except MclError as exc:
        return f"mcl monitor: {exc}"
    print(f"mcl monitor: serving Foxglove at ws://{where.rpartition(':')[0]}:{live.port} "
          "(foxglove.sdk.v1)", file=sys.stderr, flush=True)
    return live


def _monitor(args: argparse.Namespace, security: Any, live: LiveView | None) -> int:
    """Watch over Zenoh until the end, the timeout or a signal."""
    from aal.zenoh import close_session  # start-up speed: it imports zenoh

    if args.fleet_vehicle:  # every vehicle of a fleet
        return monitor_fleet(args, View, watch)
    view = View(args.name, args.zenoh)
    if live is not None:
        view.forward = live
    stop = threading.Event()
    for sig in (signal.SIGTERM, signal.SIGINT):
        signal.signal(sig, lambda *_: stop.set())
    try:
        session = open_session(args.zenoh, security, args.scouting, args.timeout, stop)
    except SessionRefused as exc:
        return refused(exc)
    if session is None:
        return Exit.UNDECIDED if not stop.is_set() else Exit.OK
    try:
        entities = follow(session, view)
        plain = args.plain or not sys.stdout.isatty()
        code = watch(view, args.until_end, args.timeout, plain, sys.stdout, stop)
        for e in entities:
            e.undeclare()
        return code
    finally:
        close_session(session)


if __name__ == "__main__":
    sys.exit(main())
