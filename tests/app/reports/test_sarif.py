"""mclc's SARIF for code scanning (app/reports/formats.py, app/reports/rules.py): every step of
a counterexample is a location of a codeFlow, at the MCL line the JSON report gives (a lasso's
loop after its run); rules carry help text and, under a documents URI, a link into docs/; files
are repository-relative or file:// URIs; no warning for template paths a mission cannot take."""

from __future__ import annotations

import json
import re
from pathlib import Path
from typing import Any

import pytest

from app.reports import formats, rules
from tests.support import MISSIONS, REPO, cli, write

CONFLICT = "MISSION {\n  PARALLEL { GoTo((0, 0, 5, 0)) } AND { Surface() }\n}\n"
LASSO = ("PARAM start = (0, 0, 1, 0);\nMISSION m {\n"
         "    WHILE { Wait(1 s) } DO { GoTo(start, timeout = 2 min) }\n}\n")


def mclc(*args: str, cwd: Path | None = None) -> tuple[dict[str, Any], dict[str, Any]]:
    """The JSON report and the SARIF of one mission."""
    report = json.loads(cli("mclc", *args, "--json", cwd=cwd).stdout)
    return report, json.loads(cli("mclc", *args, "--format", "sarif", cwd=cwd).stdout)


def steps_of(flow: dict[str, Any]) -> list[tuple[int, int, str]]:
    return [(loc["location"]["physicalLocation"]["region"]["startLine"],
             loc["location"]["physicalLocation"]["region"]["startColumn"],
             loc["location"]["message"]["text"])
            for loc in flow["threadFlows"][0]["locations"]]


def test_a_counterexample_is_a_code_flow_a_location_a_step(tmp_path: Path) -> None:
    bad = write(tmp_path, CONFLICT, "conflict.mcl")
    report, doc = mclc(str(bad), cwd=tmp_path)
    prop = next(p for p in report["verification"]["properties"] if not p["holds"])
    (result,) = [r for r in doc["runs"][0]["results"] if r["level"] == "error"]
    assert result["ruleId"] == "dof-exclusive" == prop["property"]
    assert result["message"]["text"] == prop["message"]
    steps = steps_of(result["codeFlows"][0])
    assert [(line, col) for line, col, _ in steps] == [(s["line"], s["col"])
                                                       for s in prop["counterexample"]]
    assert steps[-1][2] == ("4. Surface(): start — sends enable Surface")
    order = [loc["executionOrder"] for loc in
             result["codeFlows"][0]["threadFlows"][0]["locations"]]
    assert order == list(range(1, len(steps) + 1))


def test_a_lasso_shows_its_run_then_its_loop(tmp_path: Path) -> None:
    path = write(tmp_path, LASSO, "lasso.mcl")
    report, doc = mclc(str(path), cwd=tmp_path)
    prop = next(p for p in report["verification"]["properties"] if p["property"] == "terminates")
    assert prop["cycle"], "the lasso's loop"
    result = next(r for r in doc["runs"][0]["results"] if r["ruleId"] == "terminates")
    steps = steps_of(result["codeFlows"][0])
    expected = prop["counterexample"] + prop["cycle"]
    assert [(line, col) for line, col, _ in steps] == [(s["line"], s["col"]) for s in expected]
    loop = [text for _, _, text in steps[len(prop["counterexample"]):]]
    assert all(f"loop {i}/{len(prop['cycle'])}: " in t for i, t in enumerate(loop, 1))
    assert "then the loop" in result["codeFlows"][0]["message"]["text"]


def test_uris_are_repository_relative_or_file_uris(tmp_path: Path) -> None:
    (tmp_path / ".git").mkdir()
    (tmp_path / "sub").mkdir()
    inside = write(tmp_path / "sub", CONFLICT, "in side.mcl")
    _, doc = mclc("in side.mcl", cwd=tmp_path / "sub")
    run = doc["runs"][0]
    assert run["originalUriBaseIds"]["%SRCROOT%"]["uri"] == tmp_path.as_uri() + "/"
    where = run["results"][0]["locations"][0]["physicalLocation"]["artifactLocation"]
    assert where == {"uri": "sub/in%20side.mcl", "uriBaseId": "%SRCROOT%"}
    assert inside.exists()
    outside = formats.artifact(str(MISSIONS / "dam_inspection.mcl"), tmp_path)
    assert outside == {"uri": (MISSIONS / "dam_inspection.mcl").as_uri()}


