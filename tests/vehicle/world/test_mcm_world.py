"""Paper 003's world: the seeded mine field and the dynamics of eq. 2."""

from __future__ import annotations

import math

import numpy as np
import pytest

from vehicle.world.mcm_bodies import UUV_MODEL, Body, BodyState, Dof
from vehicle.world.mine_field import mine_field


def test_the_mine_lies_where_the_seed_puts_it() -> None:
    a, b, c = mine_field(4), mine_field(4), mine_field(5)
    assert a == b and a.target != c.target
    tx, ty, tz = a.target
    assert 25.0 <= math.hypot(tx, ty) <= 35.0 and tz == pytest.approx(a.bottom - 0.5)
    assert all(1.5 <= math.hypot(x - tx, y - ty) <= 8.0 for x, y in a.clutter)
    assert a.in_target_frame(tx + 1.0, ty - 2.0) == pytest.approx((1.0, -2.0))


def test_eq_2_settles_where_damping_meets_the_thrust() -> None:
    dof = Dof(alpha=40.0, beta_v=6.0, beta_vv=40.0, limit=30.0)
    v = 0.0
    for _ in range(2000):
        v += 0.01 * dof.acceleration(v, 20.0)
    # 6 v + 40 v^2 = 20  ->  v = (-6 + sqrt(36 + 3200)) / 80
    assert v == pytest.approx((-6.0 + math.sqrt(36.0 + 3200.0)) / 80.0, rel=1e-4)
    assert dof.acceleration(0.0, 100.0) == pytest.approx(30.0 / 40.0)  # the thrust's limit


def body(**kw: float) -> Body:
    return Body(UUV_MODEL, BodyState(0.0, 0.0, 5.0, 0.0), np.random.default_rng(1),
                noise=(0.0, 0.0, 0.0), bottom=10.0, **kw)  # type: ignore[arg-type]


def test_the_buoyancy_bias_lifts_an_idle_uuv_and_the_current_carries_it() -> None:
    b = body()
    for _ in range(300):
        b.step(0.1, (0.0, 0.0, 0.0), current=(0.2, -0.1))
    assert b.state.z < 4.0  # 1.5 N light: it rises
    assert b.state.x == pytest.approx(6.0, abs=1e-6) and b.state.y == pytest.approx(-3.0)


def test_the_seabed_stops_it() -> None:
    b = body()
    for _ in range(400):
        b.step(0.1, (10.0, 25.0, 0.0), current=(0.0, 0.0))
    assert b.state.z == 10.0 and b.on_bottom and b.state.u == 0.0
