"""``mcl lsp`` end to end: a real server process driven by pytest-lsp's client over stdio.

The server's diagnostics for each shipped mission are mclc's (``mclc --json`` run beside it,
located by app/reports/formats.py as every report of mclc is); a broken mission shows its
parse error at its line; a failing proof shows at the line mclc gives, its counterexample
steps as related information at their MCL lines; hover, definition, completion, symbols,
rename, code actions and inlay hints on the dam mission.
"""

from __future__ import annotations

import asyncio
import json
import subprocess
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import pytest

pytest_lsp = pytest.importorskip("pytest_lsp")
from lsprotocol import types
from pygls import uris
from pytest_lsp import ClientServerConfig, LanguageClient, client_capabilities

from app.lsp.diagnostics import NOT_ACTIONABLE
from app.lsp.server import PROVED
from app.reports.formats import problems
from tests.support import single_missions

ROOT = Path(__file__).resolve().parents[3]
MISSIONS = single_missions()
DAM = ROOT / "missions" / "dam_inspection.mcl"
SEVERITY = {types.DiagnosticSeverity.Error: "error", types.DiagnosticSeverity.Warning: "warning"}
CLASH = """PARAM a = (0, 0, 1, 0 deg);
PARAM b = (5, 0, 1, 0 deg);

MISSION {
    PARALLEL {
        GoTo(a)
    } AND {
        GoTo(b)
    }
}
"""


@pytest_lsp.fixture(config=ClientServerConfig(  # type: ignore[untyped-decorator]
    server_command=[sys.executable, "-m", "app.mcl", "lsp", "--proof-delay", "0"]))
async def client(lsp_client: LanguageClient) -> Any:
    await lsp_client.initialize_session(types.InitializeParams(
        capabilities=client_capabilities("visual-studio-code"),
        root_uri=uris.from_fs_path(str(ROOT))))
    yield
    await lsp_client.shutdown_session()


async def open_and_prove(client: LanguageClient, path: Path, text: str | None = None,
                         version: int = 1) -> Sequence[types.Diagnostic]:
    """Open a mission and wait for its proof's diagnostics."""
    uri = uris.from_fs_path(str(path))
    assert uri is not None
    proved = asyncio.wrap_future(client.protocol.wait_for_notification(PROVED))
    client.text_document_did_open(types.DidOpenTextDocumentParams(types.TextDocumentItem(
        uri, "mcl", version, path.read_text("utf-8") if text is None else text)))
    await asyncio.wait_for(proved, 120)
    return client.diagnostics[uri]


def mclc(path: Path) -> dict[str, Any]:
    run = subprocess.run([sys.executable, "-m", "app.mclc", "--json", str(path)],
                         capture_output=True, text=True, timeout=300)
    report: dict[str, Any] = json.loads(run.stdout)
    return report


def expected(report: dict[str, Any]) -> list[tuple[str, int, int, str]]:
    """What mclc's reports say of a file: (rule, line, col, level), the rules an author
    cannot act on left out."""
    return sorted((p["rule"], p["line"], p["col"], p["level"]) for p in problems(report)
                  if p["rule"] not in NOT_ACTIONABLE)


def shown(found: Sequence[types.Diagnostic]) -> list[tuple[str, int, int, str]]:
    return sorted((str(d.code), d.range.start.line + 1, d.range.start.character + 1,
                   SEVERITY[d.severity or types.DiagnosticSeverity.Error]) for d in found)


def position(path: Path, needle: str, offset: int = 0) -> types.Position:
    """The 0-based place of the first ``needle`` in a file (plus ``offset`` characters)."""
    for number, line in enumerate(path.read_text("utf-8").split("\n")):
        if needle in line:
            return types.Position(number, line.index(needle) + offset)
    raise AssertionError(f"{needle!r} not in {path}")


@pytest.mark.asyncio
@pytest.mark.parametrize("mission", MISSIONS, ids=lambda p: p.stem)
async def test_diagnostics_are_mclcs(client: LanguageClient, mission: Path) -> None:
    found = await open_and_prove(client, mission)
    assert shown(found) == expected(mclc(mission))