def test_rules_have_help_and_a_link_into_the_documents(monkeypatch: pytest.MonkeyPatch,
                                                        tmp_path: Path) -> None:
    report = json.loads(cli("mclc", str(write(tmp_path, CONFLICT)), "--json").stdout)
    monkeypatch.setenv("MCL_DOCS_URI", "https://forge.example/mcl/blob/main/docs/")
    driver = json.loads(formats.sarif([report]))["runs"][0]["tool"]["driver"]
    assert driver["informationUri"] == "https://forge.example/mcl/blob/main/docs/CI.md"
    (rule,) = driver["rules"]
    assert rule["helpUri"] == ("https://forge.example/mcl/blob/main/docs/"
                               "LANGUAGE.md#what-mclc-proves")
    assert rule["shortDescription"]["text"] == rules.PROPERTIES["dof-exclusive"][0]
    assert rules.PROPERTIES["dof-exclusive"][1] in rule["help"]["markdown"]
    assert rule["defaultConfiguration"] == {"level": "error"}
    monkeypatch.delenv("MCL_DOCS_URI")
    driver = json.loads(formats.sarif([report]))["runs"][0]["tool"]["driver"]
    assert "example.invalid" not in json.dumps(driver)
    assert driver["rules"][0]["help"]["text"] == rules.PROPERTIES["dof-exclusive"][1]


def test_a_diagnostic_is_a_rule_whose_help_is_its_hint(tmp_path: Path) -> None:
    broken = write(tmp_path, "MISSION {\n  Surface();\n}\n")
    doc = json.loads(cli("mclc", str(broken), "--format", "sarif").stdout)
    (rule,) = doc["runs"][0]["tool"]["driver"]["rules"]
    assert rule["id"] == "trailing-semicolon" and rule["help"]["text"] == "delete this ';'"
    assert "codeFlows" not in doc["runs"][0]["results"][0]


def test_no_dead_transition_noise_in_sarif_and_github() -> None:
    dam = str(MISSIONS / "dam_inspection.mcl")
    report = json.loads(cli("mclc", dam, "--json").stdout)
    dead = next(p for p in report["verification"]["properties"]
                if p["property"] == "no-dead-transitions")
    assert not dead["holds"]  # the JSON keeps it: template paths the mission cannot take
    assert {p["property"] for p in report["verification"]["properties"]} == set(rules.PROPERTIES)
    doc = json.loads(formats.sarif([report]))
    assert doc["runs"][0]["results"] == [] and doc["runs"][0]["tool"]["driver"]["rules"] == []
    assert formats.github([report]) == f"{dam}: verified"


def test_every_property_of_the_language_has_a_rule() -> None:
    text = (REPO / "docs" / "LANGUAGE.md").read_text("utf-8")
    section = text.split("## What `mclc` proves", 1)[1].split("\n## ", 1)[0]
    documented = re.findall(r"^\| ([a-z-]+) \|", section, re.M)
    assert set(documented) - {"property"} == set(rules.PROPERTIES)
    page, anchor = rules.PROVES.split("#")
    headings = re.findall(r"^#+ (.+)$", (REPO / "docs" / page).read_text("utf-8"), re.M)
    assert anchor in [re.sub(r"[^a-z0-9 -]", "", h.lower()).replace(" ", "-") for h in headings]


def test_a_broken_deadline_shows_its_critical_path() -> None:
    dam = str(MISSIONS / "dam_inspection.mcl")
    args = (dam, "--no-verify", "--deadline", "45min")
    report, doc = mclc(*args)
    path = [s for s in report["duration"]["critical_path"] if s["seconds"] != 0]
    result = next(r for r in doc["runs"][0]["results"] if r["ruleId"] == "deadline")
    steps = steps_of(result["codeFlows"][0])
    assert [line for line, _, _ in steps] == [s["line"] for s in path]
    assert steps[0][2].startswith(f"1. {path[0]['task']}: {path[0]['ending']}")
