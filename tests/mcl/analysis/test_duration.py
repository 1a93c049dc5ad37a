"""Proved best- and worst-case durations (mcl/analysis/duration.py), checked two ways.

1. Random missions x random timings of the vehicle's events on the player: every run that
   ends lasts between the mission's best and worst bounds; one still running after t seconds
   shows worst >= t.
2. On small missions, an exhaustive search over event times on a 1 s grid (every timer is a
   whole number of seconds) gives the shortest and longest run of the player: the bounds
   contain them (and equal them on the constructs' own tests); the outcomes the bounds allow
   contain those the time Petri net's state-class graph (petri/verification/timed.py) reaches.

Plus each construct's rule on a small mission, and --deadline / --battery / --reserve through
a real ``mclc`` subprocess.
"""

from __future__ import annotations

import copy
import json
import math
from pathlib import Path
from typing import Any

import pytest
from hypothesis import HealthCheck, assume, event, given, settings
from hypothesis import strategies as st

from mcl import ast, printer, tasklib
from mcl.api import compile_file, compile_source
from app.reports.duration import judge
from mcl.analysis.duration import Durations, analyse
from mcl.quantities import parse_battery, parse_deadline, parse_reserve
from diagnostics import Source
from petri.net import Net
from petri.execution.player import Player, Record
from petri.semantics import MISSION_ABORT
from petri.verification.timed import explore_timed
from tests import strategies as S
from tests.support import GENERIC_TASKS, MISSIONS, cli, write

INF = math.inf
GENERIC = tasklib.load_sources([Source("core", (Path(tasklib.__file__).parent / "tasks" /
                                                "core.tasks").read_text("utf-8")),
                                Source("generic.tasks", GENERIC_TASKS)])


def bounds(body: str, library: tasklib.Library | None = GENERIC) -> Durations:
    compiled = compile_source(Source("m.mcl", f"MISSION {{ {body} }}"), library=library)
    return analyse(compiled.checked)


def ends(d: Durations) -> dict[str, tuple[float, float]]:
    return dict(d.ends)


# -- each construct's rule -------------------------------------------------------------------
def test_a_timer_takes_exactly_its_time_and_a_sequence_sums() -> None:
    d = bounds("Wait(5 s); Timeout(3 s); Now()")
    assert (d.best, d.worst) == (8, 8)
    assert ends(d) == {"ok": (8, 8)}
    assert ends(bounds("Wait(5 s); Timeout(3 s)")) == {"fail": (8, 8)}


def test_an_event_task_may_end_at_once_or_never() -> None:
    d = bounds("Wait(2 s); A()")
    assert (d.best, d.worst) == (2, INF)
    assert [s.text for s in d.unbounded] == ["A()"]
    assert "for ever" in d.unbounded[0].ending
    assert d.critical_path[0].text == "Wait(2 s)"


def test_a_per_call_timeout_bounds_a_task() -> None:
    d = bounds("GoTo((0, 0, 1, 0), timeout = 30 s)", library=None)
    assert ends(d) == {"ok": (0, 30), "fail": (0, 30)}
    assert ends(bounds("GoTo((0, 0, 1, 0))", library=None)) == {"ok": (0, 600),
                                                                  "fail": (0, 600)}


def test_parallel_and_waits_for_every_branch() -> None:
    assert ends(bounds("PARALLEL { Wait(5 s) } AND { Wait(3 s) }")) == {"ok": (5, 5)}
    # a failing branch does not stop the others
    assert ends(bounds("PARALLEL { Timeout(1 s) } AND { Wait(3 s) }")) == {"fail": (3, 3)}


def test_parallel_or_ends_with_the_first_branch() -> None:
    assert ends(bounds("PARALLEL { A() } OR { Timeout(10 s) }")) == {
        "ok": (0, 10), "fail": (0, 10)}
    assert ends(bounds("PARALLEL { Wait(5 s) } OR { Timeout(10 s) }")) == {"ok": (5, 5)}
    d = bounds("PARALLEL { Wait(4 s); B() } OR { Timeout(10 s) }")
    assert (d.best, d.worst) == (4, 10)
    assert d.critical_path[-1].text == "Timeout(10 s)"


