"""MCL's diagnostics and mclc's verdict as the Language Server Protocol's diagnostics.

* A parse, library or check error (a :class:`diagnostics.Diagnostic`) keeps its place, its
  hint (appended to the message, as ``mclc`` prints it) and its code.
* A property that fails or is undecided sits where ``mclc``'s reports put it
  (app/reports/formats.py: the MCL line of the counterexample's last step, the line that
  turned the behaviour on), with every step of the counterexample, and of a lasso's loop, as
  related information at its own MCL line.
* In a fleet, each vehicle's properties likewise, their messages after the vehicle's name;
  then each fleet property that fails or is undecided, where mclc's reports put it, with its
  counterexample's steps interleaved as the run took them, each vehicle's at its MCL line
  and a channel's (a message ignored or lost) at the channel's declaration.
"""

from __future__ import annotations

from typing import Any

from lsprotocol import types
from pygls import uris

from app.reports.formats import problems
from diagnostics import Diagnostic, Source

# Properties whose failure an author cannot act on: template paths a mission cannot take
# (every mission has some). They stay in mclc's reports, not in the editor.
NOT_ACTIONABLE = ("no-dead-transitions",)
SOURCE = "mcl"  # the name editors show beside each diagnostic

SEVERITY = {"error": types.DiagnosticSeverity.Error,
            "warning": types.DiagnosticSeverity.Warning,
            "note": types.DiagnosticSeverity.Information}


def word_range(source: Source, line: int, col: int, end_line: int = 0,
               end_col: int = 0) -> types.Range:
    """The LSP range (0-based) of a place given 1-based: to ``end_line:end_col`` when known,
    else the word (name, number) that starts at ``line:col``, at least one character."""
    if line <= 0:  # the file as a whole
        return types.Range(types.Position(0, 0), types.Position(0, 0))
    start = types.Position(line - 1, max(col - 1, 0))
    if end_line >= line and (end_line > line or end_col > col):
        return types.Range(start, types.Position(end_line - 1, max(end_col - 1, 0)))
    text = source.line(line)
    end = max(col - 1, 0)
    while end < len(text) and (text[end].isalnum() or text[end] in "_."):
        end += 1
    return types.Range(start, types.Position(line - 1, max(end, start.character + 1)))


def from_mcl(source: Source, d: Diagnostic) -> types.Diagnostic:
    """A parse, library or check diagnostic of ``source``."""
    span = d.span
    here = span is not None and span.file == source.name
    rng = (word_range(source, span.line, span.col, span.end_line, span.end_col)
           if span is not None and here else word_range(source, 0, 0))
    message = d.message if here or span is None else f"{span}: {d.message}"
    return types.Diagnostic(rng, message + (f" (hint: {d.hint})" if d.hint else ""),
                            severity=SEVERITY.get(d.severity, types.DiagnosticSeverity.Error),
                            code=d.code or None, source=SOURCE)


def from_verification(source: Source, verification: dict[str, Any],
                      vehicle: str = "") -> list[types.Diagnostic]:
    """Each property of mclc's verdict (its JSON, ``Verdict.to_json()``) that fails or is
    undecided, at the place mclc's reports give it; in a fleet, ``vehicle``'s verdict (its
    name before each message)."""
    out = []
    for p in verification.get("properties", []):
        if p["holds"] or p["property"] in NOT_ACTIONABLE:
            continue
        steps = [("", s) for s in p.get("counterexample") or []]
        steps += [("loop: ", s) for s in p.get("cycle") or []]
        related = [types.DiagnosticRelatedInformation(
            types.Location(uris.from_fs_path(s["file"]) or s["file"],
                           word_range(source, s["line"], s["col"])),
            f"{i}. {loop}{step_text(s)}")
            for i, (loop, s) in enumerate(steps, 1) if s.get("file")]
        out.append(property_diagnostic(source, p, related, f"{vehicle}: " if vehicle else ""))
    return out


def from_fleet(source: Source, fleet: dict[str, Any]) -> list[types.Diagnostic]:
    """Each fleet property of a fleet's verdict (``FleetVerdict.to_json()`` with
    ``channel_places``) that fails or is undecided, at the place mclc's reports give it (the
    MCL line of its counterexample's last vehicle step), with every step, each vehicle's and
    each channel's, in the order of the run."""
    uri = uris.from_fs_path(source.name) or source.name
    places = fleet.get("channel_places", {})
    out = []
    for p in fleet.get("properties", []):
        if p["holds"]:
            continue
        steps = [("", s) for s in p.get("counterexample") or []]
        steps += [("loop: ", s) for s in p.get("cycle") or []]
        related = []
        for i, (loop, s) in enumerate(steps, 1):
            if s.get("vehicle") is None:  # a channel's step: at the channel's declaration
                line, col = places.get(s.get("channel"), (0, 0))
                text = s["text"]
            else:
                line, col = s.get("line") or 0, s.get("col") or 0
                text = f"{s['vehicle']} {step_text(s)}"
            related.append(types.DiagnosticRelatedInformation(
                types.Location(uris.from_fs_path(s["file"]) or s["file"]
                               if s.get("file") else uri, word_range(source, line, col)),
                f"{i}. {loop}{text}"))
        out.append(property_diagnostic(source, p, related, f"fleet {fleet['fleet']}: "))
    return out


def step_text(step: dict[str, Any]) -> str:
    """A step of a counterexample in the mission's words: construct, what happened, the
    event it took."""
    event = step.get("event")
    return f"{step['construct']}: {step['label']}" + (
        f" on {event}" if event and event not in step["label"] else "")


def property_diagnostic(source: Source, p: dict[str, Any],
                        related: list[types.DiagnosticRelatedInformation],
                        whose: str) -> types.Diagnostic:
    """A property that fails or is undecided, at the place mclc's reports give it."""
    [where] = problems({"file": source.name, "verification": {"properties": [p]}})
    said = p["message"]
    if p.get("status") == "undecided" and not said.startswith("undecided"):
        said = "undecided: " + said
    return types.Diagnostic(
        word_range(source, where["line"], where["col"]), whose + said,
        severity=SEVERITY[where["level"]], code=p["property"], source=SOURCE,
        related_information=related or None)


def stopped(source: Source, why: str) -> types.Diagnostic:
    """A proof that could not finish (too long, crashed): one note at the top of the file."""
    return types.Diagnostic(word_range(source, 0, 0), f"not verified: {why}",
                            severity=types.DiagnosticSeverity.Information,
                            code="not-verified", source=SOURCE)
