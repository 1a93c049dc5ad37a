"""The report ``mclc`` gives of one compiled mission (a file's, or a fleet vehicle's): its
summary, its verification, its proved durations, as JSON and as text.

Its statuses are those of every command (``mission.exits.Exit``, docs/EXIT.md); with several
verdicts, the worst (:data:`SEVERITY`).
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Callable
from typing import Any

from diagnostics import Diagnostic
from mcl.analysis import verdicts
from mcl.api import Compiled
from petri.net import Net

from mission.exits import SEVERITY as SEVERITY  # worst last (mclc's, fleet_check's)
from mission.exits import Exit

GraphWriter = Callable[[str, str, Net, Any, str], None]  # mclc's --graphml writer


def verify_and_report(compiled: Compiled, args: argparse.Namespace, fmt: str,
                      write_graph: GraphWriter | None = None,
                      title: str | None = None, part: str = "") -> tuple[Exit, dict[str, Any]]:
    """Verify a compiled mission as ``args`` ask (``--no-verify``, ``--method``, limits) and
    report it; in text, print it under ``title`` (default ``FILE: mission NAME``). ``part``
    names the mission within its file when a file holds several (a fleet's vehicle)."""
    report = summary(compiled)
    status = Exit.OK
    if not args.no_verify:
        verdict = verify(compiled, args, write_graph, part)
        report["verification"] = verdict.report
        status = (Exit.OK if verdict.ok else Exit.FAILED if verdict.failed
                  else Exit.UNDECIDED)
        report["status"] = ("verified" if verdict.ok else "property-fails" if verdict.failed
                            else "undecided")
    from app.reports.duration import check as check_durations  # start-up speed, as above

    bounds = check_durations(compiled.checked, args.limits)
    report["duration"] = bounds.report
    if bounds.failures:
        status = max(status, Exit.FAILED, key=SEVERITY.index)
        report["status"] = "property-fails"
    if fmt == "text":
        print_text(compiled, report, args, title)
        if args.limits.asked:
            print("\n".join([f"  FAIL {f}" for f in bounds.failures] + bounds.lines))
    return status, report


def verify(compiled: Compiled, args: argparse.Namespace, write_graph: GraphWriter | None,
           part: str = "") -> verdicts.Report:
    """The verification's report: from the cache when the same mission, options and code were
    verified before (mcl/analysis/verdicts.py), but with ``--graphml``, which writes the graph
    a verification explores."""
    if args.graphml is None or write_graph is None:
        return verdicts.verified(compiled, args.method, args.max_markings, args.max_memory, part)
    from mcl.analysis.verification import verify_mission  # numpy: loaded when needed

    verdict = verify_mission(compiled, args.method, max_markings=args.max_markings,
                             max_bytes=args.max_memory, keep_graph=True)
    write_graph(compiled.source.name, args.graphml, compiled.net, verdict.space,
                "--method auto took the structural route")
    return verdicts.Report.of(verdict)


def summary(compiled: Compiled) -> dict[str, Any]:
    """What a compiled mission is: its task calls, its net's size, its parameters and its
    warnings."""
    m = compiled.mission
    tasks = [{"task": c.name, "line": c.span.line, "col": c.span.col}
             for c in m.calls()]
    return {"file": compiled.source.name, "mission": m.name, "status": "compiled",
            "tasks": len(tasks), "task_calls": tasks,
            "places": len(compiled.net.places), "transitions": len(compiled.net.transitions),
            "arcs": compiled.net.arc_count(),
            "parameters": {"set": sorted(compiled.checked.params),
                           "unset": compiled.checked.unset},
            "diagnostics": [diag_json(d) for d in compiled.warnings]}


def print_text(compiled: Compiled, report: dict[str, Any], args: argparse.Namespace,
               title: str | None = None) -> None:
    for d in compiled.warnings:
        print(d.format(), file=sys.stderr)
    head = title or f"{compiled.source.name}: mission {compiled.name}"
    print(f"{head}: {report['tasks']} task calls, "
          f"{report['places']} places, {report['transitions']} transitions")
    for flag, what in ((args.dot, "full net"), (args.dot_tasks, "task view"),
                       (args.pnml, "PNML"), (args.net_json, "net JSON"),
                       (args.graphml, "reachability graph")):
        if flag:
            print(f"  wrote {what} to {flag}")
    if "verification" in report:
        from app.reports.text import verification_text  # start-up speed, as above

        print(verification_text(report["verification"]))


def diag_json(d: Diagnostic) -> dict[str, Any]:
    """A diagnostic in mclc's JSON report."""
    span = d.span
    return {"severity": d.severity, "message": d.message, "hint": d.hint, "code": d.code,
            "file": span.file if span else None, "line": span.line if span else None,
            "col": span.col if span else None}
