"""``mcl replay``: check that a run log is a legal run of the mission (README, "mcl replay").

    mcl replay RUN.jsonl MISSION.mcl [--tasks FILE]

The log's digest chain, its clock and its end record are checked, then every record against
the mission's net (``petri/execution/replay.py``). Its exit statuses (conforms, does not,
invalid input): docs/EXIT.md.
"""

from __future__ import annotations

import argparse
import sys
from typing import Any

from mcl.api import compile_file
from mission.exits import Exit

from app.guard import guarded


def _parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="mcl replay")
    p.add_argument("log", metavar="RUN.jsonl")
    p.add_argument("mission", metavar="MISSION.mcl")
    p.add_argument("--tasks", action="append", default=[], metavar="FILE")
    p.add_argument("--debug", action="store_true")
    return p


def main(argv: list[str] | None = None) -> int:
    """``mcl replay ARGS`` (``argv``: what follows ``replay``)."""
    args = _parser().parse_args(sys.argv[1:] if argv is None else argv)
    return guarded("replay", args.debug, lambda: _replay(args))


def _replay(args: argparse.Namespace) -> int:
    from diagnostics import Source
    from mcl import parser
    from petri.execution.replay import check
    from petri.execution.runlog import LogError, read_log, verify

    try:
        records = read_log(args.log)
    except LogError as exc:
        if exc.line is None:  # the file itself: missing, a directory, unreadable
            print(f"{args.log}: error: {exc.reason}\n  hint: mcl replay RUN.jsonl "
                  "MISSION.mcl takes the run log "
                  "'mcl run' wrote", file=sys.stderr)
            return Exit.INVALID
        print(f"{args.log}:{exc.line}: not conformant: {exc.reason}")
        return Exit.FAILED
    header = records[0]
    params: dict[str, Any] = header.get("params") or {}
    tasks: list[Any] = header.get("tasks") or []
    if not isinstance(params, dict) or not isinstance(tasks, list):
        params, tasks = {}, []  # verify() below names line 1
    overrides = {name: (parser.parse_value(str(text), "<log header>"),
                        Source(f"{args.log} header: {name}", str(text)))
                 for name, text in params.items()}
    compiled = compile_file(args.mission, args.tasks or [str(t) for t in tasks] or None,
                            overrides, require_values=True)
    try:
        verify(records, args.log)  # the digest chain, time, the end record
    except LogError as exc:
        print(f"{args.log}:{exc.line}: not conformant: {exc.reason}")
        return Exit.FAILED
    result = check(compiled.net, records, {})
    if result.ok:
        print(f"{args.log}: conforms to {args.mission}: {result.firings} firings in "
              f"{result.records} records")
        return Exit.OK
    print(f"{args.log}:{result.line}: not conformant: {result.reason}")
    return Exit.FAILED


if __name__ == "__main__":
    sys.exit(main())
