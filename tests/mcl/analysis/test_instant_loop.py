"""``instant-loop`` (issue 21): a loop whose every lap can complete with no mission time passing
when the vehicle answers its events at once is reported by the verifier, on every route, as a
warning naming the WHILE and the events that close a lap; a lap that waits for a timer > 0 is
not. The quoted missions of the issue passed no-zeno and spun at mission time 0 on a scripted
vehicle."""

from __future__ import annotations

import os
from pathlib import Path

from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
import pytest

from mcl import printer
from mcl.analysis import structural
from mcl.analysis.verification import verify_mission
from petri.verification.properties import Result, Verdict
from tests.mcl import test_routes as routes_test
from tests.strategies import route_libraries, route_missions
from tests.support import cli

GOTO = ("MISSION {\n    PARALLEL {\n        WHILE { GoTo((-1, 0, 1, 0)) } DO { Surface()%s }\n"
        "    } OR { Timeout(10 min) }\n}\n")
LOGS = ("MISSION {\n    PARALLEL {\n        WHILE { Surface() } DO { StartLogs(enable); "
        "StartLogs(disable)%s }\n    } OR { Timeout(10 min) }\n}\n")


def instant(verdict: Verdict) -> Result:
    return next(r for r in verdict.results if r.name == "instant-loop")


def on_every_route(text: str) -> dict[str, Result]:
    compiled = routes_test.compile_text(text)
    return {"explicit": instant(verify_mission(compiled, "explicit")),
            "structural": instant(structural.analyse(compiled.checked)),
            "auto": instant(verify_mission(compiled, "auto"))}


def test_the_quoted_loops_are_instant_loops_on_every_route() -> None:
    for text, events in ((GOTO % "", ("GoTo.reached", "Surface.surfaced")),
                         (LOGS % "", ("Surface.surfaced",))):
        for route, r in on_every_route(text).items():
            assert (r.status, r.severity) == ("fails", "warning"), (route, text)
            assert r.message.startswith("the WHILE at line 3 can go round with no mission "
                                        "time passing"), (route, r.message)
            assert all(e in r.message for e in events), (route, r.message)
            assert "10,000 firings" in r.message
        compiled = routes_test.compile_text(text)
        verdict = verify_mission(compiled, "explicit")
        assert verdict.ok  # a warning: the verdict stays free of errors
        assert next(r for r in verdict.results if r.name == "no-zeno").holds
        cycle = instant(verdict).cycle or []
        assert {compiled.net.transitions[t].event for t in cycle} >= set(events)


def test_a_lap_that_waits_a_second_is_no_instant_loop() -> None:
    for text in (GOTO % "; Wait(1 s)", LOGS % "; Wait(1 s)"):
        for route, r in on_every_route(text).items():
            assert r.status == "holds", (route, r.message)


def test_a_timer_inside_the_condition_alone_makes_each_lap_take_time() -> None:
    text = "MISSION { PARALLEL { WHILE { Wait(1 s) } DO { Surface() } } OR { Timeout(1 min) } }"
    assert {r.status for r in on_every_route(text).values()} == {"holds"}
    # but a timer the lap can bypass (the other branch of an IF, on GoTo.failed) does not
    text = ("MISSION { PARALLEL { WHILE { IF { GoTo((1, 0, 1, 0)) } THEN { Wait(1 s) } "
            "ELSE { Wait(0 s) } } DO { Surface() } } OR { Timeout(1 min) } }")
    assert {r.status for r in on_every_route(text).values()} == {"fails"}


@settings(max_examples=int(os.environ.get("MCL_ROUTE_EXAMPLES", "40")), deadline=None,
          suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])
@given(st.data())
def test_the_structural_route_finds_the_same_instant_loops(data: st.DataObject) -> None:
    lib = data.draw(route_libraries(), label="library")
    mission = data.draw(route_missions(lib), label="mission")
    text = printer.mission(mission)
    compiled = routes_test.compile_text(text, lib.text)
    reference = verify_mission(compiled, "explicit", max_markings=200_000)
    if reference.undecided:
        return  # too large to be the reference
    found = instant(structural.analyse(compiled.checked, compiled.net)).status
    assert found == instant(reference).status, f"{lib.text}\n{text}"


@pytest.mark.slow
def test_mclc_names_the_loop_and_the_events(tmp_path: Path) -> None:
    spinning, waiting = tmp_path / "spin.mcl", tmp_path / "wait.mcl"
    spinning.write_text(GOTO % "", "utf-8")
    waiting.write_text(GOTO % "; Wait(1 s)", "utf-8")
    for method in ("explicit", "structural"):
        proc = cli("mclc", str(spinning), "--method", method)
        assert proc.returncode == 0, proc.stdout + proc.stderr  # a warning, not an error
        assert ("[warn] instant-loop: the WHILE at line 3 can go round with no mission time "
                "passing") in proc.stdout, proc.stdout
        assert "GoTo.reached" in proc.stdout
        proc = cli("mclc", str(waiting), "--method", method)
        assert proc.returncode == 0, proc.stdout + proc.stderr
        assert "[ok  ] instant-loop: every loop waits for a timer > 0" in proc.stdout
