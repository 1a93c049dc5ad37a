"""The proofs of a fleet in the editor: each vehicle's properties and the fleet's own, at the
places mclc's reports give them, with the counterexample's steps of both vehicles (and of the
channel) interleaved as related information; within the editor's budget of joint markings;
a fleet's Send and Receive are the channel's, not the vehicle's, when ``--vehicle`` is
checked."""

from __future__ import annotations

from pathlib import Path

import pytest

pytest.importorskip("pygls")
from lsprotocol import types

from app.lsp.document import analyse
from app.lsp.proofs import prove
from app.lsp.server import proved
from tests.mcl.analysis.fleet_missions import (ASV_ALWAYS_SENDS, UUV_NO_SURFACING, UUV_WAITS,
                                               fleet_text)

ROOT = Path(__file__).resolve().parents[3]
RELAY = ROOT / "missions" / "fleet_relay.mcl"


def shown(path: str, text: str) -> list[types.Diagnostic]:
    """The proof's diagnostics of a fleet, as the server publishes them."""
    doc = analyse(path, text, 1)
    assert doc.provable and doc.diagnostics == []
    return proved(doc, prove(path, text))


def place(text: str, needle: str) -> tuple[int, int]:
    """1-based line and column of the first ``needle``."""
    before = text[:text.index(needle)]
    return before.count("\n") + 1, len(before) - before.rfind("\n")


def steps(d: types.Diagnostic) -> list[tuple[int, int, str]]:
    return [(r.location.range.start.line + 1, r.location.range.start.character + 1, r.message)
            for r in d.related_information or []]


def test_the_shipped_fleet_is_proved_without_a_diagnostic() -> None:
    text = RELAY.read_text("utf-8")
    outcome = prove(str(RELAY), text)
    assert outcome.kind == "verified" and set(outcome.vehicles) == {"leader", "follower"}
    assert outcome.fleet is not None and outcome.fleet["verified"]
    assert outcome.fleet["reachable_markings"] > 1000  # the product, explored
    assert shown(str(RELAY), text) == []


def test_a_follower_that_loses_its_surfacing_fails_at_both_vehicles_lines(
        tmp_path: Path) -> None:
    text = fleet_text(uuv=UUV_NO_SURFACING)
    path = tmp_path / "mcm.mcl"
    found = {str(d.code): d for d in shown(str(path), text)}
    silence = found["fleet-silence"]
    assert silence.severity == types.DiagnosticSeverity.Error
    assert silence.message.startswith("fleet mcm: ") and "AchieveHeadDist" in silence.message
    run = steps(silence)
    # the last step of the run is the uuv's: the diagnostic sits at its line
    assert (silence.range.start.line + 1, silence.range.start.character + 1) == run[-1][:2]
    at = {(line, col): message for line, col, message in run}
    assert at[place(text, "Send(guide, release)")].endswith(
        "asv Send(guide, release): start and end")
    fix = "Receive(guide, fix, timeout = 10 s)"
    assert f"uuv {fix}: timeout 10 s → fail" in at[place(text, fix)]
    whose = [message.split(" ", 2)[1] for _, _, message in run]
    assert {"asv", "uuv"} <= set(whose)
    first_uuv = whose.index("uuv")
    assert "asv" in whose[first_uuv:], "the vehicles' steps interleaved, not one after the other"
    assert all(r.location.uri == path.as_uri() for r in silence.related_information or [])
    # the uuv's own proof fails too, said as the uuv's
    assert found["behaviours-off-at-end"].message.startswith("uuv: ")


def test_a_channels_step_is_shown_at_the_channel(tmp_path: Path) -> None:
    text = fleet_text(ASV_ALWAYS_SENDS, UUV_WAITS, lossy=False, every=False)
    found = {str(d.code): d for d in shown(str(tmp_path / "mcm.mcl"), text)}
    deadlock = found["fleet-no-deadlock"]
    assert (deadlock.range.start.line + 1, deadlock.range.start.character + 1) == place(
        text, "Receive(guide, release)")
    [(line, col, message)] = [s for s in steps(deadlock) if "channel guide" in s[2]]
    assert (line, col) == place(text, "CHANNEL guide")
    assert "release reaches uuv, where no Receive waits: ignored" in message


@pytest.mark.slow  # a cut exploration: about 1.5 s the first time in a process
def test_beyond_the_editors_budget_the_fleet_is_proved_compositionally(tmp_path: Path) -> None:
    text = fleet_text(uuv=UUV_NO_SURFACING)
    path = str(tmp_path / "mcm.mcl")
    outcome = prove(path, text, fleet_markings=10)
    assert outcome.fleet is not None and "compositional" in outcome.fleet["note"]
    fleet = [d for d in proved(analyse(path, text, 1), outcome)
             if str(d.code).startswith("fleet-")]
    assert fleet and all(d.severity == types.DiagnosticSeverity.Warning for d in fleet)
    assert all(d.message.startswith("fleet mcm: undecided") for d in fleet)


@pytest.mark.parametrize("vehicle", ["sim", "ictineu"])
def test_send_and_receive_need_no_behaviour_of_the_vehicle(vehicle: str) -> None:
    text = RELAY.read_text("utf-8")
    assert prove(str(RELAY), text, vehicle).lacks == ()
    # the follower holds its altitude at its post: a behaviour the Ictineu does not have
    text = text.replace("PARAM postPos", 'USES "ictineu";\n        USES "seabed.tasks";\n'
                        "        PARAM postPos").replace(
        "GoTo(postPos);", "KeepAltitude(enable, 2 m); GoTo(postPos); KeepAltitude(disable);")
    lacks = prove(str(RELAY), text, vehicle).lacks
    assert [(d.code, d.span.line if d.span else 0) for d in lacks] == (
        [] if vehicle == "sim" else [("vehicle-lacks-behaviour", place(text, "KeepAltitude")[0])] * 2)


def test_a_fleet_the_checker_refuses_is_not_proved() -> None:
    text = RELAY.read_text("utf-8").replace("timeout = 3 min", "timeout = 3 min, within = 1 s")
    assert not analyse(str(RELAY), text).provable
    assert prove(str(RELAY), text).kind == "invalid"
