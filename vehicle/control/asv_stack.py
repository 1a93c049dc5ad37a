"""The ASV's simulated stack (paper 003 §2): good navigation, the forward-looking multibeam,
the one-way modem's sending side.

The ASV knows where it is (GNSS-grade: 0.1 m, 0.5 deg). It starts with the mine where the
survey's map put it (2 m off, seeded) and reacquires it with the multibeam: once it has been
within 40 m and in view for three pings with the ASV steady, the mean of those echoes is the origin of {T}
(:attr:`AsvStack.origin`, with the sonar's own error). From then on every ping looks for the
UUV; the last detection is what a ``fix`` message carries (:meth:`payload`: R, epsilon, the
ASV's heading and position in {T}, the ping time, eq. 3). Every detection is kept
(:attr:`detections`) for the figures, with what the sonar really picked.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from behaviours.base import Perception
from behaviours.mcm import ASV, McmPerception
from vehicle.control.mcm_stack import McmStack, McmWorld
from vehicle.sensors.multibeam import Multibeam, SonarFix, fix_position

MAP_ERROR = 2.0  # m (1 sigma each way): the survey's position of the mine
REACQUIRE_RANGE = 40.0  # m: the multibeam sees the mine within this range
NAV_SIGMA = (0.1, math.radians(0.5))  # the ASV's position (m) and heading (rad) errors


class AsvStack(McmStack):
    """The ASV in the world: KeepStation, Reacquire, DetectUUV, TrackUUV; the multibeam."""

    classes = ASV

    def __init__(self, world: McmWorld, seed: int = 1) -> None:
        super().__init__(world, world.asv)
        self.rng = np.random.default_rng([seed, 7])
        tx, ty, _ = world.scene.target
        self.mine = (tx + float(self.rng.normal(0.0, MAP_ERROR)),
                     ty + float(self.rng.normal(0.0, MAP_ERROR)))
        self.sonar = Multibeam(world.scene, self.rng.spawn(1)[0],
                               clutter_from=float(world.faults.get("clutter", math.inf)),
                               false_target_from=float(world.faults.get("falsetarget",
                                                                         math.inf)))
        self.origin: tuple[float, float] | None = None  # {T}'s origin in {E}, once reacquired
        self.mine_echoes: list[tuple[float, float]] = []
        self.detections: list[SonarFix] = []
        self.sent_fixes: list[tuple[float, SonarFix]] = []  # (sent at, the fix) for figures

    # -- the modem ------------------------------------------------------------------------------
    def payload(self, channel: str, message: str, t: float) -> dict[str, Any]:
        """What a message says: a ``fix`` carries the last detection of the UUV (§4.1), a
        ``release`` the mine's depth (its echo sounder's, 0.1 m), every other nothing."""
        if message == "fix" and self.detections:
            self.sent_fixes.append((t, self.detections[-1]))
            return self.detections[-1].payload()
        if message == "release":
            return {"depth": round(self.world.scene.target[2]
                                   + float(self.rng.normal(0.0, 0.1)), 2)}
        return {}

    def heard(self, channel: str, message: str, data: dict[str, Any], t: float) -> None:
        """The ASV hears nothing (the link is one way)."""

    # -- sensing ---------------------------------------------------------------------------------
    def sense(self) -> None:
        if self.world.carried():
            self.world.ride()
        if not self.sonar.due(self.t):
            return
        asv = self.body.state
        if self.origin is None:
            self.sonar.next_ping = self.t + self.sonar.period
            self.look_for_mine()
            return
        fix = self.sonar.ping(self.t, asv, self.world.uuv.state, self.origin)
        if fix is not None and not self.world.carried():
            self.detections.append(fix)

    def look_for_mine(self) -> None:
        """One ping at the mine: three in view within range, the ASV steady (under
        0.15 m/s, a sharp image), set {T}'s origin."""
        a, (tx, ty, _) = self.body.state, self.world.scene.target
        if abs(a.u) > 0.15:
            return
        bearing = math.remainder(math.atan2(ty - a.y, tx - a.x) - a.psi, 2 * math.pi)
        if math.hypot(tx - a.x, ty - a.y) > REACQUIRE_RANGE or abs(bearing) > self.sonar.fov / 2:
            return
        sigma = 0.1 + math.hypot(tx - a.x, ty - a.y) * self.sonar.sigma_bearing  # cross-range
        self.mine_echoes.append((tx + float(self.rng.normal(0.0, sigma)),
                                 ty + float(self.rng.normal(0.0, sigma))))
        if len(self.mine_echoes) >= 3:
            xs, ys = zip(*self.mine_echoes)
            self.origin = (sum(xs) / len(xs), sum(ys) / len(ys))
            self.mine = self.world.origin = self.origin

    def perception(self) -> Perception:
        s = self.body.state
        x = s.x + float(self.rng.normal(0.0, NAV_SIGMA[0]))
        y = s.y + float(self.rng.normal(0.0, NAV_SIGMA[0]))
        psi = s.psi + float(self.rng.normal(0.0, NAV_SIGMA[1]))
        # the echoes as the ASV sees them, the slant range laid flat (it does not know the
        # UUV's depth): enough to tell whether the UUV moves
        track = tuple((f.ping, *fix_position(f, 0.0)) for f in self.detections[-40:])
        return McmPerception(self.t, x, y, 0.0, psi, s.u, 0.0, 0.0, s.r, mine=self.mine,
                             reacquired=self.origin is not None, uuv_track=track)

    def figures(self) -> dict[str, Any]:
        """What its sonar did, against ground truth: where it set {T}, what it took for the
        UUV."""
        tx, ty, _ = self.world.scene.target
        picked = {k: sum(1 for f in self.detections if f.echo == k)
                  for k in ("uuv", "clutter", "target")}
        frame = (f"{math.hypot(self.origin[0] - tx, self.origin[1] - ty):.2f} m off the mine"
                 if self.origin is not None else "never set")
        return {"target frame": frame,
                "sonar took for the UUV": f"the UUV {picked['uuv']} times, clutter "
                                          f"{picked['clutter']}, the mine {picked['target']}",
                "fixes sent": len(self.sent_fixes)}