def test_try_catch_do_races_then_runs_do() -> None:
    d = bounds("TRY { Wait(10 s) } CATCH { A() } DO { Wait(2 s) }")
    assert ends(d) == {"ok": (2, 12)}
    assert [s.text for s in d.critical_path] == ["Wait(10 s)", "CATCH A()", "Wait(2 s)"]
    # a CATCH that never ends is harmless; one that ends first runs DO
    assert ends(bounds("TRY { Wait(3 s) } CATCH { Wait(5 s) } DO { Timeout(1 s) }")) == {
        "ok": (3, 3)}
    assert ends(bounds("TRY { Wait(7 s) } CATCH { Wait(5 s) } DO { Timeout(1 s) }")) == {
        "fail": (6, 6)}


def test_if_runs_the_branch_its_condition_picks() -> None:
    assert ends(bounds("IF { Timeout(1 s) } THEN { Wait(5 s) } ELSE { Wait(2 s) }")) == {
        "ok": (3, 3)}
    assert ends(bounds("IF { Wait(1 s) } THEN { Wait(5 s) } ELSE { Wait(2 s) }")) == {
        "ok": (6, 6)}
    assert ends(bounds("IF { Timeout(1 s) } THEN { Wait(5 s) }")) == {"fail": (1, 1)}


def test_a_while_is_unbounded_and_named_unless_a_race_bounds_it() -> None:
    d = bounds("Wait(1 s); WHILE { A() } DO { Wait(1 s) }")
    assert d.worst == INF and d.best == 1
    assert any(s.text.startswith("WHILE") and s.line == 1 for s in d.unbounded)
    bounded = bounds("PARALLEL { WHILE { A() } DO { Wait(1 s) } } OR { Timeout(60 s) }")
    assert (bounded.best, bounded.worst) == (0, 60)
    # a loop whose condition always fails at once runs no lap
    assert ends(bounds("WHILE { Timeout(2 s) } DO { Wait(1 s) }")) == {"ok": (2, 2)}


def test_every_block_has_its_bounds_in_source_order() -> None:
    d = bounds("Wait(1 s);\n PARALLEL { Wait(2 s) } OR { A() }")
    assert [(b.construct, b.line) for b in d.blocks][:2] == [("Sequence", 1), ("Call", 1)]
    par = next(b for b in d.blocks if b.construct == "ParallelOr")
    assert (par.best, par.worst, par.line) == (0, 2, 2)


def test_the_dam_mission_bound_and_estimate() -> None:
    compiled = compile_file(str(MISSIONS / "dam_inspection.mcl"))
    d = analyse(compiled.checked)
    # 10 + 3 + (60 + 5 Surface after the CATCH) + 10 min, then Alarms may fire at the last
    # instant: + 5 min Surface = 93 min
    assert (d.best, d.worst) == (0, 93 * 60)
    assert [s.line for s in d.critical_path if s.seconds] == [34, 35, 39, 44, 47, 51]
    assert d.estimate is not None and 1100 < d.estimate < 1400  # simulated run: ~1200 s
    assert d.energy is not None and 0 < d.energy.worst_wh < INF
    verdict = judge(d, deadline=45 * 60)
    assert verdict.failures and "93 min" in verdict.failures[0]
    assert not judge(d, deadline=2 * 3600).failures


def test_energy_counts_peak_power_over_time_and_latches_for_the_whole_mission() -> None:
    lib = tasklib.load_sources([Source("x.tasks", """
        behaviour Motor events done power 100 W;
        behaviour Lamp power 10 W;
        task Run(d: duration) { start: enable Motor; ok: Motor.done; timeout: d -> fail;
                                stop: disable Motor; }
        task Lamp(enable) { start: enable Lamp; latch: Lamp; }
        task Lamp(disable) { start: disable Lamp; unlatch: Lamp; }
        task Wait(d: duration) { timeout: d -> ok; }
    """)])
    d = bounds("Run(36 s); Wait(36 s)", lib)
    assert d.energy is not None and d.energy.worst_wh == pytest.approx(1.0)  # 100 W x 36 s
    d = bounds("Lamp(enable); Run(36 s); Lamp(disable); Wait(324 s)", lib)
    assert d.energy is not None  # 1 Wh of motor + 10 W lamp over the whole 360 s
    assert d.energy.worst_wh == pytest.approx(1.0 + 1.0)
    v = judge(d, battery_wh=2.4, reserve=0.2)
    assert v.failures and "reserve" in v.failures[0]
    assert not judge(d, battery_wh=2.6, reserve=0.2).failures


