"""One semantics for the verifier and the player (petri/semantics.py, petri/verification/properties.py,
petri/execution/player.py; issue 11): termination proved without the external stop (a lasso when it
fails), Zeno loops refused and never spun on, sound verdicts (undecided when cut), shared
watchers, disables that would switch off a behaviour another task holds, events never lost
to a tie, and the player's runs are paths of the verified reachability graph.
"""

from __future__ import annotations

import json
import random
import subprocess
import sys
from pathlib import Path
from typing import Any

import numpy as np
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from mcl import printer, tasklib
from mcl.api import compile_source
from diagnostics import Source
from petri.net import Net
from petri.execution.player import Player, Record
from petri.verification.reachability import explore
from petri.semantics import Semantics
from petri.verification.properties import Result, verify
from tests import strategies as S
from tests.support import shipped_nets

MCLC = [sys.executable, "-m", "app.mclc"]
GENERIC = tasklib.load(["generic"])


def compile_text(text: str, library: tasklib.Library | None = None) -> Net:
    return compile_source(Source("m.mcl", text), library=library).net


def results(net: Net, **kw: Any) -> dict[str, Result]:
    return {r.name: r for r in verify(net, **kw).results}


def replay(net: Net, steps: list[int]) -> Player:
    """Fire a counterexample's transitions one by one on the player (each must be enabled)."""
    player = Player(net, params={})
    for i, t in enumerate(steps):
        assert player.enabled(t), f"step {i + 1}: {net.transitions[t].name} is not enabled"
        player.fire(t, float(i))
    return player


# -- termination ----------------------------------------------------------------------------
FOREVER = "MISSION {\n    WHILE { Wait(1 s) } DO { Wait(10 s) }\n}\n"


def test_a_loop_whose_condition_never_fails_is_refused_with_a_lasso_that_replays() -> None:
    net = compile_text(FOREVER)
    r = results(net)["can-end"]
    assert not r.holds and not r.undecided
    assert "the WHILE at line 2 cannot end" in r.message
    assert "`Wait(1 s)` can never fail" in r.message
    assert r.counterexample is not None and r.cycle
    player = replay(net, r.counterexample)
    before = list(player.marking)
    for t in r.cycle:  # the loop goes round and comes back to where it started
        assert player.enabled(t), net.transitions[t].name
        player.fire(t, 0.0)
    assert player.marking == before
    assert not player.finished


def test_mclc_refuses_the_forever_loop_exit_1(tmp_path: Path) -> None:
    path = tmp_path / "forever.mcl"
    path.write_text(FOREVER)
    proc = subprocess.run(MCLC + [str(path), "--method", "explicit"], capture_output=True,
                          text=True, timeout=300)
    assert proc.returncode == 1, proc.stdout + proc.stderr
    assert "[FAIL] can-end: the WHILE at line 2 cannot end" in proc.stdout
    assert "then round and round for ever:" in proc.stdout


def test_a_loop_that_can_end_can_end() -> None:
    text = ("MISSION { WHILE { PARALLEL { Wait(1 s) } OR { KeepHeadDistException() } } "
            "DO { Wait(10 s) } }")
    assert results(compile_text(text))["can-end"].holds


def test_the_shipped_missions_can_end_by_themselves() -> None:
    shipped = shipped_nets()  # each vehicle of a fleet too
    assert len(shipped) >= 6
    for name, net in shipped:
        r = results(net)
        assert r["can-end"].holds, (name, r["can-end"].message)
        assert r["stop-safe"].holds, (name, r["stop-safe"].message)


def test_an_external_stop_that_cannot_finish_is_caught() -> None:
    # a mutation: the mission's abort no longer reaches its body, so nothing stops it
    net = compile_text("MISSION { GoTo((0, 0, 1, 0 deg)) }")
    stop = next(i for i, t in enumerate(net.transitions) if t.event == "Mission.abort")
    tr = net.transitions[stop]
    body_abort = [p for p, _ in tr.outputs if net.places[p].role == "abort"]
    net.transitions[stop] = type(tr)(tr.name, tr.inputs,
                                     tuple(a for a in tr.outputs if a[0] not in body_abort),
                                     tr.actions, tr.event, tr.timer, tr.origin, tr.label)
    r = results(net)["stop-safe"]
    assert not r.holds and not r.undecided, r.message


# -- Zeno -----------------------------------------------------------------------------------
ZENO = """MISSION {
    PARALLEL {
        WHILE { IF { Wait(0 s) } THEN { StartCamera(disable) } } DO { Wait(0 s) }
    } OR {
        Wait(120 s)
    }
}
"""


def test_a_loop_without_time_passing_is_refused() -> None:
    net = compile_text(ZENO)
    r = results(net)["no-zeno"]
    assert not r.holds and "the WHILE at line 3" in r.message
    assert r.cycle and all(Semantics(net).zero_time(t) for t in r.cycle)
    replay(net, (r.counterexample or []) + r.cycle)


