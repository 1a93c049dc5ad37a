"""Reports for CI systems, all made from mclc's JSON report of each file.

* ``junit``: JUnit XML, one test suite per file, one test case per property (and one for the
  input itself when it is not valid MCL); a failed property carries its counterexample.
* ``sarif``: SARIF 2.1.0, one result per error, warning and failed property, located at the
  MCL line (for a property: the source line of the counterexample's last step); a
  counterexample is a ``codeFlow`` with a location per step (a lasso's loop after its run);
  the rules carry help text and a link into the documents (:mod:`app.reports.rules`); files
  are URIs relative to the root of the repository mclc runs in (``%SRCROOT%``) or, outside
  it, ``file://`` URIs.
* ``no-dead-transitions`` is not reported in ``sarif`` and ``github`` for a mission: its
  dead transitions are template paths the mission cannot take, nothing an author can act on.
* A deadline or battery that some run can break (``mclc --deadline/--battery``, the JSON's
  ``duration.failures``) is a failure / error too, located at the longest step of the critical
  path (docs/DURATION.md).
* ``github``: GitHub Actions workflow commands (``::error file=...,line=...::``) that show as
  annotations on the mission's lines in a pull request.
"""

from __future__ import annotations

import json
import os
import xml.etree.ElementTree as ET
from pathlib import Path
from typing import Any
from urllib.parse import quote

from app.reports.fleet import fleet_entry
from app.reports.rules import docs_uri, rule

NOT_ACTIONABLE = {"no-dead-transitions"}  # for a mission: template paths it cannot take


def _problems(report: dict[str, Any]) -> list[dict[str, Any]]:
    """Every diagnostic and failed property of one file, each with a place and a level (and,
    for a property, the steps of its counterexample and of its loop)."""
    out = []
    for d in report.get("diagnostics", []):
        out.append({"rule": d.get("code") or "mcl", "level": d["severity"],
                    "message": d["message"] + (f" (hint: {d['hint']})" if d.get("hint") else ""),
                    "file": d.get("file") or report["file"], "line": d.get("line") or 1,
                    "col": d.get("col") or 1, "about": d["message"], "hint": d.get("hint") or ""})
    mission = "mission" in report
    for p in report.get("verification", {}).get("properties", []):
        if p["holds"] or (mission and p["property"] in NOT_ACTIONABLE):
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
                    "col": last.get("col") or 1, "steps": located,
                    "loop": [s for s in p.get("cycle") or [] if s.get("file")],
                    "about": ("undecided: " if undecided else "") + p["message"], "hint": ""})
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
    steps = [{"file": report["file"], "line": s.get("line") or 1, "col": s.get("col") or 1,
              "construct": s["task"], "label": f"{s['ending']} ({s['seconds']} s)"}
             for s in path if s["seconds"] != 0]
    return [{"rule": "deadline" if text.startswith("deadline") else "battery",
             "level": "error", "message": text + (f" — critical path: {trace}" if trace else ""),
             "file": report["file"], "line": longest.get("line") or 1,
             "col": longest.get("col") or 1, "about": text, "hint": "", "steps": steps}
            for text in duration.get("failures", [])]


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
        lines.append(f"{_suite(report)}: {status}")
    return "\n".join(lines)


def _suite(report: dict[str, Any]) -> str:
    """A report's name: its file, and a fleet's vehicle after it (``mcm.mcl uuv``)."""
    vehicle = report.get("vehicle")
    return str(report["file"]) + (f" {vehicle}" if vehicle else "")


