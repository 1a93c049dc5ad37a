"""The fleet of docs/LANGUAGE.md ("Fleets", paper 003's scenario) compiles and verifies as
the page says, and the place it quotes is where the compiler puts that call."""

from __future__ import annotations

import re

from diagnostics import Source
from mcl.analysis.verification import verify_mission
from mcl.fleet import compile_fleet_source
from tests.support import REPO

PAGE = (REPO / "docs" / "LANGUAGE.md").read_text("utf-8")


def _example() -> str:
    section = PAGE[PAGE.index("\n## Fleets"):]
    match = re.search(r"```\n(FLEET.*?|//.*?)```", section, re.S)
    assert match is not None, "the Fleets section has no example"
    return match.group(1)


def test_the_documented_fleet_compiles_with_the_channels_it_declares() -> None:
    fleet = compile_fleet_source(Source("mcm.mcl", _example()))
    assert fleet.name == "mcm" and list(fleet.vehicles) == ["asv", "uuv"]
    guide = fleet.channels["guide"]
    assert (guide.sender, guide.receivers, guide.lossy) == ("asv", ("uuv",), True)
    assert (guide.delay_min, guide.delay_max, guide.interval) == (1.0, 3.0, 2.0)


def test_the_quoted_place_of_a_receive_is_the_compilers() -> None:
    quoted = re.search(r"`uuv mcm\.mcl:(\d+):(\d+)\s+(Receive\([^`]*\))`", PAGE)
    assert quoted is not None
    line, col, text = int(quoted[1]), int(quoted[2]), " ".join(quoted[3].split())
    net = compile_fleet_source(Source("mcm.mcl", _example())).vehicles["uuv"].net
    places = {(t.origin.line, t.origin.col, t.origin.text) for t in net.transitions
              if t.origin is not None}
    assert (line, col, text) in places


def test_every_vehicle_of_the_documented_fleet_verifies() -> None:
    fleet = compile_fleet_source(Source("mcm.mcl", _example()))
    for name, compiled in fleet.vehicles.items():
        verdict = verify_mission(compiled, "explicit")
        assert verdict.ok, (name, [p["property"] for p in verdict.to_json()["properties"]
                                   if not p["holds"]])