def test_the_player_does_not_spin_on_a_zeno_loop() -> None:
    records: list[Record] = []
    player = Player(compile_text(ZENO), observers=[records.append])
    player.start(0.0)  # Wait(0 s) falls due at once: the loop would go round for ever
    assert player.finished and player.status == "fail"
    assert not player.behaviours_on
    notes = [r.data["note"] for r in records if r.kind == "note"]
    assert any("without time passing" in n for n in notes), notes


def test_mcl_run_of_a_zeno_mission_ends_by_itself(tmp_path: Path) -> None:
    path = tmp_path / "zeno.mcl"
    path.write_text(ZENO)
    log = tmp_path / "run.jsonl"
    proc = subprocess.run([sys.executable, "-m", "app.mcl", "run", str(path),
                           "--no-verify", "--log", str(log), "--quiet"],
                          capture_output=True, text=True, timeout=300)
    assert proc.returncode != 0, proc.stdout
    records = [json.loads(line) for line in log.read_text().splitlines()]
    assert any("without time passing" in str(r.get("note", "")) for r in records)


# -- sound verdicts ---------------------------------------------------------------------------
SIX = "MISSION { PARALLEL " + " AND ".join(["{ Wait(1 s); Wait(2 s) }"] * 6) + " }"


def test_a_cut_exploration_is_undecided_not_failed() -> None:
    verdict = verify(compile_text(SIX), max_markings=2_000)
    assert not verdict.ok and not verdict.failed and verdict.undecided
    r = {r.name: r for r in verdict.results}
    for name in ("no-deadlock", "terminates", "stop-safe", "dof-exclusive", "one-safe"):
        assert r[name].undecided and "exploration stopped" in r[name].message, name


def test_mclc_exits_4_when_undecided(tmp_path: Path) -> None:
    path = tmp_path / "six.mcl"
    path.write_text(SIX)
    proc = subprocess.run(MCLC + [str(path), "--method", "explicit", "--max-markings", "2000"],
                          capture_output=True, text=True, timeout=300)
    assert proc.returncode == 4, proc.stdout + proc.stderr
    assert "UNDECIDED" in proc.stdout and "[????] can-end" in proc.stdout
    assert "[FAIL]" not in proc.stdout


def test_a_violation_seen_before_the_cut_is_still_reported() -> None:
    text = ("MISSION { PARALLEL { GoTo((0, 0, 5, 0 deg)) } AND { Surface() } AND "
            + " AND ".join(["{ Wait(1 s); Wait(2 s) }"] * 4) + " }")
    r = results(compile_text(text), max_markings=3_000)["dof-exclusive"]
    assert not r.holds and not r.undecided
    replay(compile_text(text), r.counterexample or [])


# -- watchers and holders ----------------------------------------------------------------------
NESTED_ALARMS = """MISSION {
    TRY {
        TRY { GoTo((0, 0, 1, 0 deg)) } CATCH { Alarms() } DO { Surface() };
        GoTo((0, 0, 2, 0 deg))
    } CATCH {
        Alarms()
    } DO {
        Surface()
    }
}
"""


def actions(records: list[Record]) -> list[tuple[str, str]]:
    return [(r.data["action"], r.data["behaviour"]) for r in records if r.kind == "action"]


def test_nested_alarm_handlers_verify() -> None:
    verdict = verify(compile_text(NESTED_ALARMS))
    assert verdict.ok, [(r.name, r.message) for r in verdict.results if not r.holds]


def test_nested_alarm_handlers_run_and_alarms_stays_on_until_the_last_holder() -> None:
    records: list[Record] = []
    player = Player(compile_text(NESTED_ALARMS), observers=[records.append])
    player.start(0.0)
    assert actions(records).count(("enable", "Alarms")) == 2
    player.handle_event("GoTo.reached", 10.0)  # the inner TRY ends: its watcher lets go
    assert ("disable", "Alarms") not in actions(records)  # the outer one still holds it
    assert "Alarms" in player.behaviours_on
    player.handle_event("Alarms.leak", 20.0)  # the outer CATCH fires: the DO surfaces
    player.handle_event("Surface.surfaced", 30.0)
    assert player.status == "ok" and not player.behaviours_on
    assert actions(records).count(("disable", "Alarms")) == 1


def test_a_dof_behaviour_still_needs_one_owner() -> None:
    text = "MISSION { PARALLEL { GoTo((0, 0, 1, 0 deg)) } AND { GoTo((1, 0, 1, 0 deg)) } }"
    r = results(compile_text(text))["behaviour-single-owner"]
    assert not r.holds and "GoTo" in r.message


def test_an_unlatch_under_a_running_task_is_refused() -> None:
    text = ("MISSION { PARALLEL { AchieveHeadDist(0 deg, 1.5 m) } AND "
            "{ Wait(1 s); KeepHeadDist(disable) } }")
    net = compile_text(text)
    r = results(net)["no-disable-while-held"]
    assert not r.holds and "KeepHeadDist(disable)" in r.message
    player = replay(net, r.counterexample or [])
    assert "AchieveHeadDist" in Semantics(net).behaviours_on(player.marking)


