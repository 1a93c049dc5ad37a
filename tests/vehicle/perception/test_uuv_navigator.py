"""The UUV's navigator of paper 003 §4: the fix geometry of §4.1 against hand-computed cases,
the delayed-fusion methods of §4.3 against one another and against a filter that had each fix
on time, and the EKF's consistency (NEES) over many seeded approaches."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.stats import chi2

from tests.vehicle.perception.uuv_approach import (
    Approach,
    FixMessage,
    Run,
    errors,
    guess,
    navigate,
    simulate,
)
from vehicle.perception.sonar_fix import FixNoise, sonar_fix
from vehicle.perception.uuv_model import DIM, PSI, FloatArray, R, U, UuvModel, W, X, Y
from vehicle.perception.uuv_navigator import METHODS, UuvNavigator

# --- §4.1: the fix ----------------------------------------------------------------------------


def test_fix_geometry_by_hand() -> None:
    # R = 13 m, UUV 5 m below the head: horizontal range sqrt(169 - 25) = 12 m
    assert sonar_fix(13.0, 0.0, (3.0, 4.0), 5.0) == pytest.approx((15.0, 4.0))
    assert sonar_fix(13.0, math.pi / 2, (3.0, 4.0), 5.0) == pytest.approx((3.0, 16.0))
    # bearing 180 deg, ASV at (-1, 2), R = 5, depth 3: 4 m to the south (x down)
    assert sonar_fix(5.0, math.pi, (-1.0, 2.0), 3.0) == pytest.approx((-5.0, 2.0))
    # noise put R below the depth: the UUV is under the head
    assert sonar_fix(4.0, 1.0, (2.0, 1.0), 5.0) == pytest.approx((2.0, 1.0))


def test_fix_variance_grows_with_range() -> None:
    noise = FixNoise(range_std=0.3, bearing_std=0.01, asv_std=0.4)
    assert noise.variance(0.0) == pytest.approx(0.09 + 0.16)
    assert noise.variance(50.0) == pytest.approx(0.09 + 0.25 + 0.16)


def navigator_with_depths(sonar_depth: float = 0.0) -> UuvNavigator:
    """A navigator that read 5 m of depth up to t = 1 s and 12 m after (it dived)."""
    x0 = np.zeros(DIM)
    nav = UuvNavigator("repropagate", x0=x0, P0=np.eye(DIM) * 400.0, gate=None,
                       sonar_depth=sonar_depth)
    for k in range(31):
        t = 0.1 * k
        nav.predict(t, (0.0, 0.0, 0.0), 0.0, 5.0 if t <= 1.0 else 12.0)
    return nav


def test_the_fix_uses_the_depth_at_the_ping_not_the_depth_now() -> None:
    nav = navigator_with_depths()
    assert nav.fix(0.5, 13.0, 0.0, (3.0, 4.0), 3.0)
    fix = nav.last_fix
    assert fix is not None and fix.fused and fix.late_steps == 25
    assert fix.depth == 5.0 and fix.xy == pytest.approx((15.0, 4.0))
    # the same message pinged at 2 s, when the UUV was at 12 m: sqrt(169 - 144) = 5 m away
    nav.fix(2.0, 13.0, math.pi / 2, (3.0, 4.0), 3.0)
    assert nav.last_fix is not None and nav.last_fix.xy == pytest.approx((3.0, 9.0))


def test_the_bearing_in_the_head_adds_the_asv_heading_and_the_head_depth_is_subtracted() -> None:
    nav = navigator_with_depths(sonar_depth=1.0)
    nav.fix(0.5, 13.0, math.radians(60), (3.0, 4.0), 3.0, asv_heading=math.radians(30))
    assert nav.last_fix is not None and nav.last_fix.depth == 4.0
    assert nav.last_fix.xy == pytest.approx((3.0, 4.0 + math.sqrt(169.0 - 16.0)))


def test_a_fix_older_than_the_history_is_dropped_and_a_false_one_gated() -> None:
    nav = UuvNavigator("larsen", history=2.0, x0=np.zeros(DIM))
    for k in range(51):
        nav.predict(0.1 * k, (0.0, 0.0, 0.0), 0.0, 0.0)
    assert not nav.fix(1.0, 1.0, 0.0, (0.0, 0.0), 5.0)
    assert nav.fixes_too_old == 1 and nav.last_fix is not None
    assert nav.last_fix.reason == "too old"
    # a clutter echo 300 m off while the filter is sure it is within a few metres: gated
    P0 = np.eye(DIM) * 0.01
    nav = UuvNavigator("repropagate", x0=np.zeros(DIM), P0=P0)
    for k in range(21):
        nav.predict(0.1 * k, (0.0, 0.0, 0.0), 0.0, 0.0)
    x_before, _ = nav.estimate()
    assert not nav.fix(1.0, 300.0, 0.0, (0.0, 0.0), 2.0)
    assert nav.fixes_gated == 1 and nav.fixes_fused == 0
    np.testing.assert_array_equal(nav.estimate()[0], x_before)  # the echo changed nothing
    assert nav.fix(1.0, 0.5, 0.0, (0.0, 0.0), 2.0) and nav.fixes_fused == 1


def test_unknown_method_is_refused_with_the_choices() -> None:
    with pytest.raises(ValueError, match="naive, repropagate, larsen"):
        UuvNavigator("smoother")


# --- §4.3: delayed fusion ---------------------------------------------------------------------


class LinearModel:
    """A linear stand-in for eq. 3: the UUV model linearised once (no quadratic drag, the
    kinematics at u = 0.8 m/s, psi = -0.3 rad), x' = F x + G tau."""

    def __init__(self, dt: float = 0.1) -> None:
        base = UuvModel(beta_uu=0.0, beta_ww=0.0, beta_rr=0.0)
        x = np.zeros(DIM)
        x[U], x[PSI] = 0.8, -0.3
        self.F = base.jacobian(x, np.zeros(3), dt)
        self.G = np.zeros((DIM, 3))
        self.G[U, 0], self.G[W, 1], self.G[R, 2] = (dt / base.alpha_u, dt / base.alpha_w,
                                                    dt / base.alpha_r)
        self.Q = base.noise(dt)

    def step(self, x: FloatArray, tau: FloatArray, dt: float) -> FloatArray:
        out: FloatArray = self.F @ x + self.G @ tau
        return out

    def jacobian(self, x: FloatArray, tau: FloatArray, dt: float) -> FloatArray:
        return self.F

    def noise(self, dt: float) -> FloatArray:
        return self.Q


