"""The quick verdict (petri/verification/all_hold.py) is the explicit route's, word for word,
wherever it answers, and it answers wherever every property holds on a small safe net."""

from __future__ import annotations

from typing import Any

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from mcl import printer
from mcl.analysis import termination
from mcl.api import Compiled, compile_file, compile_source
from mcl.fleet import compile_fleet_file, is_fleet
from mcl.tasklib import load, load_sources
from diagnostics import Source
from petri.verification import all_hold as quick
from petri.verification import reachability
from petri.verification.properties import Verdict, verify
from tests.strategies import route_libraries, route_missions
from tests.support import MISSIONS, REPO

CORE_TASKS = (REPO / "mcl" / "tasks" / "core.tasks").read_text("utf-8")

# the properties the quick verdict decides on the graph (terminates is the caller's; the
# static actions-match-behaviours and the warning no-dead-transitions it reports as found)
ON_THE_GRAPH = {"one-safe", "proper-completion", "no-deadlock", "can-end", "no-zeno",
                "instant-loop", "behaviours-off-at-end", "behaviour-single-owner",
                "dof-exclusive", "no-disable-while-held", "stop-safe"}


def as_reported(verdict: Verdict) -> dict[str, Any]:
    """What mclc reports of a verdict, but the seconds it took."""
    return {**verdict.to_json(), "seconds": None}


def compare(compiled: Compiled) -> bool:
    """Whether the quick verdict answered; where it did, it is the explicit route's."""
    net = compiled.net
    decided = termination.result(compiled.checked)
    full = verify(net, termination=lambda g, how, cut: termination.result(compiled.checked,
                                                                           how, g))
    found = quick.explored(net, 5_000_000)
    verdict = quick.all_hold(net, found, decided) if found is not None else None
    if verdict is None:  # it leaves only what the explicit route finds not holding, or bigger
        assert (found is None or len(found[0]) > quick.MAX_MARKINGS
                or not decided.holds
                or any(not r.holds for r in full.results if r.name in ON_THE_GRAPH)), \
            [(r.name, r.status) for r in full.results]
        return False
    assert as_reported(verdict) == as_reported(full)
    assert verdict.dead_transitions == full.dead_transitions
    space = quick.state_space(net, found)  # what the explicit route is given instead
    again = verify(net, termination=lambda g, how, cut: decided, space=space)
    assert as_reported(again) == as_reported(full)
    return True


def test_every_shipped_mission_small_enough_gets_the_explicit_routes_verdict() -> None:
    answered = []
    for path in sorted(MISSIONS.glob("*.mcl")):
        if is_fleet(str(path)):
            compiled = list(compile_fleet_file(str(path)).vehicles.values())
        else:
            compiled = [compile_file(str(path))]
        answered += [path.name for c in compiled if len(c.net.places) < 250 and compare(c)]
    assert "dam_inspection.mcl" in answered and "mcm.mcl" in answered, answered


def test_its_search_stops_where_explore_stops_a_small_safe_nets() -> None:
    assert quick.SEARCH_MARKINGS == reachability.SMALL_SAFE_MARKINGS
    assert quick.MAX_PLACES == reachability.SMALL_SAFE_PLACES


@pytest.mark.slow
@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.data())
def test_random_missions_get_the_explicit_routes_verdict(data: st.DataObject) -> None:
    """Missions with latches, races and loops, many of which fail a property."""
    lib = data.draw(route_libraries(), label="library")
    mission = data.draw(route_missions(lib), label="mission")
    text = printer.mission(mission)
    library = load_sources([Source("core.tasks", CORE_TASKS), Source("r.tasks", lib.text)])
    compare(compile_source(Source("r.mcl", text), library=library))


def test_a_violation_is_left_to_the_explicit_route() -> None:
    generic = load(["generic"])  # core timers, A() .. D(), Now(), Lamp(enable|disable)
    for body in ("WHILE { Now() } DO { Wait(1 s) }",  # can-end, terminates
                 "WHILE { A() } DO { B() }",  # instant-loop (a warning), terminates
                 "Lamp(enable)"):  # behaviours-off-at-end
        compiled = compile_source(Source("m.mcl", f"MISSION {{\n  {body}\n}}\n"),
                                  library=generic)
        assert not compare(compiled), body
    sound = "MISSION {\n  Lamp(enable); Wait(1 s); Lamp(disable)\n}\n"
    assert compare(compile_source(Source("m.mcl", sound), library=generic))
