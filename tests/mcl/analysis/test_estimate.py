"""The nominal estimate (mcl/analysis/estimate.py) costs a polynomial of the mission's size.

Issue 21: a 26-line random mission (a WHILE inside a PARALLEL OR inside a WHILE) had not
answered after 5 minutes: the estimate walked each WHILE up to 10,000 laps, nested. Checked
here: on WHILE / PARALLEL OR nests up to 6 deep the estimate answers, and the work it reports
(``Nominal.steps``, blocks entered) stays under 3 N (P + 2)² + 1 for N blocks and P task calls
(each block is walked once per point the vehicle may have been sent to, a WHILE at most P + 2
laps); on random missions it equals a lap-by-lap walk of every WHILE (the old way, capped).
"""

from __future__ import annotations

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from diagnostics import Source
from mcl import ast, printer
from mcl.analysis.estimate import Nominal, Outcome
from mcl.api import compile_source
from mcl.checker import Checked
from tests import strategies as S


def nested(depth: int, inner: str = "GoTo((1, 2, 3, 0))") -> str:
    """``depth`` WHILEs, each holding a PARALLEL OR that holds the next one: every lap ends
    (the OR's Wait), but no WHILE ever stops nominally."""
    body = inner
    for i in range(depth):
        body = f"WHILE {{ Wait(1 s) }} DO {{ PARALLEL {{ {body} }} OR {{ Wait({i + 2} s) }} }}"
    return f"MISSION m {{ {body} }}"


def work_bound(body: ast.Block) -> int:
    blocks = len(ast.walk(body))
    calls = len(ast.calls(body))
    return 3 * blocks * (calls + 2) ** 2 + 1


def nominal(checked: Checked) -> tuple[Nominal, float | None, list[str]]:
    n = Nominal(checked)
    seconds, notes = n.mission(checked.mission.body)
    return n, seconds, notes


@pytest.mark.parametrize("depth", [1, 2, 3, 6])
def test_nested_whiles_are_estimated_with_polynomial_work(depth: int) -> None:
    checked = compile_source(Source("m.mcl", nested(depth))).checked
    n, seconds, notes = nominal(checked)
    assert seconds is None  # the outermost WHILE goes round for ever
    assert notes[-1] == "line 1: WHILE goes round for ever nominally"
    assert len(notes) == len(set(notes))  # each note once, however many laps
    assert 0 < n.steps <= work_bound(checked.mission.body)


def test_a_loop_that_ends_after_laps_is_estimated_lap_by_lap() -> None:
    # lap 1: 1 m to (1, 0, 0) at 0.4 m/s (2.5 s, within the 5 s timeout), then 4 m on;
    # lap 2: 4 m back takes 10 s: the 5 s timeout fails the condition and the loop ends ok
    text = ("MISSION m { WHILE { GoTo((1, 0, 0, 0), timeout = 5 s) } "
            "DO { GoTo((5, 0, 0, 0)) } }")
    checked = compile_source(Source("m.mcl", text)).checked
    n, seconds, _ = nominal(checked)
    assert seconds == pytest.approx(2.5 + 10 + 5)
    assert seconds == LapByLap(checked).mission(checked.mission.body)[0]
    assert n.steps <= work_bound(checked.mission.body)


class LapByLap(Nominal):
    """The old walk: no memo, every WHILE lap after lap up to ``MAX_LAPS`` (then: for ever).
    Exponential in the nesting: only for small missions."""

    MAX_LAPS = 40

    def block(self, b: ast.Block) -> Outcome:
        self.steps += 1
        return self.walk(b)

    def while_do(self, w: ast.WhileDo) -> Outcome:
        total = 0.0
        for _ in range(self.MAX_LAPS):
            rc = self.block(w.condition)
            if rc is None:
                return None
            total += rc[1]
            if rc[0] == "fail":
                return "ok", total
            rb = self.block(w.body)
            if rb is None:
                return None
            total += rb[1]
            if rb[0] == "fail":
                return "fail", total
        self.notes.append(f"line {w.span.line}: WHILE goes round for ever nominally")
        return None


@pytest.mark.slow
@settings(max_examples=150, deadline=None, derandomize=True,
          suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])
@given(mission=S.ictineu_missions(max_depth=2, max_calls=7, with_params=False))
def test_the_estimate_equals_a_lap_by_lap_walk(mission: ast.Mission) -> None:
    checked = compile_source(Source("random.mcl", printer.mission(mission))).checked
    n, seconds, notes = nominal(checked)
    old = LapByLap(checked)
    old_seconds, old_notes = old.mission(checked.mission.body)
    assert seconds == old_seconds
    assert notes == list(dict.fromkeys(old_notes))
    assert n.steps <= work_bound(checked.mission.body)


@pytest.mark.slow
@settings(max_examples=60, deadline=None, derandomize=True,
          suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])
@given(mission=S.ictineu_missions(max_depth=6, max_calls=16, with_params=False),
       wrap=st.integers(0, 3))
def test_deep_random_missions_cost_a_polynomial(mission: ast.Mission, wrap: int) -> None:
    text = printer.mission(mission)
    inner = text[text.index("{") + 1:text.rindex("}")]
    checked = compile_source(Source("random.mcl", nested(wrap, inner))).checked
    n, _, _ = nominal(checked)
    assert n.steps <= work_bound(checked.mission.body)
