"""The language server on a fleet file: every vehicle checked, its errors and warnings as
diagnostics at their places; the reading features answer without a crash; formatting gives
mcl fmt's layout. A fleet's proofs: test_fleet_proofs.py."""

from __future__ import annotations

from pathlib import Path

import pytest

pytest.importorskip("pygls")
from lsprotocol import types

from app.lsp import hover, outline
from app.lsp.diagnostics import from_mcl
from app.lsp.document import analyse
from app.lsp.locate import at
from app.lsp.server import code_actions, formatting, inlay_hints

ROOT = Path(__file__).resolve().parents[3]
RELAY = ROOT / "missions" / "fleet_relay.mcl"
TEXT = RELAY.read_text("utf-8")


def test_the_shipped_fleet_is_checked_without_a_diagnostic() -> None:
    doc = analyse(str(RELAY), TEXT, 1)
    assert doc.fleet is not None and doc.fleet.name == "relay"
    assert doc.diagnostics == [] and not doc.ok  # ok: a single mission; a fleet is provable


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
    [fleet] = outline.symbols(doc)
    assert fleet.name == "FLEET relay"
    assert [k.name for k in fleet.children or []] == ["CHANNEL orders", "VEHICLE leader",
                                                      "VEHICLE follower"]
    follower = (fleet.children or [])[2]
    assert [k.name for k in follower.children or []][-2:] == ["MISSION follow", "ON STOP"]
    labels = {item.label for item in outline.completion(doc)}
    assert {"Send", "Receive", "orders", "start", "abort", "LOSSY", "CHANNEL"} <= labels
    assert code_actions(doc, RELAY.as_uri()) == []
    assert inlay_hints(doc) == []
    [edit] = formatting(doc)
    assert edit.new_text == TEXT  # mcl fmt's layout
    assert formatting(analyse(str(RELAY), TEXT)) == []  # already laid out


def _place(needle: str) -> tuple[int, int]:
    lines = TEXT.split("\n")
    number = next(i for i, line in enumerate(lines, 1) if needle in line)
    return number, lines[number - 1].index(needle) + 1


@pytest.mark.parametrize(("needle", "shown"), [
    ("Send(orders, start)", "puts **start** on channel **orders**"),
    ("Receive(orders, start", "ok when **orders.start** comes"),
    ("GoTo(postPos)", "behaviour **GoTo**"),
    ("postPos);", "PARAM postPos = (-5, 0, 1, 0 deg)"),
])
def test_hover_in_a_vehicle_reads_that_vehicles_mission(needle: str, shown: str) -> None:
    doc = analyse(str(RELAY), TEXT)
    line, col = _place(needle)
    vehicle = doc.vehicle_at(line, col)
    assert vehicle is not None and vehicle.mission is not None
    found = at(vehicle.mission, line, col)
    assert found is not None
    text = hover.hover(vehicle, found)
    assert text is not None and shown in text, text


def test_outside_every_vehicle_there_is_no_vehicle() -> None:
    doc = analyse(str(RELAY), TEXT)
    assert doc.vehicle_at(*_place("CHANNEL orders")) is None
    assert doc.vehicle_at(*_place("VEHICLE leader")) is doc.vehicles["leader"]
