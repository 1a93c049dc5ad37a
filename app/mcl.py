"""``mcl``: the operator's command; each subcommand is one module of ``app/``.

    mcl run MISSION.mcl [--vehicle KIND[:WHERE]] ...   app/run.py (kinds: app/vehicles/)
    mcl replay RUN.jsonl MISSION.mcl                   app/replay.py
    mcl check MISSION.mcl ...                          app/check.py (the same as mclc)
    mcl vehicle --zenoh ENDPOINT | --mavlink URL ...   app/vehicle.py
    mcl monitor --zenoh ENDPOINT ...                   app/monitor.py
    mcl mosaic RUN.jsonl ...                           app/mosaic.py
    mcl view RUN.jsonl MISSION.mcl                     app/view/command.py (in a browser)
    mcl export RUN.jsonl... --mcap OUT.mcap            app/export.py (docs/MCAP.md)
    mcl lsp                                            app/lsp/server.py (for editors)
    mcl fmt MISSION.mcl... [--check | --diff]          app/fmt.py

Each module's ``main(argv)`` takes what follows the subcommand and returns the exit status
(docs/EXIT.md). A standard output closed under a command (``mcl ... | head -1``) ends it quietly.
"""

from __future__ import annotations

import argparse
import importlib
import os
import sys
import threading
from collections.abc import Callable
from typing import cast

from app.blas import one_blas_thread
from app.streams import lost_line, open_standard_streams, stdout_closed, watched_stdout
from app.version import VersionAction
from app import arguments
from mission.exits import Exit

COMMANDS = {  # subcommand: (its module, its line in 'mcl --help')
    "run": ("app.run", "run a mission on a vehicle"),
    "vehicle": ("app.vehicle", "serve the simulated vehicle over Zenoh or MAVLink: mcl vehicle "
                "--zenoh ENDPOINT | --mavlink URL [--speed X] [--seed N] [--inject FAULT@S]"),
    "monitor": ("app.monitor", "watch a mission and its vehicle over Zenoh: mcl monitor "
                "--zenoh ENDPOINT [--until-end] [--foxglove HOST:PORT]"),
    "mosaic": ("app.mosaic", "make the photomosaic and coverage map of a run's images: "
               "mcl mosaic RUN.jsonl [--scale MM_PER_PX]"),
    "view": ("app.view.command", "show a run in a browser: the mission's tree with each "
             "block's state at any instant, the timeline, the track, the bounds, the mosaic: "
             "mcl view RUN.jsonl MISSION.mcl | --zenoh ENDPOINT MISSION.mcl [--port N]"),
    "export": ("app.export", "write a run log, verified, as an MCAP file for Foxglove: "
               "mcl export RUN.jsonl... --mcap OUT.mcap [--no-images] (docs/MCAP.md)"),
    "replay": ("app.replay", "check that a run log is a legal run of the mission"),
    "lsp": ("app.lsp.server", "the MCL language server for editors, over standard input and "
            "output: mcl lsp (docs/EDITORS.md)"),
    "fmt": ("app.fmt", "rewrite missions in the canonical layout, comments kept: mcl fmt "
            "FILE|DIR... [--check | --diff]"),
    "check": ("app.check", "compile and verify missions, as mclc does: mcl check MISSION.mcl... "
              "[mclc's options]"),
}


def _parser() -> argparse.ArgumentParser:
    """What ``mcl --help`` and ``mcl`` without a known subcommand say."""
    p = arguments.Parser(prog="mcl", description="Run MCL missions and check their logs.")
    p.add_argument("--version", action=VersionAction)
    sub = p.add_subparsers(dest="command", required=True)
    for name, (_, line) in COMMANDS.items():
        sub.add_parser(name, help=line)
    return p


def main(argv: list[str] | None = None) -> int:
    """The ``mcl`` console script (``argv`` None: the process's own arguments) or a call
    with its arguments; the exit status. A run from the process's arguments then ends the
    process at once (:func:`end_at_once`)."""
    one_blas_thread()  # before numpy loads (app/blas.py)
    args = sys.argv[1:] if argv is None else list(argv)
    status = _command(args)
    if argv is None and args[:1] == ["run"]:
        end_at_once(status)
    return status


def end_at_once(status: int) -> None:
    """End the process with ``status`` now, its objects never freed, as ``mclc`` does
    (app/mclc.py): freeing a dam run's modules, arrays and mosaic took 0.07 to 0.1 s at its
    end. Only once the run has ended safely — its log closed, its behaviours off, the camera's
    worker stopped and its shared memory removed (``mcl run`` does all of it before it
    returns) — and nothing else runs: a thread that is not a daemon's, or a child process,
    is left to Python's own exit, which waits for them; so is a standard stream that cannot
    be flushed, so that Python's exit says so as it would have."""
    if any(t is not threading.main_thread() and not t.daemon for t in threading.enumerate()):
        return
    processes = sys.modules.get("multiprocessing")  # imported only by a run that took images
    if processes is not None and processes.active_children():
        return
    try:
        sys.stdout.flush()
        sys.stderr.flush()
    except Exception:  # noqa: BLE001 - a stream that cannot be flushed: Python's exit tells
        return
    os._exit(int(status))


def _command(args: list[str]) -> int:
    """Run the subcommand ``args[0]`` with the rest of ``args``; its exit status."""
    open_standard_streams()
    try:
        with watched_stdout():
            if args and args[0] in COMMANDS:
                module = importlib.import_module(COMMANDS[args[0]][0])
                command = cast(Callable[[list[str]], int], module.main)
                return command(args[1:])
            _parser().parse_args(args)  # --help, or a usage error (exit 2)
            return Exit.INVALID
    except BrokenPipeError as exc:  # a closed pipe: quietly; a full disk: one line
        stdout_closed()
        line = lost_line(f"mcl {args[0]}" if args and args[0] in COMMANDS else "mcl", exc)
        if line is None:
            return Exit.OK
        print(line, file=sys.stderr)
        return Exit.INVALID


if __name__ == "__main__":
    sys.exit(main())