def flat(reports: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """The reports of missions: a fleet's report (``vehicles``) gives one per vehicle, then
    one for the fleet's own properties."""
    return [r for report in reports
            for r in (report.get("vehicles") or [report]) + fleet_entry(report)]


def junit(reports: list[dict[str, Any]]) -> str:
    suites = ET.Element("testsuites", name="mclc")
    for report in reports:
        suite = ET.SubElement(suites, "testsuite", name=_suite(report))
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
            case = ET.SubElement(suite, "testcase", classname=_suite(report),
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
            case = ET.SubElement(suite, "testcase", classname=_suite(report), name=key)
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


def source_root() -> Path:
    """``%SRCROOT%``: the repository mclc runs in (the nearest directory up from the current
    one that holds ``.git``), else the current directory."""
    here = Path.cwd()
    return next((d for d in (here, *here.parents) if (d / ".git").exists()), here)


def artifact(file: str, root: Path) -> dict[str, str]:
    """A SARIF artifact location: relative to ``%SRCROOT%`` when the file is under ``root``,
    else a ``file://`` URI."""
    absolute = Path(os.path.normpath(Path.cwd() / file))
    try:
        relative = absolute.relative_to(root)
    except ValueError:
        return {"uri": absolute.as_uri()}
    return {"uri": quote(relative.as_posix()), "uriBaseId": "%SRCROOT%"}


def _location(file: str, line: int, col: int, text: str = "") -> dict[str, Any]:
    where: dict[str, Any] = {"physicalLocation": {
        "artifactLocation": artifact(file, source_root()),
        "region": {"startLine": line, "startColumn": col}}}
    if text:
        where["message"] = {"text": text}
    return where


def _step_text(step: dict[str, Any]) -> str:
    """One firing of a counterexample in the mission's words: construct, what happened, the
    actions it sends."""
    text = f"{step.get('construct')}: {step.get('label')}"
    if step.get("event"):
        text += f" (on {step['event']})"
    if step.get("actions"):
        text += " — sends " + ", ".join(step["actions"])
    return text


def code_flow(steps: list[dict[str, Any]], loop: list[dict[str, Any]]) -> dict[str, Any]:
    """A counterexample as one thread of locations, a step each; a lasso's loop follows its
    run, its steps marked as the loop's."""
    located = [(s, "") for s in steps] + [(s, f"loop {i}/{len(loop)}: ")
                                          for i, s in enumerate(loop, 1)]
    return {"message": {"text": "the steps that show it"
                        + (", then the loop that repeats" if loop else "")},
            "threadFlows": [{"locations": [
                {"location": _location(s["file"], s["line"], s["col"],
                                       f"{i}. {prefix}{_step_text(s)}"),
                 "executionOrder": i, "nestingLevel": 0}
                for i, (s, prefix) in enumerate(located, 1)]}]}


def sarif(reports: list[dict[str, Any]]) -> str:
    rules: dict[str, dict[str, Any]] = {}
    results = []
    for report in reports:
        for p in _problems(report):
            if p["rule"] not in rules:
                rules[p["rule"]] = rule(p["rule"], p["level"], p["about"], p["hint"])
            result: dict[str, Any] = {
                "ruleId": p["rule"],
                "ruleIndex": list(rules).index(p["rule"]),
                "level": "error" if p["level"] == "error" else "warning",
                "message": {"text": p["about"] if p.get("steps") or p.get("loop")
                            else p["message"]},
                "locations": [_location(p["file"], p["line"], p["col"])],
            }
            if p.get("steps") or p.get("loop"):
                result["codeFlows"] = [code_flow(p.get("steps", []), p.get("loop", []))]
            results.append(result)
    driver: dict[str, Any] = {"name": "mclc", "rules": list(rules.values())}
    base = docs_uri()
    if base is not None:
        driver["informationUri"] = base + "CI.md"
    doc = {
        "$schema": "https://json.schemastore.org/sarif-2.1.0.json",
        "version": "2.1.0",
        "runs": [{"tool": {"driver": driver},
                  "originalUriBaseIds": {"%SRCROOT%": {"uri": source_root().as_uri() + "/"}},
                  "columnKind": "unicodeCodePoints",
                  "results": results}],
    }
    return json.dumps(doc, indent=2)
