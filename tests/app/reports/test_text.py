"""app/reports/text.py: the verification part of mclc's text output, from the JSON report."""

from __future__ import annotations

from typing import Any

from app.reports.text import verification_text
from diagnostics import Source
from mcl import tasklib
from mcl.api import compile_source
from petri.verification.properties import verify


def step(line: int, label: str, **extra: Any) -> dict[str, Any]:
    return {"transition": f"t{line}", "label": label, "event": extra.get("event"),
            "timer": extra.get("timer"), "actions": extra.get("actions", []), "file": "m.mcl",
            "line": line, "col": 3, "construct": extra.get("construct", "A()")}


def prop(name: str, status: str, message: str, method: str = "explicit",
         severity: str = "error", **extra: Any) -> dict[str, Any]:
    return {"property": name, "holds": status == "holds", "status": status,
            "severity": severity, "message": message, "method": method,
            "counterexample": extra.get("counterexample"), "cycle": extra.get("cycle"),
            "marking": extra.get("marking")}


def test_each_status_its_mark_and_a_lasso_numbered_on() -> None:
    report = {"verified": False, "undecided": False, "reachable_markings": 12,
              "reachability_arcs": 20, "seconds": 0.01234, "properties": [
                  prop("one-safe", "holds", "every place holds at most one token"),
                  prop("terminates", "fails", "it loops", counterexample=[
                      step(1, "mission starts", construct="MISSION")], cycle=[
                      step(2, "end", event="Probe.ok", actions=["enable Lamp"]),
                      step(3, "again", timer=2.0)], marking="{a, b}"),
                  prop("no-zeno", "undecided", "it depends", method="outcomes"),
                  prop("no-dead-transitions", "fails", "2 never fire", severity="warning")]}
    assert verification_text(report).splitlines() == [
        "  NOT verified: 12 reachable markings, 20 arcs, 0.012 s",
        "  [ok  ] one-safe: every place holds at most one token",
        "  [FAIL] terminates: it loops",
        "         shortest firing sequence to the loop:",
        "           1. m.mcl:1:3  MISSION: mission starts",
        "         then round and round for ever:",
        "           2. m.mcl:2:3  A(): end on Probe.ok  [enable Lamp]",
        "           3. m.mcl:3:3  A(): again after 2.0 s",
        "         reaching the marking {a, b}",
        "  [????] no-zeno: it depends",
        "  [warn] no-dead-transitions: 2 never fire",
        "  method for one-safe, terminates, no-dead-transitions: explicit",
        "  method for no-zeno: outcomes",
    ]


def test_a_verdict_not_enumerated_and_one_method() -> None:
    report = {"verified": True, "undecided": False, "reachable_markings": 0,
              "reachability_arcs": 0, "seconds": 0.5, "properties": [
                  prop("one-safe", "holds", "by construction", method="templates")]}
    assert verification_text(report).splitlines() == [
        "  verified by construction and static analysis (the state space is not "
        "enumerated), 0.500 s",
        "  [ok  ] one-safe: by construction",
        "  method: templates",
    ]


def test_the_text_of_a_real_verdict() -> None:
    net = compile_source(Source("w.mcl", "MISSION { A(); WHILE { Now() } DO { Now() } }"),
                         library=tasklib.load(["generic"])).net
    report = verify(net).to_json()
    lines = verification_text(report).splitlines()
    assert lines[0].startswith(f"  NOT verified: {report['reachable_markings']} reachable ")
    assert "  [FAIL] no-zeno: the WHILE at line 1 can go round without time passing" in "\n".join(
        lines)
    assert sum(line.startswith("  [") for line in lines) == len(report["properties"])
