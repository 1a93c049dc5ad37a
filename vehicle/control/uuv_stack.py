"""The UUV's simulated stack (paper 003 §2, §4): compass, depth, camera, no positioning
sensor; its navigator fuses the ASV's fixes heard over the one-way modem.

The navigator is any object with :class:`Navigation`'s methods: the EKF of
``vehicle/perception/uuv_navigator.py`` when it is given, else dead reckoning
(vehicle/perception/uuv_dead_reckoning.py). A heard ``fix`` (:meth:`UuvStack.heard`) goes to
it with its ping time (the depth at the ping is the navigator's to keep, §4.1); a heard
``release`` lets the UUV go from under the ASV and tells it the mine's depth. Everything heard is kept for the figures
(:attr:`heard_fixes`: the hearing time, the fix).
"""

from __future__ import annotations

import math
from typing import Any, Protocol

import numpy as np

from behaviours.base import Perception
from behaviours.mcm import UUV, McmPerception
from vehicle.control.mcm_stack import McmStack, McmWorld
from vehicle.perception.uuv_dead_reckoning import DeadReckoning
from vehicle.sensors.multibeam import SonarFix
from vehicle.sensors.uuv_sensors import TargetSighting, UuvSensors


class Navigation(Protocol):
    """What the UUV's stack asks of its navigator (times in s on the UUV's clock)."""

    def predict(self, t: float, tau: tuple[float, float, float]) -> None: ...
    def heading(self, t: float, psi: float) -> None: ...
    def depth(self, t: float, z: float) -> None: ...
    def sonar(self, t: float, fix: SonarFix) -> None: ...
    def camera(self, sighting: TargetSighting) -> None: ...
    def estimate(self) -> tuple[float, float, float, float, float, float, float]: ...


class UuvStack(McmStack):
    """The UUV in the world: KeepDepth, FollowLine, Home, Land, Snapshot, Ascend."""

    classes = UUV
    gains = (60.0, 80.0, 5.0)

    def __init__(self, world: McmWorld, seed: int = 1,
                 navigator: Navigation | None = None) -> None:
        super().__init__(world, world.uuv)
        self.sensors = UuvSensors(world.scene, np.random.default_rng([seed, 11]))
        self.navigator: Navigation = navigator or DeadReckoning(0.0, 0.0)
        self.sighted_at = -math.inf
        self.fix_at = -math.inf
        self.fixes = 0
        self.mine_depth: float | None = None
        self.heard_fixes: list[tuple[float, SonarFix]] = []
        self.estimates: list[tuple[float, float, float]] = []  # t, x, y in {T}

    # -- the modem ------------------------------------------------------------------------------
    def payload(self, channel: str, message: str, t: float) -> dict[str, Any]:
        return {}  # the UUV sends nothing (one way)

    def heard(self, channel: str, message: str, data: dict[str, Any], t: float) -> None:
        """A message heard at time t: ``release`` lets it go, a ``fix`` goes to the
        navigator (one without a detection in it, or unreadable, is ignored)."""
        if message == "release":
            self.world.release(t)
            depth = data.get("depth")
            if isinstance(depth, (int, float)) and math.isfinite(depth):
                self.mine_depth = float(depth)
            return
        if message != "fix":
            return
        try:
            fix = SonarFix.from_payload(data)
        except (KeyError, TypeError, ValueError):
            return
        self.navigator.sonar(t, fix)
        self.fix_at, self.fixes = t, self.fixes + 1
        self.heard_fixes.append((t, fix))

    # -- sensing ---------------------------------------------------------------------------------
    def sense(self) -> None:
        s = self.body.state
        self.navigator.predict(self.t, self.tau)
        self.navigator.heading(self.t, self.sensors.heading(s))
        self.navigator.depth(self.t, self.sensors.depth(s))
        if self.world.carried():
            return
        sighting = self.sensors.camera(self.t, s)
        if sighting is not None:
            self.navigator.camera(sighting)
            self.sighted_at = self.t

    def move(self, tau: tuple[float, float, float]) -> None:
        if self.world.carried():
            return  # riding under the ASV: the ASV's stack moves it
        super().move(tau)

    def perception(self) -> Perception:
        x, y, z, psi, u, w, r = self.navigator.estimate()
        self.estimates.append((self.t, x, y))
        return McmPerception(self.t, x, y, z, psi, u, 0.0, w, r, sighted_at=self.sighted_at,
                             fix_at=self.fix_at, fixes=self.fixes,
                             mine_depth=self.mine_depth)
