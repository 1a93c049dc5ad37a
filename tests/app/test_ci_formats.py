"""mclc's reports for CI: JUnit XML, SARIF, GitHub annotations, and several files at once."""

from __future__ import annotations

import json
import xml.etree.ElementTree as ET
from pathlib import Path

import pytest
import yaml

from tests.support import MISSIONS, REPO, cli, write

CONFLICT = "MISSION {\n  PARALLEL { GoTo((0, 0, 5, 0)) } AND { Surface() }\n}\n"
BROKEN = "MISSION {\n  Surface();\n}\n"


@pytest.mark.slow
def test_worst_status_wins(tmp_path: Path) -> None:
    good = str(MISSIONS / "dam_inspection.mcl")
    bad = str(write(tmp_path, CONFLICT, "conflict.mcl"))
    invalid = str(write(tmp_path, BROKEN, "broken.mcl"))
    assert cli("mclc", good).returncode == 0
    assert cli("mclc", good, bad).returncode == 1
    assert cli("mclc", bad, invalid, good).returncode == 2


def test_junit(tmp_path: Path) -> None:
    bad = write(tmp_path, CONFLICT, "conflict.mcl")
    invalid = write(tmp_path, BROKEN, "broken.mcl")
    proc = cli("mclc", str(MISSIONS / "dam_inspection.mcl"), str(bad), str(invalid),
               "--format", "junit")
    assert proc.returncode == 2
    root = ET.fromstring(proc.stdout)
    suites = {s.get("name"): s for s in root.iter("testsuite")}
    assert set(suites) == {str(MISSIONS / "dam_inspection.mcl"), str(bad), str(invalid)}
    assert suites[str(MISSIONS / "dam_inspection.mcl")].get("failures") == "0"
    conflict = suites[str(bad)]
    assert conflict.get("failures") == "1"
    failure = conflict.find("testcase[@name='dof-exclusive']/failure")
    assert failure is not None and "GoTo" in (failure.text or "")
    assert suites[str(invalid)].find("testcase/failure") is not None


def test_sarif(tmp_path: Path) -> None:
    bad = write(tmp_path, CONFLICT, "conflict.mcl")
    proc = cli("mclc", str(bad), "--format", "sarif")
    assert proc.returncode == 1
    doc = json.loads(proc.stdout)
    assert doc["version"] == "2.1.0"
    results = doc["runs"][0]["results"]
    errors = [r for r in results if r["level"] == "error"]
    assert [r["ruleId"] for r in errors] == ["dof-exclusive"]
    region = errors[0]["locations"][0]["physicalLocation"]["region"]
    assert region["startLine"] == 2 and region["startColumn"] > 1
    assert {r["id"] for r in doc["runs"][0]["tool"]["driver"]["rules"]} >= {"dof-exclusive"}


def test_github_annotations(tmp_path: Path) -> None:
    invalid = write(tmp_path, BROKEN, "broken.mcl")
    proc = cli("mclc", str(invalid), "--format", "github")
    assert proc.returncode == 2
    first = proc.stdout.splitlines()[0]
    assert first.startswith(f"::error file={invalid},line=2,col=12,title=mclc trailing-semicolon::")


def test_pre_commit_hook_definition() -> None:
    hooks = yaml.safe_load((REPO / ".pre-commit-hooks.yaml").read_text())
    hook = next(h for h in hooks if h["id"] == "mclc")
    assert hook["entry"] == "mclc" and hook["language"] == "python"
    assert hook["files"] == r"\.mcl$"