# fixes every second, 0.5 to 3 s late: fixes overlap (a ping before the last one arrives)
# and arrive out of order; a fifth are lost; the camera sees the UUV for its last 10 m
BUSY = Approach(fix_period=1.0, delay=(0.5, 3.0), loss=0.2, visibility=10.0)


def trajectory(run: Run, method: str, model: object | None = None) -> tuple[FloatArray, FloatArray]:
    nav = UuvNavigator(method, x0=guess(BUSY), model=model, gate=None)  # type: ignore[arg-type]
    return navigate(run, nav)


def test_the_run_has_overlapping_and_out_of_order_fixes() -> None:
    run = simulate(BUSY, 3)
    arrivals = [m for tick in run.ticks for m in tick.fixes]
    pings = [m.t_ping for m in arrivals]
    assert run.lost > 0 and len(arrivals) > 20
    assert any(b < a for a, b in zip(pings, pings[1:]))  # out of order
    assert any(nxt.t_ping < m.t_now and nxt.t_now > m.t_now for m, nxt in zip(arrivals, arrivals[1:]))


@pytest.mark.parametrize("seed", [3, 4])
def test_larsen_equals_repropagation_on_a_linear_model(seed: int) -> None:
    run = simulate(BUSY, seed)
    model = LinearModel()
    x_re, P_re = trajectory(run, "repropagate", model)
    x_la, P_la = trajectory(run, "larsen", model)
    x_na, _ = trajectory(run, "naive", model)
    assert np.max(np.abs(x_la - x_re)) < 1e-8
    assert np.max(np.abs(P_la - P_re)) < 1e-8
    # and the comparison can tell: the naive filter is metres away
    assert np.max(np.hypot(*(x_na - x_re)[:, [X, Y]].T)) > 0.5