def test_the_player_keeps_a_held_behaviour_on() -> None:
    text = ("MISSION { PARALLEL { AchieveHeadDist(0 deg, 1.5 m) } AND "
            "{ Wait(1 s); KeepHeadDist(disable) } }")
    records: list[Record] = []
    player = Player(compile_text(text), observers=[records.append])
    player.start(0.0)
    player.settle(2.0)  # the unlatch fires while the task still runs
    assert "AchieveHeadDist" in player.behaviours_on
    assert ("disable", "AchieveHeadDist") not in actions(records)
    player.handle_event("AchieveHeadDist.achieved", 3.0)
    assert player.status == "ok" and not player.behaviours_on


# -- ties -------------------------------------------------------------------------------------
def test_an_event_at_the_instant_a_timer_starts_its_watcher_is_not_lost() -> None:
    text = "MISSION { Wait(5 s); TRY { Wait(100 s) } CATCH { Alarms() } DO { Surface() } }"
    records: list[Record] = []
    player = Player(compile_text(text), observers=[records.append])
    player.start(0.0)
    assert player.handle_event("Alarms.leak", 5.0) == 1  # the watcher starts at 5 s too
    assert ("enable", "Surface") in actions(records)
    assert not [r for r in records if r.kind == "ignored"]


# -- the player's runs are paths of the verified graph ------------------------------------------
def graph_markings(net: Net) -> set[bytes]:
    ss = explore(net)
    assert ss.complete
    return {bytes(row.astype(np.uint8)) for row in ss.markings}


def visit(player: Player, seen: list[bytes]) -> None:
    seen.append(bytes(np.array(player.marking, np.uint8)))


@settings(max_examples=40, deadline=None, suppress_health_check=list(HealthCheck))
@given(S.generic_missions(max_depth=3, max_calls=6, lamps="paired")
       .filter(lambda m: S.concurrency(m.body) <= 3), st.integers(0, 2**32 - 1))
def test_every_player_run_is_a_path_of_the_reachability_graph(mission: Any, seed: int) -> None:
    text = printer.mission(mission)
    net = compile_source(Source("g.mcl", text), library=GENERIC).net
    reachable = graph_markings(net)
    rnd = random.Random(seed)
    seen: list[bytes] = []
    player = Player(net, observers=[lambda r: visit(player, seen) if r.kind == "fire" else None])
    player.start(0.0)
    now = 0.0
    for _ in range(60):  # random events at random times, bounded
        if player.finished:
            break
        now += rnd.choice([0.0, 0.5, 1.0, 3.0])
        if rnd.random() < 0.2:
            player.settle(now)
            continue
        player.handle_event(rnd.choice(["Probe.ok", "Probe.fail"]), now)
    player.abort(now + 1.0, "the test stops it")  # the external stop, from wherever it is
    assert player.finished and not player.behaviours_on, text
    assert not Semantics(net).behaviours_on(player.marking), text
    missing = [i for i, m in enumerate(seen) if m not in reachable]
    assert not missing, f"{text}\nfiring {missing[0] + 1} leaves the verified graph"


# -- timers against timers ----------------------------------------------------------------------
def test_timers_decide_a_clash_the_player_cannot_reach() -> None:
    # Surface ends (surfaced, or its 5 s timeout) before GoTo starts at 10 s: no clash on z
    text = ("MISSION { PARALLEL { Wait(10 s); GoTo((0, 0, 1, 0 deg)) } AND "
            "{ Surface(timeout = 5 s) } }")
    r = results(compile_text(text))["dof-exclusive"]
    assert r.holds and "by the timers' values" in r.message
    late = results(compile_text(text.replace("5 s", "15 s")))["dof-exclusive"]
    assert not late.holds and not late.undecided
    replay(compile_text(text.replace("5 s", "15 s")), late.counterexample or [])


def test_replay_refuses_a_timer_fired_late_even_with_the_digests_recomputed(
        tmp_path: Path) -> None:
    from petri.execution.replay import check
    from petri.execution.runlog import RunLog, net_digest, read_log

    net = compile_text("MISSION { Wait(5 s); Wait(3 s) }")
    path = tmp_path / "run.jsonl"
    player = Player(net)
    with RunLog(path, {"mission": "m", "net": net_digest(net), "params": {}}) as log:
        player.observers.append(log)
        player.start(0.0)
        player.settle(100.0)
        log.end(100.0, "ended", "the mission ended ok")
    records = read_log(path)
    assert check(net, records, {}).ok
    timers = [i for i, r in enumerate(records) if r.get("cause") == "timer"]
    forged = [dict(r) for r in records]
    for r in forged[timers[-1]:]:  # the second timer and everything after it, later
        r["t"] = float(r["t"]) + 7.0
    result = check(net, forged, {})
    assert not result.ok and result.line == records[timers[-1]]["_line"]
    assert "after its time" in result.reason
