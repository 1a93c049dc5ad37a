"""``mclc``: compile and verify MCL missions (and verify Petri nets given as PNML).

Its exit statuses are those of every command, from the one table (``mission.exits.Exit``,
documented in docs/EXIT.md): ``OK`` every file verified, ``FAILED`` a property fails,
``INVALID`` invalid input, ``INTERNAL`` a bug in mclc, ``UNDECIDED`` nothing fails but some
property could not be established. With several files, the worst (:data:`SEVERITY`).
The files written besides the report are checked by app/outputs.py.
"""

from __future__ import annotations

import argparse
import gc
import os
import sys
from typing import NoReturn

from app import kept_reports
from app.blas import one_blas_thread
from app.arguments import memory_size
from app.streams import lost_line, open_standard_streams, stdout_closed, watched_stdout
from app.version import VersionAction
from app import arguments
from mcl import dataclass_methods
from mission.exits import SEVERITY, Exit  # the exit statuses of every command: docs/EXIT.md

# What a call checks and prints is in app/mclc_files.py, loaded only when no report kept from
# an earlier call answers it (app/kept_reports.py): the kept one needs no compiler.
# With several files, mclc exits with the worst status: internal, invalid, failed, undecided,
# ok (docs/EXIT.md).


def _parser(prog: str = "mclc") -> argparse.ArgumentParser:
    p = arguments.Parser(
        prog=prog,
        description="Compile MCL missions to Petri nets and verify them. "
                    f"Exit {int(Exit.OK)} every file verified, {int(Exit.FAILED)} a property "
                    f"fails, {int(Exit.INVALID)} invalid input, {int(Exit.INTERNAL)} a bug in "
                    f"mclc, {int(Exit.UNDECIDED)} undecided (some property could not be "
                    "established); with several files, the worst ("
                    + ", ".join(str(int(e)) for e in reversed(SEVERITY))
                    + "). Every command's exit statuses: docs/EXIT.md.")
    p.add_argument("--version", action=VersionAction)
    p.add_argument("files", nargs="+", metavar="FILE",
                   help="mission files (.mcl) or Petri nets (.pnml, or a contest .tgz)")
    p.add_argument("--tasks", action="append", default=[], metavar="FILE",
                   help="task library (.tasks); repeat for several (default: the Ictineu "
                        "library shipped with mcl)")
    p.add_argument("--param", action="append", default=[], metavar="NAME=VALUE",
                   help="a mission parameter, e.g. --param h=90deg (overrides PARAM)")
    p.add_argument("--params", action="append", default=[], metavar="FILE",
                   help="a parameter file: one 'name = value' per line")
    p.add_argument("--dot", metavar="FILE", help="write the full net as Graphviz DOT")
    p.add_argument("--dot-tasks", metavar="FILE",
                   help="write the net with each task collapsed to one node (paper Fig. 5)")
    p.add_argument("--pnml", metavar="FILE", help="write the net as PNML (ISO/IEC 15909-2)")
    p.add_argument("--net-json", metavar="FILE", help="write the whole net as JSON")
    p.add_argument("--graphml", metavar="FILE",
                   help="write the reachability graph the explicit route verified as GraphML "
                        "(a node per marking, an edge per firing; via networkx)")
    p.add_argument("--json", action="store_true", help="print a JSON report (= --format json)")
    p.add_argument("--format", choices=["text", "json", "junit", "sarif", "github"],
                   default=None, help="report format on standard output (default text): "
                   "json, JUnit XML, SARIF 2.1.0, or GitHub Actions annotations")
    p.add_argument("--no-verify", action="store_true", help="compile only; do not verify")
    p.add_argument("--method", choices=["auto", "explicit", "structural", "compositional"],
                   default="auto",
                   help="explicit: enumerate every reachable marking (exact, with firing "
                        "sequences); structural: templates verified with generic children plus "
                        "outcome and static analyses of the syntax tree (for missions too large "
                        "to enumerate); auto (default): explicit when its estimated memory fits "
                        "1 GiB, completed by structural if the exploration is cut "
                        "(mcl/analysis/verification.py); compositional (a fleet only): each "
                        "vehicle proved alone against its channels, the product never built "
                        "(docs/METHODS.md, Fleets)")
    p.add_argument("--max-markings", type=_positive, default=5_000_000, metavar="N",
                   help="explicit route: stop after N markings; what the cut exploration "
                        "cannot decide is reported undecided (exit 4) (default 5,000,000)")
    p.add_argument("--max-memory", type=memory_size, default=1 << 30, metavar="SIZE",
                   help="the memory the explicit route (and, for a net, the BDDs) may use, "
                        "e.g. 512MiB, 4GiB (default 1GiB): its need is estimated before it "
                        "starts and before each array grows; over it, auto takes "
                        "the structural route (a mission) or the symbolic search (a 1-safe "
                        "net), else the search stops there and says undecided (exit 4)")
    p.add_argument("--deadline", metavar="DURATION",
                   help="fail (exit 1) if some run can last longer, e.g. 45min, 1.5h, 600s; "
                        "prints the critical path (docs/DURATION.md)")
    p.add_argument("--battery", metavar="WH", help="battery capacity, e.g. 800Wh: report the "
                   "worst-case energy (power declared per behaviour) and the margin; fail "
                   "(exit 1) if it can run out")
    p.add_argument("--reserve", metavar="PERCENT", help="with --battery: fail (exit 1) if the "
                   "worst case can eat into this share of the battery, e.g. 20%%")
    p.add_argument("--debug", action="store_true", help="show tracebacks of internal errors")
    return p


