"""The language server's parts in-process: the document analysis, what stands at a place,
hover, definition, rename, completion, symbols and the diagnostics' places."""

from __future__ import annotations

from pathlib import Path

import pytest

pytest.importorskip("pygls")
from lsprotocol import types

from app.lsp import hover, navigation, outline
from app.lsp.diagnostics import from_mcl, from_verification, word_range
from app.lsp.document import analyse, shipped_path
from app.lsp.locate import at, inside
from app.lsp.server import code_actions, formatting, inlay_hints
from diagnostics import Source, Span
from mcl.analysis.verification import verify_mission
from mcl.api import compile_source
from mcl.tasks_formatter import format_library_text

ROOT = Path(__file__).resolve().parents[3]
DAM = ROOT / "missions" / "dam_inspection.mcl"
TEXT = DAM.read_text("utf-8")
LINES = TEXT.split("\n")


def place(needle: str, offset: int = 0) -> tuple[int, int]:
    """1-based line and column of the first ``needle`` (plus ``offset``)."""
    number = next(i for i, line in enumerate(LINES, 1) if needle in line)
    return number, LINES[number - 1].index(needle) + 1 + offset


def test_the_dam_mission_is_checked_and_keeps_every_stage() -> None:
    doc = analyse(str(DAM), TEXT, 3)
    assert doc.ok and doc.version == 3 and doc.diagnostics == []
    assert doc.mission is not None and doc.library is not None and doc.checked is not None


def test_a_rejected_mission_keeps_its_tree_and_libraries() -> None:
    doc = analyse(str(DAM), TEXT.replace("GoTo(recoveryPos)", "GoTo(recoveryPos, 3 s)"))
    assert not doc.ok and doc.checked is None
    assert doc.mission is not None and doc.library is not None
    assert [d.severity for d in doc.diagnostics][0] == "error"
    assert doc.diagnostics[0].span is not None
    assert doc.diagnostics[0].span.line == place("GoTo(recoveryPos)")[0]


def test_a_parse_error_has_no_tree_and_one_place() -> None:
    doc = analyse("x.mcl", "MISSION { GoTo(a) ")
    assert doc.mission is None and len(doc.diagnostics) == 1
    [d] = [from_mcl(doc.source, x) for x in doc.diagnostics]
    assert d.severity == types.DiagnosticSeverity.Error and d.range.start.line == 0


def test_a_missing_library_is_an_error_at_its_uses(tmp_path: Path) -> None:
    doc = analyse(str(tmp_path / "m.mcl"), 'USES "nowhere.tasks";\nMISSION { Surface() }')
    [d] = doc.diagnostics
    assert d.code == "missing-library" and d.span is not None and d.span.line == 1


@pytest.mark.parametrize("span, line, col, inner", [
    (Span("f", 2, 5, 2, 9), 2, 5, True), (Span("f", 2, 5, 2, 9), 2, 9, True),
    (Span("f", 2, 5, 2, 9), 2, 10, False), (Span("f", 2, 5, 2, 9), 1, 6, False),
    (Span("f", 2, 5, 4, 2), 3, 1, True), (Span("f", 2, 5), 2, 40, True),
    (Span("f", 2, 5), 3, 1, False)])
def test_inside(span: Span, line: int, col: int, inner: bool) -> None:
    assert inside(span, line, col) is inner


def test_what_stands_at_each_place() -> None:
    doc = analyse(str(DAM), TEXT)
    assert doc.mission is not None
    kinds = {needle: at(doc.mission, *place(needle, offset))
             for needle, offset in [("GoTo(initialPos)", 1), ("GoTo(initialPos)", 6),
                                    ("PARAM h ", 6), ("TRY {", 0), ("// The dam", 0)]}
    found = {k: (v.kind, v.name) if v else None for k, v in kinds.items()}
    assert found["GoTo(initialPos)"] == ("param", "initialPos")  # the last offset wins
    assert found["PARAM h "] == ("param", "h")
    assert found["TRY {"] == ("block", "TryCatchDo")
    assert found["// The dam"] is None
    call = at(doc.mission, *place("GoTo(initialPos)", 1))
    assert call is not None and (call.kind, call.name) == ("call", "GoTo")


def test_hover_texts() -> None:
    doc = analyse(str(DAM), TEXT)
    assert doc.mission is not None

    def text(needle: str, offset: int = 0) -> str:
        found = at(doc.mission, *place(needle, offset))  # type: ignore[arg-type]
        assert found is not None
        shown = hover.hover(doc, found)
        assert shown is not None
        return shown

    keep = text("KeepHeadDist(enable")
    assert "KeepHeadDist(enable, heading: angle" in keep
    assert "latches AchieveHeadDist on" in keep and "drives x, yaw" in keep
    assert "KeepHeadDist(disable)" not in keep  # the form this call resolved to, only
    assert "PARAM d = 1.5 m\n```\nlength" == text("PARAM d ", 6).removeprefix("```mcl\n")
    surface = text("Surface()")
    assert "proved duration: [" in surface and "events surfaced" in surface