@pytest.mark.asyncio
async def test_failed_proof_at_mclcs_line_with_its_counterexample(
        client: LanguageClient, tmp_path: Path) -> None:
    path = tmp_path / "clash.mcl"
    path.write_text(CLASH, encoding="utf-8")
    found = await open_and_prove(client, path)
    report = mclc(path)
    assert shown(found) == expected(report)
    assert found, "two GoTo at once must fail a proof"
    by_rule = {str(d.code): d for d in found}
    for p in report["verification"]["properties"]:
        if p["holds"] or p["property"] in NOT_ACTIONABLE:
            continue
        steps = p["counterexample"] + (p.get("cycle") or [])
        related = by_rule[p["property"]].related_information or []
        assert [(r.location.range.start.line + 1, r.location.range.start.character + 1)
                for r in related] == [(s["line"], s["col"]) for s in steps]
        assert all(r.location.uri == uris.from_fs_path(str(path)) for r in related)
    lines = {d.range.start.line + 1 for d in found}
    assert lines <= {6, 8}, "at the GoTo that turned the behaviour on, not at MISSION"


@pytest.mark.asyncio
async def test_parse_error_at_its_line(client: LanguageClient, tmp_path: Path) -> None:
    path = tmp_path / "broken.mcl"
    text = DAM.read_text("utf-8").replace("GoTo(recoveryPos)", "GoTo(recoveryPos);")
    path.write_text(text, encoding="utf-8")
    uri = uris.from_fs_path(str(path))
    assert uri is not None
    client.text_document_did_open(types.DidOpenTextDocumentParams(
        types.TextDocumentItem(uri, "mcl", 1, text)))
    await client.wait_for_notification(types.TEXT_DOCUMENT_PUBLISH_DIAGNOSTICS)
    [error] = client.diagnostics[uri]
    line = position(path, "GoTo(recoveryPos);").line
    assert (error.code, error.range.start.line) == ("trailing-semicolon", line)
    assert error.severity == types.DiagnosticSeverity.Error
    actions = await client.text_document_code_action_async(types.CodeActionParams(
        types.TextDocumentIdentifier(uri), error.range, types.CodeActionContext([error])))
    assert actions is not None
    [fix] = [a for a in actions if isinstance(a, types.CodeAction)]
    assert fix.edit is not None and fix.edit.changes is not None
    [edit] = fix.edit.changes[uri]
    assert edit.new_text == "" and edit.range.start.line == line
    assert text.split("\n")[line][edit.range.start.character] == ";"


@pytest.mark.asyncio
async def test_a_change_is_checked_at_once(client: LanguageClient, tmp_path: Path) -> None:
    path = tmp_path / "typo.mcl"
    path.write_text(CLASH, encoding="utf-8")
    await open_and_prove(client, path)
    uri = uris.from_fs_path(str(path))
    assert uri is not None
    client.text_document_did_change(types.DidChangeTextDocumentParams(
        types.VersionedTextDocumentIdentifier(version=2, uri=uri),
        [types.TextDocumentContentChangeWholeDocument(CLASH.replace("GoTo(b)", "GoTu(b)"))]))
    await client.wait_for_notification(types.TEXT_DOCUMENT_PUBLISH_DIAGNOSTICS)
    [error] = [d for d in client.diagnostics[uri]
               if d.severity == types.DiagnosticSeverity.Error]
    assert error.range.start.line == 7 and "GoTu" in error.message
    assert "did you mean GoTo?" in error.message


async def dam(client: LanguageClient) -> str:
    await open_and_prove(client, DAM)
    uri = uris.from_fs_path(str(DAM))
    assert uri is not None
    return str(uri)


@pytest.mark.asyncio
async def test_hover_on_the_dam_mission(client: LanguageClient) -> None:
    uri = await dam(client)

    async def text_at(needle: str, offset: int = 0) -> str:
        found = await client.text_document_hover_async(types.HoverParams(
            types.TextDocumentIdentifier(uri), position(DAM, needle, offset)))
        assert found is not None and isinstance(found.contents, types.MarkupContent)
        return found.contents.value

    goto = await text_at("GoTo(initialPos)")
    assert "GoTo(target: point" in goto and "drives x, y, z, yaw" in goto
    assert "events reached, failed" in goto and "120 W" in goto
    assert "timeout 10 min → fail" in goto and "ictineu.tasks" in goto
    assert "h" in (await text_at("AchieveHeadDist(h", len("AchieveHeadDist(")))
    assert "PARAM d = 1.5 m" in (await text_at("AchieveHeadDist(h, d", len("AchieveHeadDist(h, ")))
    assert "proved duration: [" in (await text_at("TRY {"))