def on_time(run: Run) -> Run:
    """The same run with every fix delivered at its ping (what re-propagation must equal)."""
    by_ping: dict[float, list[FixMessage]] = {}
    for tick in run.ticks:
        for m in tick.fixes:
            by_ping.setdefault(round(m.t_ping, 6), []).append(m)
    ticks = []
    for tick in run.ticks:
        fixes = [FixMessage(m.t_ping, m.t_ping, m.slant_range, m.bearing, m.asv_xy)
                 for m in by_ping.get(round(tick.t, 6), [])]
        ticks.append(type(tick)(tick.t, tick.tau, tick.compass, tick.depth, tick.truth,
                                tick.visual, fixes))
    return Run(ticks, run.sent, run.lost)


def test_repropagation_is_the_ekf_that_had_every_fix_on_time() -> None:
    run = simulate(Approach(loss=0.3), 5)
    last_arrival = max(i for i, tick in enumerate(run.ticks) if tick.fixes)
    x_re, P_re = trajectory(run, "repropagate")
    x_ot, P_ot = trajectory(on_time(run), "repropagate")
    np.testing.assert_allclose(x_re[last_arrival:], x_ot[last_arrival:], atol=1e-9)
    np.testing.assert_allclose(P_re[last_arrival:], P_ot[last_arrival:], atol=1e-9)
    # Larsen's linear correction on the EKF: close to it, not equal
    x_la, _ = trajectory(run, "larsen")
    gap = np.hypot(*(x_la - x_re)[last_arrival:, [X, Y]].T)
    assert 0.0 < gap.max() < 0.05


def test_the_naive_filter_lags_by_about_the_distance_of_one_delay() -> None:
    run = simulate(Approach(delay=(2.0, 2.0)), 6)
    after = [i for i, tick in enumerate(run.ticks) if tick.t > 20.0 and tick.visual is None]
    error = {m: np.hypot(*errors(run, trajectory(run, m)[0])[after][:, [X, Y]].T)
             for m in METHODS}
    speed = float(np.mean([run.ticks[i].truth[U] for i in after]))
    assert np.median(error["repropagate"]) < 0.6
    assert np.median(error["naive"]) - np.median(error["repropagate"]) > 0.4 * speed * 2.0


# --- consistency ------------------------------------------------------------------------------

SEEDS = 20


def average_nees(method: str) -> FloatArray:
    """The normalised estimation error squared at each step, averaged over SEEDS runs of the
    filter's own model (exact truth, fixes 1.5-2.5 s late, a third lost)."""
    a = Approach(duration=25.0, arrive_within=0.0, loss=0.3)
    runs = []
    for seed in range(SEEDS):
        run = simulate(a, seed, exact=True)
        xs, Ps = navigate(run, UuvNavigator(method, x0=guess(a), gate=None))
        e = errors(run, xs)
        runs.append(np.einsum("ki,kij,kj->k", e, np.linalg.inv(Ps), e))
    avg: FloatArray = np.mean(runs, axis=0)
    return avg


@pytest.mark.slow
def test_nees_within_its_chi_square_bounds_and_the_naive_filter_outside() -> None:
    lo, hi = chi2.ppf([0.005, 0.995], DIM * SEEDS) / SEEDS
    for method in ("repropagate", "larsen"):
        nees = average_nees(method)
        inside = np.mean((nees >= lo) & (nees <= hi))
        assert inside > 0.9, (method, inside)
        assert lo < nees.mean() < hi, (method, nees.mean())
    naive = average_nees("naive")
    assert naive.mean() > hi  # the late fix taken as current: overconfident
