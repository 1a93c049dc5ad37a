"""``mclc``: compile and verify MCL missions (and verify Petri nets given as PNML).

Exit status: 0 every file verified, 1 a property fails, 2 invalid input, 3 internal error.
With several files, the worst status wins.
"""

from __future__ import annotations

import argparse
import json
import sys
import traceback
from pathlib import Path
from typing import Any

from .. import ast
from ..api import Compiled, compile_file, parse_params
from ..errors import Diagnostic, MclError

EXIT_OK, EXIT_PROPERTY, EXIT_INVALID, EXIT_INTERNAL = 0, 1, 2, 3
AUTO_LIMIT = 300_000  # estimated markings above which --method auto goes structural


def _parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog="mclc",
        description="Compile MCL missions to Petri nets and verify them. "
                    "Exit 0 verified, 1 a property fails, 2 invalid input.")
    p.add_argument("files", nargs="+", metavar="FILE",
                   help="mission files (.mcl) or Petri nets (.pnml)")
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
    p.add_argument("--json", action="store_true", help="print a JSON report (= --format json)")
    p.add_argument("--format", choices=["text", "json", "junit", "sarif", "github"],
                   default=None, help="report format on standard output (default text): "
                   "json, JUnit XML, SARIF 2.1.0, or GitHub Actions annotations")
    p.add_argument("--no-verify", action="store_true", help="compile only; do not verify")
    p.add_argument("--method", choices=["auto", "explicit", "structural"], default="auto",
                   help="explicit: enumerate every reachable marking (exact, with firing "
                        "sequences); structural: templates verified with generic children plus "
                        "static analysis (for missions too large to enumerate); auto (default): "
                        f"explicit when the estimated state space is under {AUTO_LIMIT:,} "
                        "markings")
    p.add_argument("--debug", action="store_true", help="show tracebacks of internal errors")
    return p


def main(argv: list[str] | None = None) -> int:
    args = _parser().parse_args(argv)
    fmt = "json" if args.json else (args.format or "text")
    outputs = [args.dot, args.dot_tasks, args.pnml, args.net_json]
    if len(args.files) > 1 and any(outputs):
        print("mclc: error: --dot, --dot-tasks, --pnml and --net-json take one input file",
              file=sys.stderr)
        return EXIT_INVALID
    reports: list[dict[str, Any]] = []
    worst = EXIT_OK
    for path in args.files:
        try:
            status, report = _one(path, args, fmt)
        except MclError as exc:
            status, report = EXIT_INVALID, _invalid(path, exc.diagnostics)
            print(exc.format(), file=sys.stderr)
        except Exception as exc:  # a bug of ours: say so plainly, never a bare traceback
            if args.debug:
                traceback.print_exc()
            print(f"{path}: internal error: {type(exc).__name__}: {exc}\n"
                  "  hint: this is a bug in mclc; rerun with --debug and report it",
                  file=sys.stderr)
            status, report = EXIT_INTERNAL, {"file": path, "status": "internal-error",
                                             "message": str(exc)}
        reports.append(report)
        worst = max(worst, status)
    if fmt == "json":
        print(json.dumps(reports[0] if len(reports) == 1 else reports, indent=2))
    elif fmt in ("junit", "sarif", "github"):
        from . import formats

        print(getattr(formats, fmt)(reports))
    sys.stdout.flush()
    return worst


def _invalid(path: str, diagnostics: list[Diagnostic]) -> dict[str, Any]:
    return {"file": path, "status": "invalid",
            "diagnostics": [_diag_json(d) for d in diagnostics]}


def _diag_json(d: Diagnostic) -> dict[str, Any]:
    span = d.span
    return {"severity": d.severity, "message": d.message, "hint": d.hint, "code": d.code,
            "file": span.file if span else None, "line": span.line if span else None,
            "col": span.col if span else None}


def _one(path: str, args: argparse.Namespace, fmt: str) -> tuple[int, dict[str, Any]]:
    if path.lower().endswith(".pnml"):
        from petri.pnml_report import report_file

        return report_file(path, fmt)
    params = parse_params(args.param, args.params)
    compiled = compile_file(path, args.tasks or None, params)
    _write_outputs(compiled, args)
    report = _summary(compiled)
    status = EXIT_OK
    if not args.no_verify:
        verdict = _verify(compiled, args.method)
        report["verification"] = verdict.to_json()
        status = EXIT_OK if verdict.ok else EXIT_PROPERTY
        report["status"] = "verified" if verdict.ok else "property-fails"
    if fmt == "text":
        _print_text(compiled, report, args)
    return status, report


def _verify(compiled: Compiled, method: str) -> Any:
    from petri.verify import verify

    from ..structural import analyse, mission_estimate

    if method == "structural" or (
            method == "auto" and mission_estimate(compiled.checked) > AUTO_LIMIT):
        return analyse(compiled.checked)
    return verify(compiled.net)


def _write_outputs(compiled: Compiled, args: argparse.Namespace) -> None:
    from petri.dot import to_dot

    net = compiled.net
    if args.dot:
        Path(args.dot).write_text(to_dot(net, "full"), encoding="utf-8")
    if args.dot_tasks:
        Path(args.dot_tasks).write_text(to_dot(net, "tasks"), encoding="utf-8")
    if args.pnml:
        from petri.pnml import write_pnml

        write_pnml(net, args.pnml)
    if args.net_json:
        Path(args.net_json).write_text(json.dumps(net.to_dict(), indent=1), encoding="utf-8")


def _summary(compiled: Compiled) -> dict[str, Any]:
    m = compiled.mission
    tasks = [{"task": c.name, "line": c.span.line, "col": c.span.col}
             for c in ast.calls(m.body)]
    return {"file": compiled.source.name, "mission": m.name, "status": "compiled",
            "tasks": len(tasks), "task_calls": tasks,
            "places": len(compiled.net.places), "transitions": len(compiled.net.transitions),
            "arcs": compiled.net.arc_count(),
            "parameters": {"set": sorted(compiled.checked.params),
                           "unset": compiled.checked.unset},
            "diagnostics": [_diag_json(d) for d in compiled.warnings]}


def _print_text(compiled: Compiled, report: dict[str, Any], args: argparse.Namespace) -> None:
    for d in compiled.warnings:
        print(d.format(), file=sys.stderr)
    name = compiled.mission.name or "(unnamed)"
    print(f"{compiled.source.name}: mission {name}: {report['tasks']} task calls, "
          f"{report['places']} places, {report['transitions']} transitions")
    for flag, what in ((args.dot, "full net"), (args.dot_tasks, "task view"),
                       (args.pnml, "PNML"), (args.net_json, "net JSON")):
        if flag:
            print(f"  wrote {what} to {flag}")
    if "verification" in report:
        from petri.verify import format_text

        print(format_text(report["verification"]))


if __name__ == "__main__":
    sys.exit(main())
