"""The mine countermeasures scene of paper 003: a flat seabed with a mine at a seeded position,
clutter on the bottom around it, a current and the water's visibility.

Frames (paper 003 §4, Table 1): the ASV navigates in the earth frame {E} (x north, y east, z
down, origin where the ASV starts); the UUV in the target frame {T}, the same axes with the
origin above the target, so the mine is at (0, 0, z) in {T} and its position is never sent.
The scene is chosen here, not in the paper (which gives no figures for it): the mine 25 to 35 m
from the ASV's start on a seabed 8 to 12 m deep, half a metre high; a dozen clutter echoes
(rocks, debris) 1.5 to 8 m from it; no current unless asked (``current=VX,VY``); visibility
4 m (the paper: "from ten to less than one meter").
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

MINE_HEIGHT = 0.5  # m above the bottom
CLUTTER_ECHOES = 12


@dataclass(frozen=True)
class MineField:
    """The seabed of one run, in {E} (m, z down); ``current`` (m/s, x and y) acts on both
    vehicles; ``visibility`` (m) is how far the UUV's camera sees the mine."""

    target: tuple[float, float, float]  # the mine's top: x, y, depth
    bottom: float  # m, the seabed's depth (flat)
    current: tuple[float, float] = (0.0, 0.0)
    visibility: float = 4.0
    clutter: tuple[tuple[float, float], ...] = ()  # echoes on the bottom, x, y in {E}

    def in_target_frame(self, x: float, y: float) -> tuple[float, float]:
        """A horizontal position of {E} in {T} (the frame centred above the mine)."""
        return x - self.target[0], y - self.target[1]

    def distance_to_target(self, x: float, y: float, z: float) -> float:
        """The straight-line distance (m) from a point of {E} to the mine's top."""
        tx, ty, tz = self.target
        return math.sqrt((x - tx) ** 2 + (y - ty) ** 2 + (z - tz) ** 2)


def mine_field(seed: int, current: tuple[float, float] = (0.0, 0.0),
               visibility: float = 4.0) -> MineField:
    """The scene of a seed: where the mine and the clutter lie, how deep the seabed is."""
    rng = np.random.default_rng([seed, 3])
    bottom = float(rng.uniform(8.0, 12.0))
    distance = float(rng.uniform(25.0, 35.0))
    direction = float(rng.uniform(-0.5, 0.5))  # rad off north
    tx, ty = distance * math.cos(direction), distance * math.sin(direction)
    clutter = []
    for _ in range(CLUTTER_ECHOES):
        r, a = float(rng.uniform(1.5, 8.0)), float(rng.uniform(-math.pi, math.pi))
        clutter.append((tx + r * math.cos(a), ty + r * math.sin(a)))
    return MineField((tx, ty, bottom - MINE_HEIGHT), bottom, current, visibility,
                     tuple(clutter))