def test_quantities_are_parsed_or_refused_in_one_line() -> None:
    assert parse_deadline("45min") == 2700 and parse_deadline("1.5 h") == 5400
    assert parse_battery("800Wh") == 800 and parse_reserve("20%") == 0.2
    for bad in ("-5min", "nanmin", "45", "infh", "abc", ""):
        with pytest.raises(ValueError, match="--deadline"):
            parse_deadline(bad)
    for bad in ("0Wh", "-1Wh", "100"):
        with pytest.raises(ValueError, match="--battery"):
            parse_battery(bad)
    for bad in ("100%", "20", "-5%"):
        with pytest.raises(ValueError, match="--reserve"):
            parse_reserve(bad)


def test_library_clauses_are_checked() -> None:
    with pytest.raises(Exception, match="power"):
        tasklib.load_sources([Source("x.tasks", "behaviour M power -5 W;")])
    with pytest.raises(Exception, match="path parameter"):
        tasklib.load_sources([Source("x.tasks", "behaviour M events e;\n"
                                     "task T(p: point) { ok: M.e; estimate: length(p) / 1 m/s; }")])
    with pytest.raises(Exception, match="speed"):
        tasklib.load_sources([Source("x.tasks", "behaviour M events e;\n"
                                     "task T(p: point) { ok: M.e; estimate: distance(p) / 0 m/s; }")])


# -- 1. random missions x random timings on the player ----------------------------------------
SMALL = [0, 1, 2, 5]


def timer_calls(grid: bool) -> st.SearchStrategy[ast.Call]:
    duration = st.sampled_from(SMALL).map(lambda v: ast.Number(float(v), "s"))
    point = ast.Point(tuple(ast.Number(float(v), None) for v in (0, 0, 1, 0)))
    calls = [st.builds(lambda d: ast.Call("Wait", (ast.Arg(d),)), duration),
             st.builds(lambda d: ast.Call("Timeout", (ast.Arg(d),)), duration),
             st.builds(lambda d: ast.Call("Surface", (ast.Arg(d, "timeout"),)), duration),
             st.builds(lambda d: ast.Call("GoTo", (ast.Arg(point), ast.Arg(d, "timeout"))),
                       duration),
             st.just(ast.Call("KeepHeadDistException", ()))]  # a watcher: may never end
    return st.one_of(*calls)


def random_missions(grid: bool, calls: int) -> st.SearchStrategy[ast.Mission]:
    leaf = timer_calls(grid) if grid else st.one_of(
        timer_calls(False), timer_calls(False), S.ictineu_calls(with_params=False))
    return st.builds(ast.Mission, st.none(), S.bodies(leaf, 3, calls))


class Track:
    """When the mission ended; and whether the player stopped it itself (a Zeno loop): such
    a run is not one the bounds speak of."""

    def __init__(self) -> None:
        self.aborted = False
        self.ended: float | None = None

    def __call__(self, record: Record) -> None:
        if record.kind == "note" and "abort" in record.data.get("note", "").lower():
            self.aborted = True
        if record.kind == "status" and record.data.get("status") in ("ok", "fail"):
            self.ended = record.t


def waiting(net: Net, player: Player) -> list[str]:
    return sorted({tr.event for t, tr in enumerate(net.transitions)
                   if tr.event not in (None, MISSION_ABORT) and player.enabled(t)})


@pytest.mark.slow
@settings(max_examples=150, deadline=None,
          suppress_health_check=[HealthCheck.too_slow, HealthCheck.filter_too_much,
                                 HealthCheck.data_too_large])
