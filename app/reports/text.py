"""The text ``mclc`` prints for a verified mission: a line per property ([ok  ], [FAIL],
[warn] or [????] for undecided), each counterexample as numbered firings in the mission's words
(file:line:col, construct, label, event or timer, actions), and the method of each property.
Made from the JSON report, like the CI formats (:mod:`app.reports.formats`)."""

from __future__ import annotations

from typing import Any


def verification_text(report: dict[str, Any]) -> str:
    """The verification part of ``mclc``'s text output, from the JSON report's
    ``verification`` (:meth:`petri.verification.verdict.Verdict.to_json`)."""
    lines: list[str] = []
    head = ("verified" if report["verified"] else
            "UNDECIDED" if report.get("undecided") else "NOT verified")
    if report["reachable_markings"]:
        lines.append(f"  {head}: {report['reachable_markings']} reachable markings, "
                     f"{report['reachability_arcs']} arcs, {report['seconds']:.3f} s")
    else:
        lines.append(f"  {head} by construction and static analysis (the state space is "
                     f"not enumerated), {report['seconds']:.3f} s")
    for r in report["properties"]:
        status = r.get("status", "holds" if r["holds"] else "fails")
        mark = ("ok  " if status == "holds" else "????" if status == "undecided"
                else "FAIL" if r["severity"] == "error" else "warn")
        lines.append(f"  [{mark}] {r['property']}: {r['message']}")
        if r["counterexample"] is not None:
            lines.append("         shortest firing sequence from the start:"
                         if not r.get("cycle") else
                         "         shortest firing sequence to the loop:")
            lines += _steps(r["counterexample"], 1)
            if r.get("cycle"):
                lines.append("         then round and round for ever:")
                lines += _steps(r["cycle"], len(r["counterexample"]) + 1)
            if r.get("marking"):
                lines.append(f"         reaching the marking {r['marking']}")
    methods = sorted({r["method"] for r in report["properties"]})
    for m in methods:
        names = [r["property"] for r in report["properties"] if r["method"] == m]
        lines.append(f"  method for {', '.join(names)}: {m}" if len(methods) > 1
                     else f"  method: {m}")
    if report.get("cached"):
        lines.append("  (the verdict of an earlier call: the same net, options and code; "
                     "MCL_CACHE_DIR= verifies again)")
    return "\n".join(lines)


def _steps(steps: list[dict[str, Any]], first: int) -> list[str]:
    """The firings of a counterexample, one a line, numbered from ``first``."""
    lines = []
    for i, s in enumerate(steps, first):
        where = f"{s['file']}:{s['line']}:{s['col']}" if s["file"] else ""
        extra = f" on {s['event']}" if s["event"] else ""
        extra += f" after {s['timer']} s" if s["timer"] is not None else ""
        acts = f"  [{'; '.join(s['actions'])}]" if s["actions"] else ""
        lines.append(f"         {i:3}. {where}  {s['construct']}: {s['label']}{extra}{acts}")
    return lines
