"""``mclc``: compile and verify MCL missions (and verify Petri nets given as PNML).

Its exit statuses are those of every command, from the one table (``mission.exits.Exit``,
documented in docs/EXIT.md): ``OK`` every file verified, ``FAILED`` a property fails,
``INVALID`` invalid input, ``INTERNAL`` a bug in mclc, ``UNDECIDED`` nothing fails but some
property could not be established. With several files, the worst (:data:`SEVERITY`).
"""

from __future__ import annotations

import argparse
import errno
import json
import os
import stat
import sys
from collections.abc import Callable
from pathlib import Path
from typing import Any

from diagnostics import Diagnostic, MclError, Span, read_source
from mcl.api import Compiled, compile_source, parse_params
from mcl.parser import is_fleet, trees_kept

from app.arguments import memory_size
from app.mission_report import SEVERITY, diag_json, verify_and_report
from app.streams import lost_line, open_standard_streams, stdout_closed, watched_stdout
from app.version import VersionAction
from app import arguments
from mission.exits import Exit  # the exit statuses of every command: docs/EXIT.md

# With several files, mclc exits with the worst status: internal, invalid, failed, undecided,
# ok (docs/EXIT.md).
PNML_FILES = (".pnml", ".tgz")  # a Petri net: PNML, or a Model Checking Contest archive


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


class OutputError(MclError):
    """An output file that cannot be written (a directory, a missing folder, no permission):
    invalid input, reported on one line that starts with the file."""

    def __init__(self, path: str, option: str, reason: str):
        where = path or f"{option} ''"
        super().__init__(f"cannot write it ({option}): {reason}", span=Span.of_file(where),
                         hint="give the path of a file in a folder that exists and that "
                              "you may write to", code="unwritable-output")


def write_output(path: str, option: str, write: Callable[[str], None]) -> None:
    """``write(path)``, turning every way writing can fail into an :class:`OutputError`."""
    check_output(path, option)
    try:
        write(path)
    except OSError as exc:
        raise OutputError(path, option, exc.strerror or str(exc)) from None


def unread_pipe(path: Path) -> bool:
    """Whether ``path`` is a named pipe that no process has open to read (opening it to write
    would wait for one for ever); ``/dev/stdout`` into a pipe has its reader."""
    try:
        if not stat.S_ISFIFO(path.stat().st_mode):
            return False
        os.close(os.open(path, os.O_WRONLY | os.O_NONBLOCK))
    except OSError as exc:
        return exc.errno == errno.ENXIO  # the pipe has no reader
    return False


def check_output(path: str, option: str) -> None:
    """Refuse, before any work, an output path that cannot be a file: empty, a directory, in
    a folder that does not exist or is not a folder."""
    if not path:
        raise OutputError(path, option, "an empty path")
    target = Path(path)
    if target.is_dir():
        raise OutputError(path, option, "is a directory")
    if unread_pipe(target):
        raise OutputError(path, option, "a named pipe nobody reads: writing would wait for ever")
    folder = target.parent
    if not folder.exists():
        raise OutputError(path, option, f"no folder {str(folder)!r}")
    if not folder.is_dir():
        raise OutputError(path, option, f"{str(folder)!r} is not a folder")


def one_blas_thread() -> None:
    """Ask OpenBLAS for one thread, unless the user chose a number or numpy is loaded already.
    mclc does no linear algebra, and the pool OpenBLAS starts when numpy loads (numpy comes
    later, with the explicit route) would spin about 50 ms of CPU on every core for nothing:
    a quarter of what verifying the dam mission costs."""
    if "numpy" not in sys.modules:
        os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")


def main(argv: list[str] | None = None, prog: str = "mclc") -> int:
    """The command; a closed standard output ends it quietly with the status so far, one
    that cannot be written (a full disk) with one line and exit 2."""
    one_blas_thread()
    open_standard_streams()
    worst = [Exit.OK]
    try:
        with watched_stdout(), trees_kept():  # mclc parses the same files call after call
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
    from app.reports.duration import parse_limits

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
    reports: list[dict[str, Any]] = []
    worst = Exit.OK
    for path in args.files:
        try:
            status, report = _one(path, args, fmt)
        except OutputError as exc:  # before MclError: its report names the output file
            status, report = Exit.INVALID, {"file": path, "status": "invalid",
                                            "message": str(exc).splitlines()[0]}
            print(exc, file=sys.stderr)
        except MclError as exc:
            status, report = Exit.INVALID, _invalid(path, exc.diagnostics)
            print(exc.format(), file=sys.stderr)
        except BrokenPipeError:
            raise
        except Exception as exc:  # a bug of ours: say so plainly, never a bare traceback
            if args.debug:
                import traceback  # lazy for start-up speed: only for --debug (3 ms)

                traceback.print_exc()
            print(f"{path}: internal error: {type(exc).__name__}: {exc}\n"
                  "  hint: this is a bug in mclc; rerun with --debug and report it",
                  file=sys.stderr)
            status, report = Exit.INTERNAL, {"file": path, "status": "internal-error",
                                             "message": str(exc)}
        reports.append(report)
        worst = max(worst, status, key=SEVERITY.index)
        so_far[0] = worst
    if fmt == "json":
        print(json.dumps(reports[0] if len(reports) == 1 else reports, indent=2))
    elif fmt in ("junit", "sarif", "github"):
        from app.reports import formats

        print(getattr(formats, fmt)(formats.flat(reports)))
    sys.stdout.flush()
    return worst