def _positive(text: str) -> int:
    try:
        value = int(text.replace("_", "").replace(",", ""))
    except ValueError:
        raise argparse.ArgumentTypeError(f"not a whole number: {text!r}") from None
    if not 1 <= value < 2**31:
        raise argparse.ArgumentTypeError(f"must lie between 1 and 2**31 - 1, got {value}")
    return value


def main(argv: list[str] | None = None, prog: str = "mclc") -> int:
    """The command; a closed standard output ends it quietly with the status so far, one
    that cannot be written (a full disk) with one line and exit 2."""
    one_blas_thread()  # mclc does no linear algebra (app/blas.py)
    open_standard_streams()
    worst = [Exit.OK]
    try:
        with watched_stdout():
            return _main(argv, worst, prog)
    except BrokenPipeError as exc:
        stdout_closed()
        line = lost_line(prog, exc)
        if line is None:
            return worst[0]
        print(line, file=sys.stderr)
        return max(worst[0], Exit.INVALID, key=SEVERITY.index)


def _main(argv: list[str] | None, so_far: list[Exit], prog: str) -> int:
    args = _parser(prog).parse_args(argv)
    fmt = "json" if args.json else (args.format or "text")
    kept = kept_reports.kept_key(args, sys.argv[1:] if argv is None else argv, fmt, prog)
    if kept is not None and (replayed := kept_reports.replay(*kept)) is not None:
        return replayed  # what the same call printed before (app/kept_reports.py)
    # the methods of the dataclasses loaded from here on, compiled once (mcl/dataclass_methods.py)
    with dataclass_methods.kept():
        return _check(args, argv, fmt, kept, so_far, prog)


def _check(args: argparse.Namespace, argv: list[str] | None, fmt: str,
           kept: tuple[str, list[str | bytes]] | None, so_far: list[Exit], prog: str) -> int:
    """Check the files of a call no kept report answers, and keep its report if it may be."""
    # Lazy for start-up speed: a kept report needs neither the compiler nor the verifier.
    from app.mclc_files import check_files
    from app.reports.duration import parse_limits
    from mcl.parser import trees_kept

    try:
        args.limits = parse_limits(args.deadline, args.battery, args.reserve)
    except ValueError as exc:
        print(f"{prog}: error: {exc}", file=sys.stderr)
        return Exit.INVALID
    outputs = [args.dot, args.dot_tasks, args.pnml, args.net_json, args.graphml]
    if len(args.files) > 1 and any(outputs):
        print(f"{prog}: error: --dot, --dot-tasks, --pnml, --net-json and --graphml take one "
              "input file", file=sys.stderr)
        return Exit.INVALID
    if args.graphml is not None and (args.no_verify or args.method == "structural"):
        print(f"{prog}: error: --graphml writes the graph the explicit route explores, and "
              f"{'--no-verify' if args.no_verify else 'the structural route'} explores none: "
              "use --method explicit", file=sys.stderr)
        return Exit.INVALID
    # trees: mclc parses the same files call after call; the output: to keep it, for a call
    # that may be kept
    with trees_kept(), kept_reports.recorded(kept is not None) as (out, err):
        worst, reports = check_files(args, fmt, so_far)
    if kept is not None and worst != Exit.INTERNAL and reports[0].get(
            "verification", {}).get("cached") and kept_reports.kept_key(
            args, sys.argv[1:] if argv is None else argv, fmt, prog) == kept:  # unchanged
        kept_reports.keep(*kept, out.copy.getvalue(), err.copy.getvalue(), worst)
    return worst


def run() -> NoReturn:
    """The ``mclc`` console script: :func:`main` run as mypy runs, with the cyclic garbage
    collector seldom called, and then the process ending at once, its objects never freed.
    Both are the collector's work on objects that live until the end: collecting every 700
    objects made cost about 5 ms of CPU in checking the dam mission (40 collections; every
    200,000, as mypy sets it: none), and freeing the modules, the syntax trees and the graph
    of its verification about 10 ms at the end. What the call wrote is flushed first; where
    that fails, Python's own exit says so, as it would have."""
    gc.set_threshold(200_000, 30, 30)
    status = main()
    try:
        sys.stdout.flush()
        sys.stderr.flush()
    except Exception:  # noqa: BLE001 - a stream that cannot be flushed: Python's exit tells
        sys.exit(status)
    os._exit(status)


if __name__ == "__main__":
    run()
