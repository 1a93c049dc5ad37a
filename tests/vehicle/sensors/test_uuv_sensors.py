"""The UUV's camera sees the mine within the visibility and in its cone, and gives the UUV's
position in {T} (paper 003 §4.2)."""

from __future__ import annotations

import math

import numpy as np

from vehicle.sensors.uuv_sensors import UuvSensors, sees
from vehicle.world.mcm_bodies import BodyState
from vehicle.world.mine_field import MineField

FIELD = MineField((30.0, 0.0, 9.5), 10.0, visibility=4.0)


def test_the_camera_sees_the_mine_ahead_within_the_visibility_only() -> None:
    assert sees(FIELD, BodyState(28.0, 0.0, 8.5, 0.0))  # 2.2 m ahead, below the bow
    assert not sees(FIELD, BodyState(24.0, 0.0, 8.5, 0.0))  # 6.1 m: beyond the visibility
    assert not sees(FIELD, BodyState(28.0, 0.0, 8.5, math.pi))  # behind it
    murky = MineField(FIELD.target, FIELD.bottom, visibility=1.0)
    assert not sees(murky, BodyState(28.0, 0.0, 8.5, 0.0))


def test_a_sighting_is_the_uuv_in_the_target_frame_at_the_camera_rate() -> None:
    sensors = UuvSensors(FIELD, np.random.default_rng(2))
    uuv = BodyState(28.0, 0.5, 8.5, 0.0)
    first = sensors.camera(0.0, uuv)
    assert first is not None
    assert math.hypot(first.x - (-2.0), first.y - 0.5) < 5 * first.sigma
    assert sensors.camera(0.1, uuv) is None  # 4 Hz: the next frame is at 0.25 s
    assert sensors.camera(0.25, uuv) is not None
