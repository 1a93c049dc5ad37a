"""The structural route (templates verified with generic children + static analysis) against
the explicit one (every reachable marking) on random missions small enough for both.

The static analysis over-approximates: every violation the explicit search finds must be
reported by it too. A false alarm is allowed, but counted: the test reports the rate."""

from __future__ import annotations

from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
import pytest

from mcl import ast, printer

from mcl.analysis import structural
from mcl.api import compile_source
from diagnostics import Source
from mcl.tasklib import load_sources
from petri.net import Origin
from mcl.analysis.verification import verify_mission
from tests.support import single_missions

DOF_TASKS = """
behaviour Mx  drives x     events ok, fail;
behaviour Mz  drives z     events ok, fail;
behaviour Mxz drives x, z  events ok, fail;
behaviour Hold drives x;
behaviour Lamp;
task Gx()  { start: enable Mx;  ok: Mx.ok;  fail: Mx.fail;  stop: disable Mx; }
task Gz()  { start: enable Mz;  ok: Mz.ok;  fail: Mz.fail;  stop: disable Mz; }
task Gxz() { start: enable Mxz; ok: Mxz.ok; fail: Mxz.fail; stop: disable Mxz; }
task W()   { ok: Mx.ok; fail: Mz.fail; }
task Hold(enable)  { start: enable Hold;  latch: Hold; }
task Hold(disable) { start: disable Hold; unlatch: Hold; }
task Lamp(enable)  { start: enable Lamp;  latch: Lamp; }
task Lamp(disable) { start: disable Lamp; unlatch: Lamp; }
"""
LIBRARY = load_sources([Source("dof.tasks", DOF_TASKS)])
WORD = {"Hold+": ("Hold", "enable"), "Hold-": ("Hold", "disable"),
        "Lamp+": ("Lamp", "enable"), "Lamp-": ("Lamp", "disable")}


def call(name: str) -> ast.Call:
    if name in WORD:
        task, word = WORD[name]
        return ast.Call(task, (ast.Arg(ast.Ref(word)),))
    return ast.Call(name, ())


calls = st.sampled_from(["Gx", "Gz", "Gxz", "W", "Hold+", "Hold-", "Lamp+", "Lamp-"]).map(call)


def blocks(depth: int) -> st.SearchStrategy[ast.Block]:
    if depth == 0:
        return calls
    inner = blocks(depth - 1)
    seq = st.lists(inner, min_size=2, max_size=3).map(
        lambda items: ast.Sequence(tuple(i for it in items for i in
                                         (it.items if isinstance(it, ast.Sequence) else (it,)))))
    return st.one_of(
        calls, seq,
        st.tuples(inner, inner, inner).map(lambda t: ast.TryCatchDo(*t)),
        st.lists(inner, min_size=2, max_size=2).map(lambda b: ast.ParallelAnd(tuple(b))),
        st.lists(inner, min_size=2, max_size=2).map(lambda b: ast.ParallelOr(tuple(b))),
        st.tuples(inner, inner, st.none() | inner).map(lambda t: ast.IfThenElse(*t)),
        st.tuples(inner, inner).map(lambda t: ast.WhileDo(*t)),
    )


STATS = {"runs": 0, "false_alarms": 0}


@pytest.mark.slow
@settings(max_examples=200, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(blocks(2))
def test_structural_misses_no_violation(body: ast.Block) -> None:
    text = printer.mission(ast.Mission(None, body))
    compiled = compile_source(Source("r.mcl", text), library=LIBRARY)
    explicit = verify_mission(compiled, "explicit", max_markings=400_000)
    if not all(r.holds for r in explicit.results if r.name == "complete"):
        return  # too large to be the reference
    static = structural.analyse(compiled.checked)
    e = {r.name: r.holds for r in explicit.results}
    s = {r.name: r.holds for r in static.results}
    for prop in ("dof-exclusive", "behaviours-off-at-end", "behaviour-single-owner",
                 "no-disable-while-held"):
        if not e[prop]:
            assert not s[prop], f"{prop} violated but the static analysis missed it:\n{text}"
        elif not s[prop]:
            STATS["false_alarms"] += 1
    for prop in ("one-safe", "no-deadlock", "proper-completion", "stop-safe"):
        assert e[prop] and s[prop], text
    # termination is decided exactly, not assumed: a WHILE of tasks that cannot fail never
    # ends (before issue 11 the model let the environment stop the mission, so this asserted
    # that every random mission ends)
    for prop in ("terminates", "can-end", "no-zeno"):
        assert e[prop] == s[prop], f"{prop}: explicit {e[prop]}, structural {s[prop]}\n{text}"
    STATS["runs"] += 1


@pytest.mark.slow
def test_structural_agrees_with_explicit_on_the_shipped_missions() -> None:
    for path in single_missions():
        compiled = compile_source(Source(str(path), path.read_text()))
        explicit = {r.name: r.status for r in verify_mission(compiled, "explicit").results}
        static = {r.name: r.status for r in structural.analyse(compiled.checked).results}
        for prop, status in static.items():
            if prop != "no-dead-transitions":
                assert status == explicit[prop], (path, prop)


def test_a_template_that_fails_with_generic_children_fails_the_structural_route() -> None:
    """If a template were broken, 'by construction' must not claim anything."""
    from mcl.templates import common

    original = common.Context.absorb

    def absorb_without_late(self: common.Context, child: common.Interface, waiting: int,
                            done: list[int], name: str, origin: Origin) -> None:
        self.transition(f"{name}.stopped", [waiting, child.aborted], done, "stopped", origin)

    structural.template_check.cache_clear()
    common.Context.absorb = absorb_without_late  # type: ignore[method-assign]
    try:
        compiled = compile_source(Source("t.mcl", "MISSION { TRY { GoTo((0,0,1,0)) } CATCH "
                                         "{ Alarms() } DO { Surface() } }"))
        verdict = structural.analyse(compiled.checked)
    finally:
        common.Context.absorb = original  # type: ignore[method-assign]
        structural.template_check.cache_clear()
    assert not verdict.ok
    assert "a template fails with generic children" in verdict.results[0].message
    # and it proves nothing wrong with the mission either: undecided, not failing
    assert verdict.results[0].status == "undecided" and not verdict.failed


@pytest.mark.slow
def test_report_false_alarm_rate() -> None:
    """Not a check: prints how often the over-approximation raised a false alarm above."""
    print(f"structural false alarms: {STATS['false_alarms']} in {STATS['runs']} missions")
    assert STATS["false_alarms"] <= STATS["runs"]