@given(mission=random_missions(grid=False, calls=7), data=st.data())
def test_every_run_lies_inside_the_bounds(mission: ast.Mission, data: st.DataObject) -> None:
    text = printer.mission(mission)
    compiled = compile_source(Source("random.mcl", text))
    d = analyse(compiled.checked)
    net = compiled.net
    player = Player(net)
    track = Track()
    player.observers.append(track)
    player.start(0.0)
    now = 0.0
    for _ in range(60):  # steps of the environment
        if player.finished:
            break
        events = waiting(net, player)
        deadline = player.next_deadline()
        gap = None if deadline is None else max(0.0, deadline - now)
        delays = [st.sampled_from([0.0, 0.5, 1.0, 30.0]), st.floats(0, 900)]
        if gap is not None:  # at, just before, or well before a deadline
            delays.append(st.sampled_from([gap, max(0.0, gap - 5e-10), gap / 2]))
        now += data.draw(st.one_of(*delays), label="delay")
        send: bool = data.draw(st.booleans(), label="event?")
        if events and send:
            player.handle_event(data.draw(st.sampled_from(events), label="event"), now)
        else:
            player.settle(now)
    assume(not track.aborted)
    slack = 1e-6
    if player.finished:
        assert track.ended is not None
        end = track.ended
        event("ended")
        assert d.best - slack <= end <= d.worst + slack, (text, end, d.best, d.worst)
        assert player.status in d.ends, (text, player.status, d.ends)
        lo, hi = d.ends[player.status]
        assert lo - slack <= end <= hi + slack, (text, player.status, end, lo, hi)
    else:
        event("still running")
        assert now <= d.worst + slack, (text, now, d.worst)


# -- 2. exhaustive search on a grid, and the state-class graph ------------------------------
def grid_extremes(net: Net, horizon: int = 40) -> tuple[float, float, set[str], bool]:
    """The shortest and longest run of the player over every choice of events at whole
    seconds (an event may come at any instant of the grid, before or after the timers due
    then, several in one instant), the ways the mission ends, and whether some run was
    stopped by the player's Zeno guard. A run still going at ``horizon`` s is unbounded."""
    memo: dict[Any, tuple[float, float]] = {}
    statuses: set[str] = set()
    on_stack: set[Any] = set()
    zeno = [False]

    def key(p: Player, now: float) -> Any:
        return (tuple(p.marking), tuple(sorted((t, round(now - s, 6))
                                               for t, s in p.enabled_since.items())))

    def clone(p: Player) -> Player:
        return copy.deepcopy(p, {id(net): net, id(p.rules): p.rules})

    def search(p: Player, now: float) -> tuple[float, float]:
        if p.finished:
            statuses.add(p.status)
            track = p.observers[0]
            assert isinstance(track, Track)
            zeno[0] = zeno[0] or track.aborted
            return 0.0, 0.0
        if now >= horizon:
            return INF, INF
        k = key(p, now)
        if k in memo:
            return memo[k]
        if k in on_stack:  # the same state again after time passed: it can last for ever
            return INF, INF
        on_stack.add(k)
        results: list[tuple[float, float]] = []
        for e in waiting(net, p):  # an event now (before the timers due now: the tie rule)
            q = clone(p)
            q.handle_event(e, now)
            if key(q, now) != k or q.finished:
                results.append(search(q, now))
        q = clone(p)
        q.settle(now)  # the timers due now fire; events may still come in this instant
        if key(q, now) != k or q.finished:
            results.append(search(q, now))
        due = p.next_deadline()
        if due is None or due > now + 1e-9:  # a second passes (timers due now fire first)
            q = clone(p)
            q.settle(now + 1, before=True)
            lo, hi = search(q, now + 1)
            results.append((lo + 1, hi + 1))
        on_stack.discard(k)
        out = (min(r[0] for r in results), max(r[1] for r in results))
        memo[k] = out
        return out

    player = Player(net)
    player.observers.append(Track())
    player.start(0.0)
    lo, hi = search(player, 0.0)
    return lo, hi, statuses, zeno[0]


