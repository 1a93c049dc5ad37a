"""MCL's diagnostics and mclc's verdict as the Language Server Protocol's diagnostics.

* A parse, library or check error (a :class:`diagnostics.Diagnostic`) keeps its place, its
  hint (appended to the message, as ``mclc`` prints it) and its code.
* A property that fails or is undecided sits where ``mclc``'s reports put it
  (app/reports/formats.py: the MCL line of the counterexample's last step, the line that
  turned the behaviour on), with every step of the counterexample, and of a lasso's loop, as
  related information at its own MCL line.
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


def from_verification(source: Source, verification: dict[str, Any]) -> list[types.Diagnostic]:
    """Each property of mclc's verdict (its JSON, ``Verdict.to_json()``) that fails or is
    undecided, at the place mclc's reports give it."""
    out = []
    for p in verification.get("properties", []):
        if p["holds"] or p["property"] in NOT_ACTIONABLE:
            continue
        [where] = problems({"file": source.name, "verification": {"properties": [p]}})
        undecided = p.get("status") == "undecided"
        steps = [("", s) for s in p.get("counterexample") or []]
        steps += [("loop: ", s) for s in p.get("cycle") or []]
        related = [types.DiagnosticRelatedInformation(
            types.Location(uris.from_fs_path(s["file"]) or s["file"],
                           word_range(source, s["line"], s["col"])),
            f"{i}. {loop}{s['construct']}: {s['label']}"
            + (f" on {s['event']}" if s.get("event") else ""))
            for i, (loop, s) in enumerate(steps, 1) if s.get("file")]
        out.append(types.Diagnostic(
            word_range(source, where["line"], where["col"]),
            ("undecided: " if undecided else "") + p["message"],
            severity=SEVERITY[where["level"]], code=p["property"], source=SOURCE,
            related_information=related or None))
    return out


def stopped(source: Source, why: str) -> types.Diagnostic:
    """A proof that could not finish (too long, crashed): one note at the top of the file."""
    return types.Diagnostic(word_range(source, 0, 0), f"not verified: {why}",
                            severity=types.DiagnosticSeverity.Information,
                            code="not-verified", source=SOURCE)
