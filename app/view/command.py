"""``mcl view``: the mission in a browser, from a finished run log.

    mcl view RUN.jsonl MISSION.mcl [--tasks FILE] [--port N]

Checks the log as ``mcl replay`` does (its lines and digest chain, then every record against
the mission's net: the page shows only a legal run), then serves the page on
``http://127.0.0.1:PORT/`` (a free port unless ``--port``) and prints that address as its
first line, until Ctrl-C. ``?t=SECONDS`` opens the page at that instant. What the page shows:
app/view/data.py; the server: app/view/server.py. Exit statuses (docs/EXIT.md): 0 when
stopped, 2 on invalid input (a log that cannot be read, or is not a run of the mission).
"""

from __future__ import annotations

import argparse
import signal
import sys
import threading
from pathlib import Path
from typing import Any

from mcl.api import Compiled, compile_file
from mission.exits import Exit

from app.guard import guarded


def _parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="mcl view", description="Show a run of a mission in a "
                                "browser: its tree with each block's state, the timeline, the "
                                "track, the proved bounds, the mosaic.")
    p.add_argument("log", metavar="RUN.jsonl")
    p.add_argument("mission", metavar="MISSION.mcl")
    p.add_argument("--tasks", action="append", default=[], metavar="FILE",
                   help="task library (.tasks), as for the run")
    p.add_argument("--port", type=int, default=0, help="the port on 127.0.0.1 (default: a "
                   "free one)")
    p.add_argument("--debug", action="store_true")
    return p


def main(argv: list[str] | None = None) -> int:
    """``mcl view ARGS`` (``argv``: what follows ``view``)."""
    args = _parser().parse_args(sys.argv[1:] if argv is None else argv)
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
    from app.view.data import page_data, pictures
    from app.view.server import ViewServer

    try:
        compiled, records = load(args.log, args.mission, args.tasks)
    except Refused as exc:
        print(exc, file=sys.stderr)
        return Exit.INVALID
    data = page_data(compiled, records, Path(args.log))
    try:
        server = ViewServer(lambda: data, pictures(Path(args.log)), args.port)
    except OSError as exc:
        print(f"--port {args.port}: error: cannot serve on it ({exc.strerror})",
              file=sys.stderr)
        return Exit.INVALID
    stop = threading.Event()
    for sig in (signal.SIGTERM, signal.SIGINT):
        signal.signal(sig, lambda *_: stop.set())
    server.start()
    print(f"mcl view: {server.url} ({data['mission']}, {len(records)} records; Ctrl-C to "
          "stop)", flush=True)
    try:
        while not stop.wait(0.5):
            pass
    finally:
        server.shutdown()
        server.server_close()
    return Exit.OK