@settings(max_examples=60, deadline=None,
          suppress_health_check=[HealthCheck.too_slow, HealthCheck.filter_too_much,
                                 HealthCheck.data_too_large])
@given(mission=random_missions(grid=True, calls=4))
def test_small_missions_agree_with_an_exhaustive_search(mission: ast.Mission) -> None:
    text = printer.mission(mission)
    compiled = compile_source(Source("small.mcl", text))
    d = analyse(compiled.checked)
    net = compiled.net
    lo, hi, statuses, zeno = grid_extremes(net)
    assume(not zeno)  # the player's own guard stopped a Zeno loop (mclc refuses those)
    assert d.best <= lo + 1e-6, (text, d.best, lo)
    assert hi <= d.worst + 1e-6 or (hi == INF and d.worst == INF), (text, d.worst, hi)
    # the worst case is attained (or unbounded both ways) on these missions
    event("worst attained" if hi == d.worst else "worst not attained")
    assert statuses <= set(d.ends), (text, statuses, d.ends)
    space = explore_timed(net, max_classes=20_000)
    if space.complete:
        ok_place = next(p for p, pl in enumerate(net.places) if pl.name == "MISSION.ok")
        fail_place = next(p for p, pl in enumerate(net.places) if pl.name == "MISSION.fail")
        reached = set()
        if space.markings[:, ok_place].any():
            reached.add("ok")
        if space.markings[:, fail_place].any():
            reached.add("fail")
        # the grid search is a set of the time Petri net's runs ...
        assert statuses <= reached, (text, statuses, reached)
        # ... and the net's every ending is allowed by the bounds. (Not so with a 0 s timer:
        # the player fires it in the very step that arms it, before any event; the time
        # Petri net lets an event come first in that instant.)
        if all(tr.timer != 0 for tr in net.transitions):
            assert reached <= set(d.ends), (text, reached, d.ends)


# -- 3. through a real mclc ---------------------------------------------------------------
DAM = str(MISSIONS / "dam_inspection.mcl")


def test_mclc_deadline_fails_with_the_critical_path() -> None:
    proc = cli("mclc", DAM, "--no-verify", "--deadline", "45min")
    assert proc.returncode == 1, proc.stderr
    assert "some run can take 5580 s = 93 min" in proc.stdout
    assert "line 39: WallInspect([path])" in proc.stdout
    ok = cli("mclc", DAM, "--no-verify", "--deadline", "2h")
    assert ok.returncode == 0, ok.stdout + ok.stderr
    assert "holds for every run" in ok.stdout


# the follow loop of missions/pipeline_inspection.mcl before a Timeout raced it (issue 21)
UNBOUNDED_FOLLOW = """PARAM speed = 0.5;
PARAM length = 45 m;
PARAM width = 6 m;
MISSION follow {
    WHILE {
        IF { FollowPipe(speed, length) } THEN { Timeout(0 s) } ELSE { Wait(0 s) }
    } DO {
        SearchLine(width)
    }
}
"""


def test_mclc_names_what_leaves_a_mission_unbounded(tmp_path: Path) -> None:
    proc = cli("mclc", str(write(tmp_path, UNBOUNDED_FOLLOW)), "--no-verify",
               "--tasks", str(MISSIONS / "seabed.tasks"), "--deadline", "1h")
    assert proc.returncode == 1, proc.stderr
    assert "some run can last for ever" in proc.stdout
    assert "line 6: FollowPipe(speed, length) waits for FollowPipeline.lost" in proc.stdout
    assert "line 5: WHILE" in proc.stdout  # the loop is named too
    raced = cli("mclc", str(MISSIONS / "pipeline_inspection.mcl"), "--no-verify",
                "--deadline", "1h")  # the shipped mission races its loop with a Timeout
    assert raced.returncode == 0, raced.stdout + raced.stderr
    assert "holds for every run" in raced.stdout


