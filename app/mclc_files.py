"""What ``mclc`` does with the files it is given (app/mclc.py is its command line): each
compiled and verified (a mission, a fleet) or analysed (a Petri net), its report printed, the
files asked for written. Loaded once the command line is read and no report kept from an
earlier call answers it (app/kept_reports.py)."""

from __future__ import annotations

import argparse
import json
import sys
from collections.abc import Callable
from pathlib import Path
from typing import Any

from diagnostics import Diagnostic, MclError, Span, read_source
from mcl.api import Compiled, compile_source, parse_params
from mcl.parser import is_fleet

from app.mission_report import diag_json, verify_and_report
from app.outputs import OutputError, check_output, write_output
from mission.exits import SEVERITY, Exit

PNML_FILES = (".pnml", ".tgz")  # a Petri net: PNML, or a Model Checking Contest archive


def check_files(args: argparse.Namespace, fmt: str, so_far: list[Exit]
           ) -> tuple[Exit, list[dict[str, Any]]]:
    """Check each file, print the report (JSON and the other formats at the end), and give
    the worst status and the reports."""
    reports: list[dict[str, Any]] = []
    worst = Exit.OK
    for path in args.files:
        try:
            status, report = one_file(path, args, fmt)
        except OutputError as exc:  # before MclError: its report names the output file
            status, report = Exit.INVALID, {"file": path, "status": "invalid",
                                            "message": str(exc).splitlines()[0]}
            print(exc, file=sys.stderr)
        except MclError as exc:
            status, report = Exit.INVALID, invalid(path, exc.diagnostics)
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
    return worst, reports


def invalid(path: str, diagnostics: list[Diagnostic]) -> dict[str, Any]:
    """The report of a file that is not a valid mission: its diagnostics."""
    return {"file": path, "status": "invalid",
            "diagnostics": [diag_json(d) for d in diagnostics]}


def one_file(path: str, args: argparse.Namespace, fmt: str) -> tuple[Exit, dict[str, Any]]:
    """Check one file (a mission, a fleet or a Petri net) and report it."""
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
        return pnml_file(path, args, fmt)
    params = parse_params(args.param, args.params)
    source = read_source(path)
    if is_fleet(source):  # a pipe (mclc <(...)) is read once: its first word says which
        from app.fleet_check import check_fleet  # lazy for start-up speed: fleets only

        return check_fleet(source, args, fmt)
    compiled = compile_source(source, args.tasks or None, params)
    write_outputs(compiled, args)
    return verify_and_report(compiled, args, fmt, write_graph)


def write_outputs(compiled: Compiled, args: argparse.Namespace) -> None:
    """The files asked for (``--dot``, ``--dot-tasks``, ``--pnml``, ``--net-json``), every
    path checked before any is written."""
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
        (args.pnml, "--pnml", lambda path: write_net_pnml(net, path)),
        (args.net_json, "--net-json", text(lambda: json.dumps(net.to_dict(), indent=1,
                                                           allow_nan=False))),  # strict JSON
    ]
    for path, option, _ in outputs:  # every path checked before anything is written
        if path is not None:
            check_output(path, option)
    for path, option, write in outputs:
        if path is not None:
            write_output(path, option, write)


def pnml_file(path: str, args: argparse.Namespace, fmt: str) -> tuple[Exit, dict[str, Any]]:
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
        write_graph(path, args.graphml, net, space, "--method auto took the symbolic search")
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


def write_graph(source: str, target: str, net: Any, space: Any, route: str) -> None:
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


def write_net_pnml(net: Any, path: str) -> None:
    """``--pnml``: the net as PNML."""
    from petri.formats.pnml import write_pnml

    write_pnml(net, path)
