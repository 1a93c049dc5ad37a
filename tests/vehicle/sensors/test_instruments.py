"""vehicle/sensors/instruments.py: the sensor bundle (the sensors themselves are exercised at
their rates in tests/vehicle/world/test_robot.py)."""

from __future__ import annotations

import dataclasses
import math
from typing import Any

import numpy as np
import pytest

from vehicle.sensors.instruments import Msis, Sensors
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


def _beam_as_written(sonar: Msis, t: float, truth: VehicleState, bearing: float,
                     rng: np.random.Generator) -> np.ndarray:
    """A beam by the sonar's model, each ray's echo worked out and added in turn."""
    profile = sonar.near_level * np.exp(-sonar.r / (sonar.near_field / 3.0))
    first_echo = math.inf
    for offset, weight in zip(sonar.offsets.tolist(), sonar.weights.tolist()):
        phi = truth.psi + bearing + offset
        c, s = math.cos(phi), math.sin(phi)
        hit = sonar.env.ray_to_wall((truth.x, truth.y, truth.z), (c, s, 0.0))
        if hit is None or hit > sonar.max_range:
            continue
        nx, ny = sonar.env.wall_normal(truth.y + hit * s)
        if c * nx + s * ny < math.cos(sonar.incidence_limit):
            continue
        amplitude = sonar.wall_level * weight * (c * nx + s * ny)
        profile = profile + amplitude * np.exp(-0.5 * ((sonar.r - hit) / sonar.bin_size) ** 2)
        first_echo = min(first_echo, hit)
    k = 1.0 / sonar.speckle**2
    profile = profile * rng.gamma(k, 1.0 / k, sonar.r.size)
    sigma = np.where(sonar.r > first_echo + 3.0 * sonar.bin_size, 0.3, 1.0)
    sigma = sigma * sonar.background_level / math.sqrt(2.0)
    noise = rng.normal(0.0, 1.0, (2, sonar.r.size)) * sigma
    bins = np.hypot(profile + noise[0], noise[1])
    return np.asarray(np.round(np.clip(bins, 0.0, 1.0) * 255.0) / 255.0)


@pytest.mark.parametrize("curvature", [0.0, 0.02])
def test_a_sonar_beam_is_the_same_to_the_last_bit_as_its_model_written_out(
        curvature: float) -> None:
    """The sonar works out what every beam shares once and adds its rays' echoes as rows of
    one array: the beams are those of the model written ray by ray, wall near and far, seen
    square on, obliquely and not at all."""
    sonar, rng, ref = Msis(Environment(wall_curvature=curvature)), np.random.default_rng(5), \
        np.random.default_rng(5)
    poses = np.random.default_rng(6)
    echoes = 0
    for i in range(400):
        truth = VehicleState(-float(poses.uniform(0.5, 12.0)), float(poses.uniform(-2, 18)),
                             float(poses.uniform(0, 6)), float(poses.uniform(-3.1, 3.1)))
        beam = sonar.sample(0.05 * i, truth, rng)
        if beam is None:
            continue
        expected = _beam_as_written(sonar, 0.05 * i, truth, beam.bearing, ref)
        assert np.array_equal(beam.bins, expected), i
        echoes += bool(beam.bins.max() > 0.3)
    assert echoes > 20  # the wall was seen in many beams, not only the background