def test_mclc_json_junit_and_sarif_carry_the_bounds() -> None:
    proc = cli("mclc", DAM, "--no-verify", "--deadline", "45min", "--json")
    assert proc.returncode == 1
    report = json.loads(proc.stdout)
    assert report["duration"]["worst"] == 5580 and report["duration"]["best"] == 0
    assert report["duration"]["deadline"] == {"seconds": 2700, "holds": False}
    assert [s["line"] for s in report["duration"]["critical_path"]][:3] == [32, 34, 35]
    assert report["duration"]["estimate"]["label"] == "estimate (not proved)"
    junit = cli("mclc", DAM, "--no-verify", "--deadline", "45min", "--format", "junit")
    assert junit.returncode == 1 and '<testcase classname' in junit.stdout
    assert 'name="deadline"' in junit.stdout and "<failure" in junit.stdout
    sarif = json.loads(cli("mclc", DAM, "--no-verify", "--deadline", "45min",
                           "--format", "sarif").stdout)
    results = [r for r in sarif["runs"][0]["results"] if r["ruleId"] == "deadline"]
    assert results and results[0]["level"] == "error"
    assert results[0]["locations"][0]["physicalLocation"]["region"]["startLine"] == 39


def test_mclc_battery_and_reserve(tmp_path: Path) -> None:
    proc = cli("mclc", DAM, "--no-verify", "--battery", "800Wh", "--reserve", "20%")
    assert proc.returncode == 0, proc.stdout + proc.stderr
    assert "margin" in proc.stdout
    low = cli("mclc", DAM, "--no-verify", "--battery", "300Wh", "--reserve", "20%", "--json")
    assert low.returncode == 1
    battery = json.loads(low.stdout)["duration"]["battery"]
    assert battery["holds"] is False and battery["usable_wh"] == pytest.approx(240)
    watcher = write(tmp_path, "MISSION { Alarms() }")
    unbounded = cli("mclc", str(watcher), "--no-verify", "--battery", "1000Wh")
    assert unbounded.returncode == 1 and "unbounded" in unbounded.stdout


@pytest.mark.parametrize("args", [["--deadline=-5min"], ["--deadline", "nan"],
                                  ["--deadline", "45"], ["--battery=-1Wh"],
                                  ["--battery", "800Wh", "--reserve", "150%"],
                                  ["--reserve", "20%"]])
def test_mclc_refuses_bad_values_in_one_line(args: list[str]) -> None:
    proc = cli("mclc", DAM, "--no-verify", *args)
    assert proc.returncode == 2
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("mclc: error: --"), proc.stderr
    assert "Traceback" not in proc.stderr


def test_a_vehicle_scripted_from_the_critical_path_attains_the_worst_case() -> None:
    """The dam mission on the player with a vehicle that does what the critical path says:
    each task's event just before its timeout, and a CATCH's event just before the TRY would
    end. The run lasts the worst case, to within the margins taken."""
    compiled = compile_file(str(MISSIONS / "dam_inspection.mcl"))
    d = analyse(compiled.checked)
    library = compiled.checked.library
    eps = 1e-3
    script: list[tuple[float, str]] = []
    now = 0.0
    path = list(d.critical_path)
    for i, step in enumerate(path):
        if step.seconds == 0:
            continue
        now += step.seconds - eps
        following = path[i + 1:]
        catch = following[0] if following and following[0].text.startswith("CATCH") else None
        if catch is None and following and following[0].seconds == 0:
            # zero-time steps in between (StartCamera(disable)): the CATCH may come after them
            catch = next((s for s in following if s.seconds or s.text.startswith("CATCH")),
                         None)
            catch = catch if catch is not None and catch.text.startswith("CATCH") else None
        if catch is not None:
            name = catch.text.removeprefix("CATCH ").split("(")[0]
            form = library.tasks[name][0]
            script.append((now, (form.fail or form.ok)[0]))
        else:
            script.append((now, step.ending.split(" on ")[1].split()[0]))
    player = Player(compiled.net)
    track = Track()
    player.observers.append(track)
    player.start(0.0)
    for when, name in script:
        player.handle_event(name, when)
    assert player.finished and track.ended is not None, script
    assert d.worst - 10 * eps <= track.ended <= d.worst
    assert track.ended == pytest.approx(93 * 60, abs=0.01)
