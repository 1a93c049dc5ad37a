"""Golden tests for every mission in missions/, the round trip parse -> print -> parse, and
the real ``mclc`` on them.

The golden files (tests/golden/NAME.json) pin what each mission compiles to and what the
verifier finds. After an intended change, regenerate them with
``MCL_UPDATE_GOLDEN=1 make test`` and review the diff.
"""

from __future__ import annotations

import json
import os
from pathlib import Path

import pytest

from mcl import ast, parser, printer
from mcl.api import compile_file
from diagnostics import Source
from mcl.analysis.verification import verify_mission
from tests.support import MISSIONS, cli, single_missions

GOLDEN = Path(__file__).parents[1] / "golden"
FILES = single_missions()


def _summary(path: Path) -> dict[str, object]:
    compiled = compile_file(str(path))
    net = compiled.net
    verdict = verify_mission(compiled, "explicit")
    return {
        "mission": compiled.mission.name,
        "calls": [f"{c.name}@{c.span.line}:{c.span.col}" for c in compiled.mission.calls()],
        "places": len(net.places),
        "transitions": len(net.transitions),
        "arcs": net.arc_count(),
        "events": sorted({t.event for t in net.transitions if t.event}),
        "timers": sorted({str(t.timer) for t in net.transitions if t.timer is not None}),
        "actions": sorted({str(a) for t in net.transitions for a in t.actions}),
        "unset_parameters": compiled.checked.unset,
        "verified": verdict.ok,
        "reachable_markings": verdict.markings,
        "reachability_arcs": verdict.arcs,
        "properties": {r.name: r.holds for r in verdict.results},
    }


def test_there_are_the_four_missions() -> None:
    names = {p.stem for p in FILES}
    assert {"dam_inspection", "pipeline_inspection", "cable_tracking",
            "every_construct"} <= names


@pytest.mark.parametrize("path", FILES, ids=[p.stem for p in FILES])
def test_golden(path: Path) -> None:
    got = _summary(path)
    golden = GOLDEN / f"{path.stem}.json"
    if os.environ.get("MCL_UPDATE_GOLDEN") or not golden.exists():
        golden.write_text(json.dumps(got, indent=1, ensure_ascii=False) + "\n", "utf-8")
        if not os.environ.get("MCL_UPDATE_GOLDEN"):
            pytest.fail(f"{golden} did not exist; written now: review and commit it")
    assert got == json.loads(golden.read_text("utf-8"))


@pytest.mark.parametrize("path", FILES, ids=[p.stem for p in FILES])
def test_round_trip(path: Path) -> None:
    first = parser.parse(Source(str(path), path.read_text("utf-8")))
    text = printer.mission(first)
    second = parser.parse(Source("printed.mcl", text))
    assert second == first
    assert printer.mission(second) == text


def test_dam_mission_is_algorithm_1_of_the_paper() -> None:
    """docs/DESIGN.md §1: the paper's mission, as written, with its parameters."""
    m = parser.parse_file(str(MISSIONS / "dam_inspection.mcl"))
    assert [c.name for c in ast.calls(m.body)] == [
        "StartLogs", "GoTo", "AchieveHeadDist", "KeepHeadDist", "StartCamera", "WallInspect",
        "StartCamera", "KeepHeadDistException", "Surface", "KeepHeadDist", "GoTo", "Alarms",
        "Surface", "StartLogs"]
    assert isinstance(m.body, ast.Sequence) and len(m.body.items) == 3
    outer = m.body.items[1]
    assert isinstance(outer, ast.TryCatchDo)
    assert isinstance(outer.try_, ast.Sequence) and len(outer.try_.items) == 6
    assert isinstance(outer.try_.items[3], ast.TryCatchDo)
    assert {p.name for p in m.params} == {"initialPos", "h", "d", "path", "recoveryPos"}


def test_the_algorithm_as_printed_in_MCL_md_compiles_with_warnings(tmp_path: Path) -> None:
    """Without PARAM values, only warnings (docs/DESIGN.md §1: a warning when only checking)."""
    text = (MISSIONS / "dam_inspection.mcl").read_text("utf-8")
    body = text[text.index("MISSION"):]
    path = tmp_path / "algorithm1.mcl"
    path.write_text(body, "utf-8")
    proc = cli("mclc", str(path), "--no-verify")
    assert proc.returncode == 0, proc.stderr
    for name in ("initialPos", "h", "d", "path", "recoveryPos"):
        assert f"warning: parameter '{name}' has no value" in proc.stderr


@pytest.mark.slow
def test_mclc_on_every_mission_at_once() -> None:
    proc = cli("mclc", *map(str, FILES))
    assert proc.returncode == 0, proc.stdout + proc.stderr
    for path in FILES:
        assert f"{path}: mission" in proc.stdout
    assert proc.stdout.count("  verified:") == len(FILES)


def test_mclc_json_summary() -> None:
    proc = cli("mclc", str(MISSIONS / "dam_inspection.mcl"), "--json")
    assert proc.returncode == 0, proc.stderr
    report = json.loads(proc.stdout)
    assert report["tasks"] == 15  # 14 in the body, Surface() in ON STOP
    assert report["status"] == "verified"
    assert report["places"] > 0 and report["transitions"] > 0
    assert {p["property"] for p in report["verification"]["properties"]} >= {
        "one-safe", "no-deadlock", "terminates", "proper-completion",
        "behaviours-off-at-end", "dof-exclusive", "no-dead-transitions"}


def test_dot_views(tmp_path: Path) -> None:
    full, tasks = tmp_path / "full.dot", tmp_path / "tasks.dot"
    proc = cli("mclc", str(MISSIONS / "dam_inspection.mcl"), "--dot", str(full),
               "--dot-tasks", str(tasks), "--no-verify")
    assert proc.returncode == 0, proc.stderr
    full_text, task_text = full.read_text(), tasks.read_text()
    assert full_text.startswith("digraph") and task_text.startswith("digraph")
    # the task view has one grey node per task call, the full view none
    assert task_text.count('fillcolor="#bbbbbb"') == 14
    assert 'fillcolor="#bbbbbb"' not in full_text
    assert full_text.count("shape=box") > task_text.count("shape=box")
