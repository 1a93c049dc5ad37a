"""``mcl replay``: check that a run log is a legal run of the mission (README, "mcl replay").

    mcl replay RUN.jsonl MISSION.mcl [--tasks FILE] [--key PUBLIC.pem]
    mcl replay DIR FLEET.mcl [--key PUBLIC.pem]   (a fleet's logs: app/fleet_replay.py)

In this order, so that nothing the log names is read before the log is known to be what the
run wrote: the log's lines (each within a size limit, strict JSON written the run's one way:
``petri/execution/runlog.py``), its digest chain and, for a signed log, every line's
signature (by the key ``--key`` names, when given); then the header's fields and the task
libraries it names (regular ``.tasks`` files only, read with a size limit and never quoted in
an error); then every record against the mission's net (``petri/execution/replay.py``), and
what the end record claims (``mission/evidence.py``). A log that is not signed is reported as
such: its chain detects accidents, not forgery. Its exit statuses (conforms, does not,
invalid input): docs/EXIT.md.
"""

from __future__ import annotations

import argparse
import os
import stat
import sys
from pathlib import Path
from typing import Any

from diagnostics import MclError
from mcl.api import Compiled, compile_file
from mcl.fleet import is_fleet
from mission.exits import Exit
from mission.fleet_evidence import RecordProblem

from app.guard import guarded
from app import arguments, fleet_replay

MAX_TASKS_BYTES = 4 * 1024 * 1024  # a task library the log's header names, at most


def _parser() -> argparse.ArgumentParser:
    p = arguments.Parser(prog="mcl replay")
    p.add_argument("log", metavar="RUN.jsonl", help="a run log; for a fleet, the folder of "
                   "its logs (mcl run FLEET.mcl --log-dir DIR)")
    p.add_argument("mission", metavar="MISSION.mcl")
    p.add_argument("--tasks", action="append", default=[], metavar="FILE")
    p.add_argument("--key", metavar="PUBLIC.pem", default=None,
                   help="the Ed25519 public key the run's --log-key pairs with: the log "
                        "must be signed by it")
    p.add_argument("--debug", action="store_true")
    return p


def main(argv: list[str] | None = None) -> int:
    """``mcl replay ARGS`` (``argv``: what follows ``replay``)."""
    args = _parser().parse_args(sys.argv[1:] if argv is None else argv)
    return guarded("replay", args.debug, lambda: _replay(args))


class Refused(Exception):
    """The log is refused: ``line`` (None: the file), why, and whether as invalid input."""

    def __init__(self, line: int | None, reason: str, invalid: bool = False) -> None:
        super().__init__(reason)
        self.line, self.reason, self.invalid = line, reason, invalid


def _replay(args: argparse.Namespace) -> int:
    if is_fleet(args.mission):  # a fleet's folder of logs: app/fleet_replay.py
        try:
            return fleet_replay.replay(args)
        except RecordProblem as exc:
            where = exc.path if exc.line is None else f"{exc.path}:{exc.line}"
            if exc.invalid or exc.line is None:
                print(f"{where}: error: {exc.reason}", file=sys.stderr)
                return Exit.INVALID
            print(f"{where}: not conformant: {exc.reason}")
            return Exit.FAILED
    try:
        return _checked(args)
    except Refused as exc:
        if exc.line is None:  # the file itself: missing, a directory, unreadable
            print(f"{args.log}: error: {exc.reason}\n  hint: mcl replay RUN.jsonl "
                  "MISSION.mcl takes the run log 'mcl run' wrote", file=sys.stderr)
            return Exit.INVALID
        if exc.invalid:
            print(f"{args.log}:{exc.line}: error: {exc.reason}", file=sys.stderr)
            return Exit.INVALID
        print(f"{args.log}:{exc.line}: not conformant: {exc.reason}")
        return Exit.FAILED


def _checked(args: argparse.Namespace) -> int:
    from mission.evidence import end_problem, header_problem
    from petri.execution.replay import check
    from petri.execution.runlog import LogError, read_log, verify
    from petri.execution.signing import load_public

    key = load_public(args.key) if args.key is not None else None
    try:
        records = read_log(args.log)
        established = verify(records, args.log, key)  # the chain, the signatures, the end
    except LogError as exc:
        if not exc.invalid:  # a mission that is itself invalid input says so first (exit 2),
            compile_file(args.mission, args.tasks or None)  # with what the user named only
        raise Refused(exc.line, exc.reason, exc.invalid) from None
    header = records[0]
    compiled = _compile(args, header)
    problem = header_problem(header, compiled)
    if problem is not None:
        raise Refused(1, problem)
    result = check(compiled.net, records, {})
    if not result.ok:
        raise Refused(result.line, result.reason)
    problem = end_problem(header, records[-1], records, compiled)
    if problem is not None:
        raise Refused(records[-1]["_line"], problem)
    print(f"{args.log}: conforms to {args.mission}: {result.firings} firings in "
          f"{result.records} records; {established}")
    return Exit.OK


def _compile(args: argparse.Namespace, header: dict[str, Any]) -> Compiled:
    """The mission, with the header's parameters and the task libraries given (else those
    the header names, checked first: never quoted)."""
    from diagnostics import Source
    from mcl import parser

    params: dict[str, Any] = header.get("params") or {}
    overrides = {name: (parser.parse_value(str(text), "<log header>"),
                        Source(f"{args.log} header: {name}", str(text)))
                 for name, text in params.items()}
    if args.tasks or not header.get("tasks"):
        return compile_file(args.mission, args.tasks or None, overrides, require_values=True)
    named = [str(t) for t in header["tasks"]]
    for name in named:
        problem = _task_file_problem(name)
        if problem is not None:
            raise Refused(1, f"the header names the task library {name[:80]!r}, which "
                          f"{problem}; give the libraries with --tasks", invalid=True)
    try:
        return compile_file(args.mission, named, overrides, require_values=True)
    except MclError:
        raise Refused(1, "the task libraries the header names do not compile with the "
                      "mission (what they hold is not shown); give them with --tasks",
                      invalid=True) from None


def _task_file_problem(name: str) -> str | None:
    """Why a task library a log's header names is not read (None: it may be)."""
    path = Path(name)
    if path.suffix != ".tasks":
        return "is not a .tasks file"
    try:
        mode = os.stat(path)
    except OSError:
        return "cannot be found"
    if not stat.S_ISREG(mode.st_mode):
        return "is not a regular file"
    if mode.st_size > MAX_TASKS_BYTES:
        return f"is larger than {MAX_TASKS_BYTES // 2**20} MiB"
    return None


if __name__ == "__main__":
    sys.exit(main())
