"""``mcl lsp`` end to end on fleets: a real server process driven by pytest-lsp's client.

The server's diagnostics for a fleet are mclc's (``mclc --json`` run beside it: each
vehicle's properties, then the fleet's own, located by app/reports/formats.py as every report
of mclc is); a fleet property that fails carries its counterexample, both vehicles' steps at
the MCL lines mclc gives them and the channel's at the channel.
"""

from __future__ import annotations

import sys
from pathlib import Path
from typing import Any

import pytest

pytest_lsp = pytest.importorskip("pytest_lsp")
from lsprotocol import types
from pygls import uris
from pytest_lsp import ClientServerConfig, LanguageClient, client_capabilities

from app.lsp.diagnostics import NOT_ACTIONABLE
from app.reports.formats import flat, problems
from tests.app.lsp.test_server import mclc, open_and_prove, shown
from tests.mcl.analysis.fleet_missions import UUV_NO_SURFACING, fleet_text

ROOT = Path(__file__).resolve().parents[3]
RELAY = ROOT / "missions" / "fleet_relay.mcl"


@pytest_lsp.fixture(config=ClientServerConfig(  # type: ignore[untyped-decorator]
    server_command=[sys.executable, "-m", "app.mcl", "lsp", "--proof-delay", "0"]))
async def client(lsp_client: LanguageClient) -> Any:
    await lsp_client.initialize_session(types.InitializeParams(
        capabilities=client_capabilities("visual-studio-code"),
        root_uri=uris.from_fs_path(str(ROOT))))
    yield
    await lsp_client.shutdown_session()


def expected(report: dict[str, Any]) -> list[tuple[str, int, int, str]]:
    """What mclc's reports say of a fleet file, each vehicle's and the fleet's own: (rule,
    line, col, level), the rules an author cannot act on left out."""
    return sorted((p["rule"], p["line"], p["col"], p["level"]) for r in flat([report])
                  for p in problems(r) if p["rule"] not in NOT_ACTIONABLE)


@pytest.mark.slow  # a server process and mclc beside it
@pytest.mark.asyncio
async def test_the_shipped_fleet_shows_no_proof_diagnostic(client: LanguageClient) -> None:
    found = await open_and_prove(client, RELAY)
    report = mclc(RELAY)
    assert report["fleet_properties"]["verified"]
    assert shown(found) == expected(report) == []


@pytest.mark.slow  # a server process and mclc beside it
@pytest.mark.asyncio
async def test_a_fleet_without_its_surfacing_fails_as_mclc_says(
        client: LanguageClient, tmp_path: Path) -> None:
    path = tmp_path / "mcm.mcl"
    path.write_text(fleet_text(uuv=UUV_NO_SURFACING), "utf-8")
    found = await open_and_prove(client, path)
    report = mclc(path)
    assert shown(found) == expected(report)
    by_rule = {str(d.code): d for d in found}
    failed = [p for p in report["fleet_properties"]["properties"] if p["status"] == "fails"]
    assert {p["property"] for p in failed} >= {"fleet-silence", "fleet-nothing-on-at-end"}
    channel = {c["channel"]: (c["line"], c["col"]) for c in report["channels"]}
    for p in failed:
        related = by_rule[p["property"]].related_information or []
        steps = p["counterexample"] + (p.get("cycle") or [])
        assert [(r.location.range.start.line + 1, r.location.range.start.character + 1)
                for r in related] == [(s["line"], s["col"]) if s["vehicle"] else
                                      channel[s["channel"]] for s in steps]
        assert {r.message.split(" ", 2)[1] for r in related} >= {"asv", "uuv"}
        assert all(r.location.uri == uris.from_fs_path(str(path)) for r in related)