def _invalid(path: str, diagnostics: list[Diagnostic]) -> dict[str, Any]:
    return {"file": path, "status": "invalid",
            "diagnostics": [diag_json(d) for d in diagnostics]}


def _one(path: str, args: argparse.Namespace, fmt: str) -> tuple[Exit, dict[str, Any]]:
    if args.graphml is not None:
        check_output(args.graphml, "--graphml")
    if is_fleet(path):
        from app.fleet_check import check_fleet  # lazy for start-up speed: fleets only

        return check_fleet(path, args, fmt)
    if args.method == "compositional":
        raise MclError("--method compositional proves a fleet, and this file is not one",
                       span=Span.of_file(path), hint="use auto, explicit or structural for "
                       "a mission or a net", code="fleet-option")
    if path.lower().endswith(PNML_FILES):
        return _pnml(path, args, fmt)
    params = parse_params(args.param, args.params)
    source = read_source(path)
    if is_fleet(source):  # a pipe (mclc <(...)) is read once: its first word says which
        from app.fleet_check import check_fleet  # lazy for start-up speed: fleets only

        return check_fleet(source, args, fmt)
    compiled = compile_source(source, args.tasks or None, params)
    _write_outputs(compiled, args)
    return verify_and_report(compiled, args, fmt, _write_graph)


def _write_outputs(compiled: Compiled, args: argparse.Namespace) -> None:
    net = compiled.net

    def to_dot(net: Any, view: str) -> str:
        from petri.formats.dot import to_dot as dot  # lazy for start-up speed: --dot only

        return dot(net, view)

    def text(content: Callable[[], str]) -> Callable[[str], None]:
        def write(path: str) -> None:
            Path(path).write_text(content(), encoding="utf-8")
        return write

    outputs: list[tuple[str | None, str, Callable[[str], None]]] = [
        (args.dot, "--dot", text(lambda: to_dot(net, "full"))),
        (args.dot_tasks, "--dot-tasks", text(lambda: to_dot(net, "tasks"))),
        (args.pnml, "--pnml", lambda path: _write_pnml(net, path)),
        (args.net_json, "--net-json", text(lambda: json.dumps(net.to_dict(), indent=1,
                                                           allow_nan=False))),  # strict JSON
    ]
    for path, option, _ in outputs:  # every path checked before anything is written
        if path is not None:
            check_output(path, option)
    for path, option, write in outputs:
        if path is not None:
            write_output(path, option, write)


def _pnml(path: str, args: argparse.Namespace, fmt: str) -> tuple[Exit, dict[str, Any]]:
    """``mclc NET.pnml`` (or a contest ``.tgz``): the state-space report of a P/T net
    (explicit with ``--method explicit``, else explicit or symbolic, whichever fits)."""
    from app.reports.pnml import pnml_text
    from petri.formats.pnml import PnmlError
    from petri.verification.pnml_report import analyse_graph, load_net

    try:
        net = load_net(path)
    except PnmlError as exc:
        print(exc, file=sys.stderr)
        return Exit.INVALID, {"file": path, "status": "invalid", "diagnostics": [
            {"severity": "error", "message": exc.message, "hint": None, "code": "pnml",
             "file": exc.path or path, "line": exc.line, "col": exc.col}]}
    method = "explicit" if args.method == "explicit" else "auto"
    analysis, space = analyse_graph(net, method, arcs=args.graphml is not None,
                                    max_bytes=args.max_memory)
    if args.graphml is not None:
        _write_graph(path, args.graphml, net, space, "--method auto took the symbolic search")
    report = {"file": path, "status": "analysed", **analysis}
    if fmt == "text":
        print(f"{path}:")
        print(pnml_text(report))
        if args.graphml is not None:
            print(f"wrote reachability graph to {args.graphml}")
    if not analysis["complete"]:  # a limit (markings, tokens, memory) cut the search
        report["status"] = "undecided"
        return Exit.UNDECIDED, report
    return Exit.OK, report


def _write_graph(source: str, target: str, net: Any, space: Any, route: str) -> None:
    """``--graphml``: the reachability graph the verification explored, or a one-line error
    saying why there is none (``route``: what was taken instead) or why it is not written."""
    from petri.formats.graphml import GraphTooLarge, write_graphml

    if space is None:
        raise MclError(f"--graphml: {route}, which explores no reachability graph; --method "
                       "explicit gives one", span=Span.of_file(source), code="no-graph")
    try:
        write_output(target, "--graphml", lambda out: write_graphml(net, space, out))
    except GraphTooLarge as exc:
        raise MclError(f"--graphml: {exc}", span=Span.of_file(source),
                       code="graph-too-large") from None


def _write_pnml(net: Any, path: str) -> None:
    from petri.formats.pnml import write_pnml

    write_pnml(net, path)


if __name__ == "__main__":
    sys.exit(main())