def test_definition_and_rename() -> None:
    doc = analyse(str(DAM), TEXT)
    assert doc.mission is not None
    found = at(doc.mission, *place("WallInspect("))
    assert found is not None
    where = navigation.definition(doc, found)
    assert where is not None and where.uri.endswith("/mcl/tasks/ictineu.tasks")
    tasks = Path(shipped_path("<mcl>/tasks/ictineu.tasks") or "").read_text("utf-8")
    assert tasks.split("\n")[where.range.start.line].startswith("task WallInspect(")
    found = at(doc.mission, *place("PARAM h ", 6))
    assert found is not None
    edit = navigation.rename(doc, found, "heading", "file:///dam.mcl")
    assert edit is not None and edit.changes is not None
    lines = sorted(e.range.start.line + 1 for e in edit.changes["file:///dam.mcl"])
    assert lines == [place("PARAM h ")[0], place("AchieveHeadDist(h")[0],
                     place("KeepHeadDist(enable, h")[0]]
    with pytest.raises(ValueError):
        navigation.rename(doc, found, "not a name", "file:///dam.mcl")


def test_completion_and_symbols_of_a_mission_with_a_stop_handler() -> None:
    doc = analyse(str(DAM), TEXT)
    labels = [i.label for i in outline.completion(doc)]
    assert labels.count("KeepHeadDist") == 2  # both call forms
    assert {"Wait", "GoTo", "recoveryPos", "WHILE", "min"} <= set(labels)
    symbols = outline.symbols(doc)
    assert [s.name for s in symbols][-2:] == ["MISSION", "ON STOP"]
    stop = symbols[-1]
    assert [c.name for c in stop.children or []] == ["Surface()"]
    for s in symbols:  # a symbol's selection lies within its range (the protocol's rule)
        assert (s.range.start.line, s.range.start.character) <= (
            s.selection_range.start.line, s.selection_range.start.character)


def test_code_action_for_a_misspelt_task() -> None:
    doc = analyse(str(DAM), TEXT.replace("StartCamera(enable)", "StartCamra(enable)"))
    [fix] = code_actions(doc, "file:///dam.mcl")
    assert fix.edit is not None and fix.edit.changes is not None
    [edit] = fix.edit.changes["file:///dam.mcl"]
    line, col = place("StartCamera(enable)")
    assert edit.new_text == "StartCamera"
    assert (edit.range.start.line + 1, edit.range.start.character + 1) == (line, col)
    assert edit.range.end.character - edit.range.start.character == len("StartCamra")


def test_inlay_hints_bound_each_construct() -> None:
    doc = analyse(str(DAM), TEXT)
    hints = inlay_hints(doc)
    assert sorted(h.position.line + 1 for h in hints) == [
        place("    TRY {")[0], place("        TRY {")[0]]
    assert all("s" in str(h.label) for h in hints)


def test_word_range() -> None:
    src = Source("f", "MISSION {\n    GoTo(abc)\n}")
    assert word_range(src, 2, 5) == types.Range(types.Position(1, 4), types.Position(1, 8))
    assert word_range(src, 2, 9) == types.Range(types.Position(1, 8), types.Position(1, 9))
    assert word_range(src, 0, 0).end == types.Position(0, 0)


def test_a_failed_property_is_at_the_call_that_caused_it() -> None:
    text = ("PARAM a = (0, 0, 1, 0 deg);\nMISSION {\n    PARALLEL {\n        GoTo(a)\n"
            "    } AND {\n        GoTo(a)\n    }\n}\n")
    doc = analyse("clash.mcl", text)
    verdict = verify_mission(compile_source(doc.source)).to_json()
    found = from_verification(doc.source, verdict)
    assert found and {d.range.start.line + 1 for d in found} <= {4, 6}
    for d in found:
        assert d.related_information and d.related_information[0].message.startswith("1. ")


def test_a_task_library_is_loaded_not_parsed_as_a_mission() -> None:
    seabed = ROOT / "missions" / "seabed.tasks"
    text = seabed.read_text("utf-8")
    doc = analyse(str(seabed), text)
    assert doc.diagnostics == [] and doc.mission is None and doc.library is not None
    assert "KeepAltitude" in doc.library.behaviours and not doc.ok
    broken = analyse(str(seabed), text.replace("behaviour KeepAltitude", "behaviour KeepAltitude\n  drives q"))
    [d] = broken.diagnostics
    assert d.severity == "error" and d.span is not None and d.span.file == str(seabed)
    assert d.span.line > 1


def test_a_bug_of_ours_is_one_diagnostic_not_a_dead_server(
        monkeypatch: pytest.MonkeyPatch) -> None:
    def broken(source: Source) -> None:
        raise ZeroDivisionError("division by zero")

    monkeypatch.setattr("mcl.parser.parse", broken)
    [d] = analyse(str(DAM), TEXT).diagnostics
    assert d.code == "internal-error" and "ZeroDivisionError" in d.message


def test_formatting_lays_out_a_task_library_too(tmp_path: Path) -> None:
    # issue 26: a .tasks document is formatted by mcl fmt's library layout; one that does not
    # parse is left alone (its error is the diagnostic)
    text = "behaviour Go drives x events done;\ntask Go() {ok:Go.done;  // done\n}\n"
    [edit] = formatting(analyse(str(tmp_path / "lib.tasks"), text))
    assert edit.new_text == format_library_text(text) != text
    assert edit.new_text.endswith("    ok:      Go.done;  // done\n}\n")
    assert formatting(analyse(str(tmp_path / "lib.tasks"), "task Go( {\n")) == []
