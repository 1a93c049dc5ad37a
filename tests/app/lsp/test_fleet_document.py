"""The language server on a fleet file: every vehicle checked, its errors and warnings as
diagnostics at their places; the reading features answer without a crash; formatting gives
mcl fmt's layout. Fleets are not proved in the editor (mclc proves them)."""

from __future__ import annotations

from pathlib import Path

import pytest

pytest.importorskip("pygls")
from lsprotocol import types

from app.lsp import outline
from app.lsp.diagnostics import from_mcl
from app.lsp.document import analyse
from app.lsp.server import code_actions, formatting, inlay_hints

ROOT = Path(__file__).resolve().parents[3]
RELAY = ROOT / "missions" / "fleet_relay.mcl"
TEXT = RELAY.read_text("utf-8")


def test_the_shipped_fleet_is_checked_without_a_diagnostic() -> None:
    doc = analyse(str(RELAY), TEXT, 1)
    assert doc.fleet is not None and doc.fleet.name == "relay"
    assert doc.diagnostics == [] and not doc.ok  # not proved in the editor


def test_a_fleet_error_is_a_diagnostic_at_its_place() -> None:
    text = TEXT.replace("timeout = 3 min", "timeout = 3 min, within = 1 s")
    doc = analyse(str(RELAY), text)
    [d] = doc.diagnostics
    assert d.code == "fleet-bad-arguments" and d.span is not None
    lsp = from_mcl(doc.source, d)
    assert lsp.severity == types.DiagnosticSeverity.Error
    assert lsp.range.start.line == d.span.line - 1
    assert "within" in text.split("\n")[lsp.range.start.line]


def test_a_vehicle_warning_is_a_diagnostic_too() -> None:
    text = TEXT.replace("PARAM postPos", "PARAM unused = 1 m;\n        PARAM postPos")
    [d] = analyse(str(RELAY), text).diagnostics
    assert (d.severity, d.code) == ("warning", "unused-param")


def test_the_reading_features_answer_on_a_fleet() -> None:
    doc = analyse(str(RELAY), TEXT.replace("    VEHICLE leader", "VEHICLE leader"))
    assert outline.symbols(doc) == []  # no outline of a fleet yet
    assert isinstance(outline.completion(doc), list)
    assert code_actions(doc, RELAY.as_uri()) == []
    assert inlay_hints(doc) == []
    [edit] = formatting(doc)
    assert edit.new_text == TEXT  # mcl fmt's layout
    assert formatting(analyse(str(RELAY), TEXT)) == []  # already laid out
