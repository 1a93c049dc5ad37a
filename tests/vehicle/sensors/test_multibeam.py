"""The ASV's multibeam and the sonar fix of paper 003 §4.1 (eq. 3)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from vehicle.sensors.multibeam import Multibeam, SonarFix, fix_covariance, fix_position
from vehicle.world.mcm_bodies import BodyState
from vehicle.world.mine_field import MineField


def test_the_fix_geometry_of_eq_3_against_a_hand_computed_case() -> None:
    # ASV at (-10, 5) in {T}, heading 30 deg, the UUV at bearing 15 deg and slant range 13 m,
    # 5 m deep: horizontal range sqrt(13^2 - 5^2) = 12 m along 45 deg, so the UUV is at
    # (-10 + 12 cos 45, 5 + 12 sin 45) = (-1.51472, 13.48528)
    fix = SonarFix(13.0, math.radians(15.0), math.radians(30.0), -10.0, 5.0, ping=7.0)
    x, y = fix_position(fix, depth=5.0)
    assert x == pytest.approx(-1.51472, abs=1e-5)
    assert y == pytest.approx(13.48528, abs=1e-5)


def test_the_fix_needs_the_depth_at_the_ping_not_another() -> None:
    fix = SonarFix(13.0, 0.0, 0.0, 0.0, 0.0, ping=0.0)
    assert fix_position(fix, 5.0) == pytest.approx((12.0, 0.0))
    assert fix_position(fix, 2.0)[0] == pytest.approx(math.sqrt(13.0 ** 2 - 4.0))  # 12.85: off
    assert fix_position(fix, 20.0) == pytest.approx((0.0, 0.0))  # shorter than the depth


def test_a_fix_travels_as_six_numbers_and_comes_back() -> None:
    fix = SonarFix(13.25, 0.1234, -0.5, 3.5, -2.25, ping=12.5, echo="clutter")
    data = fix.payload()
    assert sorted(data) == ["R", "epsilon", "ping", "psi", "x", "y"]  # not the ground truth
    back = SonarFix.from_payload(data)
    assert (back.range, back.bearing, back.heading, back.x, back.y, back.ping) == \
        (13.25, 0.1234, -0.5, 3.5, -2.25, 12.5)
    with pytest.raises(KeyError):
        SonarFix.from_payload({"R": 1.0})


def test_the_covariance_grows_with_the_slant_range() -> None:
    near, far = (fix_covariance(SonarFix(r, 0.0, 0.0, 0.0, 0.0, 0.0)) for r in (5.0, 50.0))
    assert far[0][0] > near[0][0] > 0 and near[0][1] == 0.0


def scene() -> MineField:
    return MineField((30.0, 0.0, 9.5), 10.0, clutter=((27.0, 1.0), (26.0, -2.0)))


def sonar(**faults: float) -> Multibeam:
    return Multibeam(scene(), np.random.default_rng(1), sigma_range=0.0, sigma_bearing=0.0,
                     **faults)


def test_a_ping_measures_the_uuv_in_the_target_frame() -> None:
    asv = BodyState(0.0, 0.0, 0.0, 0.0)
    uuv = BodyState(12.0, 0.0, 5.0, 0.0)
    fix = sonar().ping(3.0, asv, uuv, origin=(30.0, 0.0))
    assert fix is not None and fix.echo == "uuv"
    assert fix.range == pytest.approx(13.0) and fix.bearing == pytest.approx(0.0)
    assert (fix.x, fix.y, fix.ping) == (-30.0, 0.0, 3.0)  # the ASV in {T}
    assert fix_position(fix, 5.0) == pytest.approx((12.0 - 30.0, 0.0))  # the UUV in {T}


def test_nothing_behind_the_sonar_head() -> None:
    asv = BodyState(0.0, 0.0, 0.0, math.pi)  # facing away
    assert sonar().ping(0.0, asv, BodyState(12.0, 0.0, 5.0, 0.0), (30.0, 0.0)) is None


def test_clutter_near_the_bottom_is_taken_for_the_uuv_from_the_fault_on() -> None:
    uuv = BodyState(26.5, 0.0, 7.0, 0.0)  # 3 m above the bottom
    quiet, faulty = sonar(), sonar(clutter_from=10.0)
    before = [faulty.pick(5.0, uuv)[0] for _ in range(200)]
    after = [faulty.pick(20.0, uuv)[0] for _ in range(200)]
    normal = [quiet.pick(20.0, uuv)[0] for _ in range(200)]
    assert before.count("clutter") == normal.count("clutter") == 0  # 3 m up: out of reach
    assert 80 < after.count("clutter") < 160  # 0.6 of the pings from the fault on


def test_a_false_target_near_the_mine_puts_the_uuv_on_it() -> None:
    asv = BodyState(0.0, 0.0, 0.0, 0.0)
    near, far = BodyState(26.0, 2.0, 4.0, 0.0), BodyState(15.0, 0.0, 4.0, 0.0)
    s = sonar(false_target_from=0.0)
    picks = [s.ping(1.0, asv, near, (30.0, 0.0)) for _ in range(100)]
    on_mine = [f for f in picks if f is not None and f.echo == "target"]
    assert 50 < len(on_mine) < 90
    # the UUV computes a position with its own depth: near the mine, not where it is
    x, y = fix_position(on_mine[0], 4.0)
    assert math.hypot(x, y) < 1.5 and math.hypot(x - (26.0 - 30.0), y - 2.0) > 3.0
    assert all(s.pick(1.0, far)[0] == "uuv" for _ in range(50))  # far from it: never
