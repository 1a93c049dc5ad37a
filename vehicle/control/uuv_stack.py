"""The UUV's simulated stack (paper 003 §2, §4): compass, depth, camera, no positioning
sensor; its navigator fuses the fixes the ASV sends over the one-way modem.

The navigator is the EKF of §4 (:class:`vehicle.perception.uuv_navigator.UuvNavigator`, or
any object with :class:`Navigation`'s methods), run at the control loop's 10 Hz: every tick
its prediction under the last thrust with the compass and the depth, the camera's sightings
near the mine (no delay), and each heard ``fix`` with its ping time (the depth at the ping is
the navigator's to keep, §4.1). A heard ``release`` lets the UUV go from under the ASV and
tells it the mine's depth. Everything heard is kept for the figures (:attr:`heard_fixes`),
and so is the estimate (:attr:`estimates`).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any, Protocol

import numpy as np
import numpy.typing as npt

from behaviours.base import Perception
from behaviours.mcm import UUV, McmPerception
from vehicle.control.mcm_stack import DT, McmStack, McmWorld
from vehicle.perception.uuv_model import PSI, R, U, W, X, Y, Z
from vehicle.perception.uuv_navigator import SensorNoise, UuvNavigator
from vehicle.sensors.multibeam import SonarFix
from vehicle.sensors.uuv_sensors import UuvSensors

Array = npt.NDArray[np.float64]


class Navigation(Protocol):
    """What the UUV's stack asks of its navigator (times in s on the UUV's clock)."""

    def predict(self, t: float, tau: Sequence[float], compass: float | None,
                depth: float | None) -> None: ...
    def visual(self, t: float, rel_xy: Sequence[float], std: float | None = None) -> None: ...
    def fix(self, t_ping: float, R: float, eps: float, asv_xy: Sequence[float], t_now: float,
            *, asv_heading: float | None = None) -> bool: ...
    def estimate(self) -> tuple[Array, Array]: ...


def navigator(method: str = "repropagate") -> UuvNavigator:
    """The UUV's EKF with a delayed-fusion method ("naive", "repropagate", "larsen"), told
    the simulated sensors' noise."""
    return UuvNavigator(method, DT, sensors=SensorNoise(compass_std=math.radians(1.0),
                                                        depth_std=0.05))


class UuvStack(McmStack):
    """The UUV in the world: KeepDepth, FollowLine, Home, Land, Snapshot, Ascend."""

    classes = UUV
    gains = (60.0, 80.0, 5.0)

    def __init__(self, world: McmWorld, seed: int = 1,
                 navigation: Navigation | None = None) -> None:
        super().__init__(world, world.uuv)
        self.sensors = UuvSensors(world.scene, np.random.default_rng([seed, 11]))
        self.navigator: Navigation = navigation or navigator()
        self.sighted_at = -math.inf
        self.fix_at = -math.inf
        self.fixes = 0
        self.mine_depth: float | None = None
        self.heard_fixes: list[tuple[float, SonarFix, bool]] = []  # heard at, fix, fused?
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
        fused = self.navigator.fix(fix.ping, fix.range, fix.bearing, (fix.x, fix.y), self.t,
                                   asv_heading=fix.heading)
        self.fix_at, self.fixes = t, self.fixes + 1
        self.heard_fixes.append((t, fix, fused))

    # -- sensing ---------------------------------------------------------------------------------
    def sense(self) -> None:
        s = self.body.state
        self.navigator.predict(self.t, self.tau, self.sensors.heading(s),
                               self.sensors.depth(s))
        if self.world.carried():
            return
        sighting = self.sensors.camera(self.t, s)
        if sighting is not None:
            self.navigator.visual(self.t, (sighting.x, sighting.y), sighting.sigma)
            self.sighted_at = self.t

    def move(self, tau: tuple[float, float, float]) -> None:
        if self.world.carried():
            return  # riding under the ASV: the ASV's stack moves it
        super().move(tau)

    def perception(self) -> Perception:
        x, _ = self.navigator.estimate()
        self.estimates.append((self.t, float(x[X]), float(x[Y])))
        return McmPerception(self.t, float(x[X]), float(x[Y]), float(x[Z]),
                             math.remainder(float(x[PSI]), 2 * math.pi), float(x[U]), 0.0,
                             float(x[W]), float(x[R]), sighted_at=self.sighted_at,
                             fix_at=self.fix_at, fixes=self.fixes,
                             mine_depth=self.mine_depth)

    def figures(self) -> dict[str, Any]:
        """The run against ground truth: how it ended, how far from the mine, the
        navigator's error in {T} from the first fix on (against the truth in the frame the ASV
        set), and what became of the fixes."""
        tx, ty, _ = self.world.scene.target
        s = self.body.state
        ended = {"Snapshot.taken": "landed, the mine in the snapshot",
                 "Snapshot.missed": "landed, the mine NOT in the snapshot",
                 "Ascend.surfaced": "ascended"}.get(
            next((f"{b}.{e}" for _, b, e in reversed(self.raised)), ""),
            "in the water" if self.world.released_at is not None else "not released")
        errors = self.navigation_errors()
        fused = sum(1 for _, _, ok in self.heard_fixes if ok)
        return {"ended": ended, "from the mine": f"{math.hypot(s.x - tx, s.y - ty):.2f} m",
                "navigator error": (f"{math.sqrt(sum(e * e for e in errors) / len(errors)):.2f}"
                                    f" m RMS, {max(errors):.2f} m at most") if errors else "-",
                "fixes heard": f"{len(self.heard_fixes)} ({fused} fused, "
                               f"{len(self.heard_fixes) - fused} refused by the gate)"}

    def navigation_errors(self) -> list[float]:
        """|estimate - truth| (m, horizontal, in {T}) at each tick from the first fix heard
        on (before it, the UUV does not know where it is, and knows it)."""
        origin = self.world.origin
        if not self.heard_fixes or origin is None:
            return []
        released = self.heard_fixes[0][0]
        truth = {round(t, 3): (x - origin[0], y - origin[1]) for t, x, y, _, _ in self.track}
        out = []
        for t, x, y in self.estimates:
            seen = truth.get(round(t, 3))
            if t >= released and seen is not None:
                out.append(math.hypot(x - seen[0], y - seen[1]))
        return out
