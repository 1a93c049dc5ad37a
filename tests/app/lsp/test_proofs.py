"""The proofs behind the editor: debounced, in a child process, dropped for a newer text,
ended when too long, and the same verdict as mclc's."""

from __future__ import annotations

import asyncio
import multiprocessing
from pathlib import Path

import pytest

pytest.importorskip("pygls")

from app.lsp.proofs import Outcome, Prover, prove
from diagnostics import Source
from mcl.analysis.verification import verify_mission
from mcl.api import compile_source

ROOT = Path(__file__).resolve().parents[3]
DAM = ROOT / "missions" / "dam_inspection.mcl"
TEXT = DAM.read_text("utf-8")


def test_prove_is_mclcs_verdict() -> None:
    outcome = prove(str(DAM), TEXT)
    verdict = outcome.verification
    expected = verify_mission(compile_source(Source(str(DAM), TEXT))).to_json()
    assert outcome.kind == "verified" and verdict is not None and outcome.lacks == ()
    assert [(p["property"], p["status"]) for p in verdict["properties"]] == [
        (p["property"], p["status"]) for p in expected["properties"]]


def test_prove_an_invalid_text() -> None:
    assert prove("x.mcl", "MISSION {") == Outcome("invalid")


def test_prove_checks_the_vehicle_named() -> None:
    seabed = ROOT / "missions" / "pipeline_inspection.mcl"
    text = seabed.read_text("utf-8")
    assert prove(str(seabed), text, "sim").lacks == ()
    lacks = prove(str(seabed), text, "ictineu").lacks
    assert lacks and {d.code for d in lacks} == {"vehicle-lacks-behaviour"}
    assert all(d.span is not None and d.span.file == str(seabed) for d in lacks)


def test_prove_keeps_to_the_explicit_routes_limits() -> None:
    verdict = prove(str(DAM), TEXT, max_markings=10).verification
    assert verdict is not None and verdict["reachable_markings"] == 0
    assert any("over the explicit route's budget of 10 markings" in p["method"]
               for p in verdict["properties"])


class Reports:
    def __init__(self) -> None:
        self.got: list[tuple[str, int | None, Outcome]] = []

    def __call__(self, uri: str, version: int | None, outcome: Outcome) -> None:
        self.got.append((uri, version, outcome))


@pytest.mark.asyncio
async def test_only_the_latest_text_is_proved() -> None:
    reports = Reports()
    prover = Prover(reports, delay=0.2)
    prover.request("u", str(DAM), TEXT, 1)
    await asyncio.sleep(0.05)  # typing goes on: version 1 is never proved
    prover.request("u", str(DAM), TEXT, 2)
    while "u" in prover.running:
        await asyncio.sleep(0.05)
    assert [(uri, version, outcome.kind) for uri, version, outcome in reports.got] == [
        ("u", 2, "verified")]


@pytest.mark.asyncio
async def test_a_running_proof_is_ended_by_a_newer_text() -> None:
    reports = Reports()
    prover = Prover(reports, delay=0.0)
    prover.request("u", str(DAM), TEXT, 1)
    for _ in range(200):  # until its process runs
        await asyncio.sleep(0.02)
        if multiprocessing.active_children():
            break
    assert multiprocessing.active_children()
    prover.cancel("u")
    await asyncio.sleep(0.3)
    assert reports.got == [] and not multiprocessing.active_children()


@pytest.mark.asyncio
async def test_a_proof_past_its_time_is_stopped() -> None:
    reports = Reports()
    prover = Prover(reports, delay=0.0, seconds=0.01)
    prover.request("u", str(DAM), TEXT, 1)
    while "u" in prover.running:
        await asyncio.sleep(0.05)
    [(_, _, outcome)] = reports.got
    assert outcome.kind == "stopped" and "longer than 0.01 s" in outcome.why
    assert not multiprocessing.active_children()
