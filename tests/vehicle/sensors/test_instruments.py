"""vehicle/sensors/instruments.py: the sensor bundle (the sensors themselves are exercised at
their rates in tests/vehicle/world/test_robot.py)."""

from __future__ import annotations

import dataclasses
from typing import Any

import numpy as np
import pytest

from vehicle.sensors.instruments import Sensors
from vehicle.sensors.readings import SonarBeam
from vehicle.world.robot import Environment, VehicleState


def _readings(sensors: Sensors, truth: VehicleState) -> list[Any]:
    return [r for k in range(200) for r in sensors.sample(0.1 * k, truth)]


def _values(readings: list[Any]) -> list[tuple[Any, ...]]:
    """Readings as plain values (a USBL fix holds arrays, which == does not compare)."""
    return [(type(r).__name__, *(v.tolist() if isinstance(v, np.ndarray) else v
                                 for v in dataclasses.astuple(r))) for r in readings]


def test_a_sensor_removed_leaves_the_others_readings_unchanged() -> None:
    env, truth = Environment(), VehicleState(-1.5, 7.5, 4.0, 0.0, 0.2)
    full, bare = Sensors(env, np.random.default_rng(3)), Sensors(env, np.random.default_rng(3))
    bare.remove(bare.sonar)
    with_sonar, without = _readings(full, truth), _readings(bare, truth)
    assert any(isinstance(r, SonarBeam) for r in with_sonar)
    assert not any(isinstance(r, SonarBeam) for r in without)
    # each sensor draws from its own stream: the others read exactly as before, noise included
    assert _values(without) == _values([r for r in with_sonar if not isinstance(r, SonarBeam)])
    assert bare.sonar not in bare.all and len(bare.all) == len(full.all) - 1
    with pytest.raises(ValueError):
        bare.remove(bare.sonar)  # not in the bundle any more
