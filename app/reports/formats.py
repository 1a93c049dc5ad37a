"""Reports for CI systems, all made from mclc's JSON report of each file.

* ``junit``: JUnit XML, one test suite per file, one test case per property (and one for the
  input itself when it is not valid MCL); a failed property carries its counterexample.
* ``sarif``: SARIF 2.1.0, one result per error, warning and failed property, located at the
  MCL line (for a property: the source line of the counterexample's last step).
* A deadline or battery that some run can break (``mclc --deadline/--battery``, the JSON's
  ``duration.failures``) is a failure / error too, located at the longest step of the critical
  path (docs/DURATION.md).
* ``github``: GitHub Actions workflow commands (``::error file=...,line=...::``) that show as
  annotations on the mission's lines in a pull request.
"""

from __future__ import annotations

import json
import xml.etree.ElementTree as ET
from typing import Any

TOOL_URI = "https://example.invalid/mcl"  # no public home yet; SARIF wants a URI


def _problems(report: dict[str, Any]) -> list[dict[str, Any]]:
    """Every diagnostic and failed property of one file, each with a place and a level."""
    out = []
    for d in report.get("diagnostics", []):
        out.append({"rule": d.get("code") or "mcl", "level": d["severity"],
                    "message": d["message"] + (f" (hint: {d['hint']})" if d.get("hint") else ""),
                    "file": d.get("file") or report["file"], "line": d.get("line") or 1,
                    "col": d.get("col") or 1})
    for p in report.get("verification", {}).get("properties", []):
        if p["holds"]:
            continue
        steps = p.get("counterexample") or []
        located = [s for s in steps if s.get("file")]
        last = located[-1] if located else {}
        trace = "; ".join(f"{s['line']}:{s['col']} {s['construct']}: {s['label']}"
                          + (f" on {s['event']}" if s.get("event") else "")
                          for s in located)
        undecided = p.get("status") == "undecided"
        level = "error" if p["severity"] == "error" and not undecided else "warning"
        out.append({"rule": p["property"], "level": level,
                    "message": ("undecided: " if undecided else "") + p["message"]
                    + (f" — shortest run: {trace}" if trace else ""),
                    "file": last.get("file") or report["file"], "line": last.get("line") or 1,
                    "col": last.get("col") or 1})
    out += _duration_problems(report)
    return out


def _duration_problems(report: dict[str, Any]) -> list[dict[str, Any]]:
    """A deadline or battery that some run can break (mclc --deadline/--battery, see
    docs/DURATION.md): an error at the longest step of the critical path."""
    duration = report.get("duration") or {}
    path = duration.get("critical_path") or []
    longest: dict[str, Any] = max(path, key=lambda s: float("inf") if s["seconds"] is None else s["seconds"],
                  default={})
    trace = "; ".join(f"{s['line']}: {s['task']} {s['ending']}" for s in path
                      if s["seconds"] != 0)
    return [{"rule": "deadline" if text.startswith("deadline") else "battery",
             "level": "error", "message": text + (f" — critical path: {trace}" if trace else ""),
             "file": report["file"], "line": longest.get("line") or 1,
             "col": longest.get("col") or 1} for text in duration.get("failures", [])]


def problems(report: dict[str, Any]) -> list[dict[str, Any]]:
    """Every diagnostic and failed or undecided property of one file (mclc's JSON report),
    each with its rule, level, message and MCL place: what every format here (and the
    language server, app/lsp/) reports."""
    return _problems(report)


def github(reports: list[dict[str, Any]]) -> str:
    def esc(text: str) -> str:
        return text.replace("%", "%25").replace("\r", "%0D").replace("\n", "%0A")

    lines = []
    for report in reports:
        for p in _problems(report):
            kind = "error" if p["level"] == "error" else "warning"
            lines.append(f"::{kind} file={p['file']},line={p['line']},col={p['col']},"
                         f"title=mclc {p['rule']}::{esc(p['message'])}")
        status = report.get("status")
        lines.append(f"{report['file']}: {status}")
    return "\n".join(lines)


def junit(reports: list[dict[str, Any]]) -> str:
    suites = ET.Element("testsuites", name="mclc")
    for report in reports:
        suite = ET.SubElement(suites, "testsuite", name=report["file"])
        cases = 0
        failures = 0
        errors = 0
        if report.get("status") in ("invalid", "internal-error"):
            case = ET.SubElement(suite, "testcase", classname=report["file"], name="valid MCL")
            tag = "failure" if report["status"] == "invalid" else "error"
            text = "\n".join(f"{d['file']}:{d['line']}:{d['col']}: {d['message']}"
                             for d in report.get("diagnostics", [])) or report.get("message", "")
            ET.SubElement(case, tag, message=text.splitlines()[0] if text else tag).text = text
            cases, failures, errors = 1, int(tag == "failure"), int(tag == "error")
        for p in report.get("verification", {}).get("properties", []):
            cases += 1
            case = ET.SubElement(suite, "testcase", classname=report["file"],
                                 name=p["property"])
            if p["holds"]:
                continue
            if p["severity"] != "error":
                ET.SubElement(case, "system-out").text = f"warning: {p['message']}"
                continue
            if p.get("status") == "undecided":  # neither proved nor refuted: not a pass
                ET.SubElement(case, "skipped", message=f"undecided: {p['message']}")
                continue
            failures += 1
            steps = p.get("counterexample") or []
            body = "\n".join(f"{i}. {s.get('file')}:{s.get('line')}:{s.get('col')} "
                             f"{s.get('construct')}: {s.get('label')}"
                             for i, s in enumerate(steps, 1))
            ET.SubElement(case, "failure", message=p["message"]).text = body
        duration = report.get("duration") or {}
        for key in ("deadline", "battery"):  # asked with mclc --deadline / --battery
            if key not in duration:
                continue
            cases += 1
            case = ET.SubElement(suite, "testcase", classname=report["file"], name=key)
            for p in _duration_problems(report):
                if p["rule"] == key:
                    failures += 1
                    ET.SubElement(case, "failure", message=p["message"].split(" — ")[0]
                                  ).text = p["message"]
        suite.set("tests", str(cases))
        suite.set("failures", str(failures))
        suite.set("errors", str(errors))
    ET.indent(suites)
    return '<?xml version="1.0" encoding="UTF-8"?>\n' + ET.tostring(suites, "unicode")


def sarif(reports: list[dict[str, Any]]) -> str:
    rules: dict[str, dict[str, Any]] = {}
    results = []
    for report in reports:
        for p in _problems(report):
            rules.setdefault(p["rule"], {"id": p["rule"],
                                         "shortDescription": {"text": p["rule"]}})
            results.append({
                "ruleId": p["rule"],
                "level": "error" if p["level"] == "error" else "warning",
                "message": {"text": p["message"]},
                "locations": [{"physicalLocation": {
                    "artifactLocation": {"uri": p["file"]},
                    "region": {"startLine": p["line"], "startColumn": p["col"]}}}],
            })
    doc = {
        "$schema": "https://json.schemastore.org/sarif-2.1.0.json",
        "version": "2.1.0",
        "runs": [{"tool": {"driver": {"name": "mclc", "informationUri": TOOL_URI,
                                      "rules": list(rules.values())}},
                  "results": results}],
    }
    return json.dumps(doc, indent=2)