@pytest.mark.asyncio
async def test_definition_on_the_dam_mission(client: LanguageClient) -> None:
    uri = await dam(client)

    async def goto(needle: str, offset: int = 0) -> types.Location:
        found = await client.text_document_definition_async(types.DefinitionParams(
            types.TextDocumentIdentifier(uri), position(DAM, needle, offset)))
        assert isinstance(found, types.Location)
        return found

    task = await goto("KeepHeadDist(enable")
    tasks = Path(uris.to_fs_path(task.uri) or "")
    assert tasks.name == "ictineu.tasks"
    declared = tasks.read_text("utf-8").split("\n")[task.range.start.line]
    assert declared.startswith("task KeepHeadDist(enable")
    param = await goto("GoTo(recoveryPos", len("GoTo("))
    assert param.uri == uri and param.range.start == position(DAM, "recoveryPos =")


@pytest.mark.asyncio
async def test_completion_symbols_rename_and_hints(client: LanguageClient) -> None:
    uri = await dam(client)
    doc = types.TextDocumentIdentifier(uri)
    listed = await client.text_document_completion_async(types.CompletionParams(
        doc, position(DAM, "Surface()")))
    assert isinstance(listed, types.CompletionList)
    labels = {i.label: i for i in listed.items}
    assert {"GoTo", "WallInspect", "initialPos", "path", "PARALLEL", "deg", "m"} <= set(labels)
    assert "target: point" in (labels["GoTo"].detail or "")
    symbols = await client.text_document_document_symbol_async(types.DocumentSymbolParams(doc))
    assert symbols is not None
    names = [s.name for s in symbols]
    assert names[:5] == ["initialPos", "h", "d", "recoveryPos", "path"]
    assert names[5:] == ["MISSION", "ON STOP"]
    mission = symbols[5]
    assert isinstance(mission, types.DocumentSymbol) and mission.children
    assert [c.name for c in mission.children] == ["StartLogs(enable)", "TRY … CATCH … DO",
                                                   "StartLogs(disable)"]
    edit = await client.text_document_rename_async(types.RenameParams(
        doc, position(DAM, "PARAM d ", len("PARAM ")), "distance"))
    assert edit is not None and edit.changes is not None
    assert sorted(e.range.start.line + 1 for e in edit.changes[uri]) == [12, 35, 36]
    hints = await client.text_document_inlay_hint_async(types.InlayHintParams(
        doc, types.Range(types.Position(0, 0), types.Position(60, 0))))
    assert hints and all(str(h.label).strip().startswith("[") for h in hints)


@pytest_lsp.fixture(config=ClientServerConfig(  # type: ignore[untyped-decorator]
    server_command=[sys.executable, "-m", "app.mcl", "lsp", "--proof-delay", "0",
                    "--vehicle", "ictineu"]))
async def ictineu_client(lsp_client: LanguageClient) -> Any:
    await lsp_client.initialize_session(types.InitializeParams(
        capabilities=client_capabilities("visual-studio-code"),
        root_uri=uris.from_fs_path(str(ROOT))))
    yield
    await lsp_client.shutdown_session()


@pytest.mark.asyncio
async def test_what_the_vehicle_lacks_at_each_call(ictineu_client: LanguageClient) -> None:
    seabed = ROOT / "missions" / "pipeline_inspection.mcl"
    found = await open_and_prove(ictineu_client, seabed)
    lacking = [d for d in found if d.code == "vehicle-lacks-behaviour"]
    assert lacking and all(d.severity == types.DiagnosticSeverity.Error for d in lacking)
    calls = {(c["line"], c["col"]) for c in mclc(seabed)["task_calls"]}
    assert {(d.range.start.line + 1, d.range.start.character + 1) for d in lacking} <= calls
    assert any("KeepAltitude" in d.message for d in lacking)


@pytest.mark.asyncio
async def test_formatting_is_mcl_fmts_layout(client: LanguageClient, tmp_path: Path) -> None:
    # issue 26: the server's formatting uses mcl fmt (mcl/formatter.py), comments kept
    path = tmp_path / "messy.mcl"
    text = "// a note\nMISSION m {GoTo((0,0,1,0 deg));   // down\n  Surface()} ON STOP {Surface()}\n"
    path.write_text(text, "utf-8")
    uri = uris.from_fs_path(str(path))
    assert uri is not None
    client.text_document_did_open(types.DidOpenTextDocumentParams(types.TextDocumentItem(
        uri, "mcl", 1, text)))
    edits = await client.text_document_formatting_async(types.DocumentFormattingParams(
        types.TextDocumentIdentifier(uri), types.FormattingOptions(4, True)))
    assert edits is not None and len(edits) == 1
    formatted = edits[0].new_text
    done = subprocess.run([sys.executable, "-m", "app.mcl", "fmt", "-"], input=text,
                          capture_output=True, text=True, timeout=60)
    assert done.returncode == 0, done.stderr
    assert formatted == done.stdout != text
    assert "// a note" in formatted and "// down" in formatted
