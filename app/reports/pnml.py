"""The text of the state-space report of a P/T net (``mclc NET.pnml``, ``python -m
app.pnml_report``): one line per answer of :func:`petri.verification.pnml_report.analyse`,
"unknown" for an answer a cut search cannot give."""

from __future__ import annotations

from typing import Any

KEYS = ["net", "places", "transitions", "method", "complete", "markings", "arcs",
        "max_tokens", "one_safe", "deadlock_reachable", "dead_transitions",
        "stop_reason", "unbounded_place", "bdd_nodes", "seconds"]


def pnml_text(report: dict[str, Any]) -> str:
    """The report, a line per key it has: the key's words, then its value."""
    width = max(len(k) for k in KEYS)
    return "\n".join(f"{k.replace('_', ' '):<{width}}  {_shown(report[k])}"
                     for k in KEYS if k in report)


def _shown(value: Any) -> str:
    """A value as the report shows it: yes/no, "unknown" for None, "none" for no names,
    thousands separated."""
    if value is None:
        return "unknown"
    if isinstance(value, bool):
        return "yes" if value else "no"
    if isinstance(value, list):
        return ", ".join(value) if value else "none"
    return f"{value:,}" if isinstance(value, int) else str(value)
