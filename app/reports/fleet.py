"""The text ``mclc`` prints for a fleet's own properties (after each vehicle's): a line per
property, as for one mission, each counterexample as the vehicles' lines interleaved in the
order of the run (``uuv mcm.mcl:23:9 Receive(guide, fix): ...``, ``channel guide: fix lost on
its way to uuv``), a lasso's loop after its prefix, and the method. Made from the JSON report
(:meth:`mcl.analysis.fleet_verification.FleetVerdict.to_json`)."""

from __future__ import annotations

from typing import Any


def fleet_text(report: dict[str, Any]) -> str:
    """The fleet part of ``mclc``'s text output."""
    head = ("verified" if report["verified"] else
            "UNDECIDED" if report.get("undecided") else "NOT verified")
    size = (f"{report['reachable_markings']:,} joint markings, "
            f"{report['reachability_arcs']:,} arcs, " if report["reachable_markings"] else "")
    lines = [f"fleet {report['fleet']}: the fleet's properties",
             f"  {head}: {size}{report['seconds']:.3f} s"]
    if report.get("note"):
        lines.append(f"  ({report['note']})")
    for r in report["properties"]:
        mark = {"holds": "ok  ", "undecided": "????"}.get(r["status"], "FAIL")
        lines.append(f"  [{mark}] {r['property']}: {r['message']}")
        if r["counterexample"] is not None:
            lines.append("         the run, each vehicle's lines in turn:"
                         if not r.get("cycle") else "         the run to the loop:")
            lines += _steps(r["counterexample"], 1)
            if r.get("cycle"):
                lines.append("         then round and round for ever:")
                lines += _steps(r["cycle"], len(r["counterexample"]) + 1)
    methods = sorted({r["method"] for r in report["properties"]})
    for m in methods:
        names = [r["property"] for r in report["properties"] if r["method"] == m]
        lines.append(f"  method for {', '.join(names)}: {m}" if len(methods) > 1
                     else f"  method: {m}")
    return "\n".join(lines)


def _steps(steps: list[dict[str, Any]], first: int) -> list[str]:
    return [f"         {i:3}. {s['text']}" for i, s in enumerate(steps, first)]


def fleet_entry(report: dict[str, Any]) -> list[dict[str, Any]]:
    """A fleet's own properties as one more report for the CI formats (named ``FILE fleet
    NAME``, after its vehicles'); none for a mission, or a fleet not verified."""
    proof = report.get("fleet_properties")
    if not proof:
        return []
    status = ("verified" if proof["verified"] else "undecided" if proof["undecided"]
              else "property-fails")
    return [{"file": report["file"], "vehicle": f"fleet {proof['fleet']}", "status": status,
             "verification": proof}]
