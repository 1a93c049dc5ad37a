"""Paper 003's phases driven by a script, on the two simulated stacks, without a mission.

The fleet mission (missions/mcm.mcl) is what runs the vehicles in ``mcl run``; this driver is
the same sequence written as Python, for the tests of the vehicles and their failure modes
(paper 003 §3) and for a quick look at the world: the ASV keeps station, reacquires the mine
and releases the UUV; the UUV holds 2 m until the first fix (acquired), follows the line on
the fixes, homes on the camera from ``switch`` m, lands and takes the snapshot. The ASV sends
a fix every ``period`` s; each reaches the UUV ``delay`` s later or is lost with probability
``loss`` (a plain stand-in for the channel model of mission/channels.py), and every one from
``silence_from`` s on. The UUV ascends when
no fix has come within ``acquire`` s of its release, none for ``stale`` s while it follows
the line, when the camera loses the mine, or when a phase outlasts its task's timeout.
"""

from __future__ import annotations

import math
import random
from dataclasses import dataclass, field
from typing import Any

from aal.messages import ActionMessage
from vehicle.control.asv_stack import AsvStack
from vehicle.control.mcm_stack import McmStack, McmWorld, mcm_world
from vehicle.control.uuv_stack import Navigation, UuvStack


LIMITS = {"guide": 300.0, "home": 120.0, "land": 120.0}  # s: the tasks' timeouts (uuv.tasks)


@dataclass
class PairRun:
    """What a driven run did: its events (t, vehicle, behaviour, event), the fixes sent
    (ping time, delivered?), how it ended and the stacks (their tracks, the world)."""

    world: McmWorld
    asv: AsvStack
    uuv: UuvStack
    events: list[tuple[float, str, str, str]] = field(default_factory=list)
    sent: list[tuple[float, bool]] = field(default_factory=list)
    outcome: str = "running"  # "landed", "ascended", "missed" or "time"
    landed_at: float | None = None

    def happened(self, event: str) -> float | None:
        """When ``Behaviour.event`` first happened (None: never)."""
        return next((t for t, _, b, e in self.events if f"{b}.{e}" == event), None)

    def miss(self) -> float:
        """Horizontal distance (m) from the UUV to the mine at the end."""
        s, (tx, ty, _) = self.world.uuv.state, self.world.scene.target
        return math.hypot(s.x - tx, s.y - ty)


def act(stack: McmStack, kind: str, behaviour: str, **params: Any) -> None:
    stack.on_action(ActionMessage(0, stack.t, "mcm", "script", kind, behaviour, params),
                    stack.t)


def drive_pair(seed: int = 1, faults: list[tuple[str, Any]] | None = None, loss: float = 0.0,
               delay: float = 2.0, period: float = 2.0, stale: float = 10.0,
               switch: float = 2.0, acquire: float = 30.0, silence_from: float = math.inf,
               until: float = 300.0,
               navigation: Navigation | None = None) -> PairRun:
    """Run the phases until the UUV has landed and taken the snapshot, ascended, or
    ``until`` s have passed."""
    world = mcm_world(seed, faults)
    run = PairRun(world, AsvStack(world, seed), UuvStack(world, seed, navigation))
    asv, uuv, rng = run.asv, run.uuv, random.Random(seed)
    act(asv, "enable", "KeepStation", distance=15.0)
    act(asv, "enable", "Reacquire")
    phase, last_send, flying, since = "reacquire", -math.inf, [], 0.0
    while asv.t < until and phase not in ("done",):
        t = asv.t + 0.1
        for name, stack in (("asv", asv), ("uuv", uuv)):
            for e in stack.due(t):
                run.events.append((round(e.t, 2), name, e.source, e.name))
                phase, was = step(run, phase, f"{e.source}.{e.name}", switch), phase
                since = since if phase == was else uuv.t
        if uuv.t - since > LIMITS.get(phase, math.inf):  # the task's timeout
            act(uuv, "disable", {"guide": "FollowLine", "home": "Home", "land": "Land"}[phase])
            act(uuv, "enable", "Ascend")
            phase, since = "ascend", uuv.t
        while uuv.t < asv.t - 1e-9:
            uuv.tick()
        if phase in ("acquire", "guide", "home") and asv.t - last_send >= period - 1e-9:
            last_send = asv.t
            lost = rng.random() < loss or asv.t >= silence_from
            run.sent.append((asv.t, not lost))
            if not lost:
                flying.append((asv.t + delay, asv.payload("guide", "fix", asv.t)))
        for due, data in [m for m in flying if m[0] <= uuv.t + 1e-9]:
            flying.remove((due, data))
            uuv.heard("guide", "fix", data, uuv.t)
            if phase == "acquire" and uuv.fixes:
                phase, since = "guide", uuv.t
                act(uuv, "disable", "KeepDepth")
                act(uuv, "enable", "FollowLine", speed=0.5, height=1.5, distance=switch)
        silent = uuv.t - max(uuv.fix_at, world.released_at or 0.0)
        if (phase == "guide" and silent > stale) or (phase == "acquire" and silent > acquire):
            act(uuv, "disable", "FollowLine" if phase == "guide" else "KeepDepth")
            act(uuv, "enable", "Ascend")
            phase = "ascend"
    if phase != "done":
        run.outcome = "time"
    return run


def step(run: PairRun, phase: str, event: str, switch: float) -> str:
    """The next phase after an event (and the actions it takes)."""
    asv, uuv = run.asv, run.uuv
    if event == "Reacquire.reacquired":
        act(asv, "disable", "Reacquire")
        act(asv, "enable", "TrackUUV", still=10.0, patience=20.0)
        uuv.heard("guide", "release", asv.payload("guide", "release", asv.t), asv.t)
        act(uuv, "enable", "KeepDepth", depth=2.0)
        return "acquire"
    if event == "FollowLine.near":
        act(uuv, "disable", "FollowLine")
        act(uuv, "enable", "Home", distance=1.0, height=0.5, patience=8.0)
        return "home"
    if event == "Home.over":
        act(uuv, "disable", "Home")
        act(uuv, "enable", "Land")
        return "land"
    if event == "Home.lost":
        act(uuv, "disable", "Home")
        act(uuv, "enable", "Ascend")
        return "ascend"
    if event == "Land.landed":
        act(uuv, "disable", "Land")
        act(uuv, "enable", "Snapshot", wait=3.0)
        run.landed_at = uuv.t
        return "snapshot"
    if event in ("Snapshot.taken", "Snapshot.missed"):
        act(uuv, "disable", "Snapshot")
        run.outcome = "landed" if event == "Snapshot.taken" else "missed"
        return "done"
    if event == "Ascend.surfaced":
        act(uuv, "disable", "Ascend")
        run.outcome = "ascended"
        return "done"
    return phase
