"""The simulated world of paper 003 and what the ASV's and the UUV's stacks share.

:class:`McmWorld` holds the scene (vehicle/world/mine_field.py) and both vehicles' bodies, so
that the ASV's multibeam sees the UUV and the UUV's camera the mine. Until it is released the
UUV rides under the ASV (:meth:`McmWorld.carried`). Each vehicle has its own stack
(:class:`McmStack`: the adapter's ``on_action`` / ``next_time`` / ``due``, like the Ictineu's
stack), ticking at the paper's 10 Hz control loop on its own clock; a fleet run keeps the two
clocks together. The inner velocity loop (surge, heave, yaw) feeds forward the model of eq. 2
and corrects with a PI on the vehicle's rate sensors (simulated exact); what the behaviours
steer by is the vehicle's estimate (the ASV's navigation, the UUV's navigator).

Faults (``mcl run --inject``): ``clutter@S`` (the sonar takes clutter for the UUV near the
bottom from S s on), ``falsetarget@S`` (it takes the mine for the UUV near it from S s on),
``current=VX,VY`` (a current of VX, VY m/s in {E}).
"""

from __future__ import annotations

import difflib
import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from aal.messages import ActionMessage, EventMessage
from behaviours.base import Behaviour, Perception, clamp
from behaviours.coordinator import Coordinator
from vehicle.world.mcm_bodies import ASV_MODEL, UUV_MODEL, Body, BodyState, Model
from vehicle.world.mine_field import MineField, mine_field

DT = 0.1  # s: the control loop's 10 Hz (paper 003 §4)
FAULTS = ("clutter", "falsetarget", "current")
UNDER_ASV = (1.5, 0.0, 0.5)  # m ahead, to starboard, below: where the UUV rides


def parse_mcm_fault(text: str) -> tuple[str, Any]:
    """``clutter@60`` -> ("clutter", 60.0); ``current=0.2,-0.1`` -> ("current", (0.2, -0.1));
    ValueError saying what is wrong and what to write."""
    example = "expected clutter@SECONDS, falsetarget@SECONDS or current=VX,VY (m/s)"
    if text.startswith("current="):
        parts = text.removeprefix("current=").split(",")
        try:
            vx, vy = (float(v) for v in parts)
        except ValueError:
            raise ValueError(f"{text}: {example}, e.g. current=0.2,0") from None
        if not all(math.isfinite(v) and abs(v) <= 2.0 for v in (vx, vy)):
            raise ValueError(f"{text}: a current is at most 2 m/s each way; {example}")
        return "current", (vx, vy)
    kind, at, seconds = text.partition("@")
    if not at or kind not in FAULTS[:2]:
        near = difflib.get_close_matches(kind, FAULTS, n=1, cutoff=0.6)
        hint = f" (did you mean {near[0]}?)" if near else ""
        raise ValueError(f"{text}: {example}{hint}")
    try:
        when = float(seconds)
    except ValueError:
        raise ValueError(f"{text}: {seconds!r} is not a number of seconds; {example}") from None
    if not math.isfinite(when) or when < 0:
        raise ValueError(f"{text}: {seconds} is not a time of the mission (0 or more "
                         f"seconds); {example}")
    return kind, when


@dataclass
class McmWorld:
    """The scene and both vehicles' ground truth, shared by the two stacks."""

    scene: MineField
    asv: Body
    uuv: Body
    released_at: float | None = None
    faults: dict[str, Any] = field(default_factory=dict)
    origin: tuple[float, float] | None = None  # {T}'s origin in {E}, once the ASV set it

    def carried(self) -> bool:
        """Whether the UUV still rides under the ASV."""
        return self.released_at is None

    def release(self, t: float) -> None:
        """Let the UUV go (it heard 'release')."""
        if self.released_at is None:
            self.released_at = t

    def ride(self) -> None:
        """While carried, the UUV is where the ASV holds it."""
        a = self.asv.state
        ahead, side, below = UNDER_ASV
        c, s = math.cos(a.psi), math.sin(a.psi)
        self.uuv.state = BodyState(a.x + c * ahead - s * side, a.y + s * ahead + c * side,
                                   below, a.psi)


def mcm_world(seed: int = 1, faults: list[tuple[str, Any]] | None = None) -> McmWorld:
    """The world of a seed with these faults (as :func:`parse_mcm_fault` gives them)."""
    chosen = dict(faults or [])
    current = chosen.get("current", (0.0, 0.0))
    scene = mine_field(seed, current=current)
    rng = np.random.default_rng([seed, 5])
    asv_rng, uuv_rng = rng.spawn(2)
    asv = Body(ASV_MODEL, BodyState(0.0, 0.0, 0.0, 0.0), asv_rng, surface_only=True)
    uuv = Body(UUV_MODEL, BodyState(*UNDER_ASV, 0.0), uuv_rng, bottom=scene.bottom)
    return McmWorld(scene, asv, uuv, faults=chosen)


class McmStack:
    """One vehicle's simulated stack in the world: its behaviours (one of each class it
    has), the coordinator and the velocity loop, on a clock of its own."""

    simulated = True
    classes: tuple[type[Behaviour], ...] = ()
    gains = (80.0, 80.0, 6.0)  # surge, heave, yaw: N per m/s, N per m/s, N m per rad/s

    def __init__(self, world: McmWorld, body: Body) -> None:
        self.world, self.body = world, body
        self.behaviours: dict[str, Behaviour] = {cls.name: cls() for cls in self.classes}
        self.coordinator = Coordinator()
        self.t = 0.0
        self.integral = [0.0, 0.0, 0.0]
        self.tau = (0.0, 0.0, 0.0)
        self.unknown_actions: list[str] = []
        self._events: list[EventMessage] = []
        self._seq = 0
        self.track: list[tuple[float, float, float, float, float]] = []  # t, x, y, z, psi
        self.raised: list[tuple[float, str, str]] = []  # every event: t, behaviour, event

    # -- the adapter's side ---------------------------------------------------------------------
    def on_action(self, action: ActionMessage, now: float) -> None:
        b = self.behaviours.get(action.behaviour)
        if b is None:
            self.unknown_actions.append(action.behaviour)
        elif action.kind == "enable":
            b.initialise(action.params, self.t)
        elif action.kind == "disable":
            b.terminate(self.t)
        else:
            b.configure(action.params, self.t)

    def next_time(self) -> float:
        return self.t + DT

    def due(self, t: float) -> list[EventMessage]:
        """Run ticks up to time t, stopping early at the first tick that raises events."""
        while self.t + DT <= t + 1e-9:
            self.tick()
            if self._events:
                break
        out, self._events = self._events, []
        return out

    def active(self) -> list[str]:
        return [n for n, b in self.behaviours.items() if b.active]

    # -- one tick -------------------------------------------------------------------------------
    def tick(self) -> None:
        self.sense()
        p = self.perception()
        responses = {}
        for b in self.behaviours.values():
            if b.active:
                responses[b.name] = b.update(p)
                for name, data in b.take_events():
                    self._events.append(EventMessage(self._seq, self.t, b.name, name, data))
                    self.raised.append((round(self.t, 3), b.name, name))
                    self._seq += 1
        demands = self.coordinator.merge(responses)
        self.tau = self.velocity_loop(demands)
        self.move(self.tau)
        self.t += DT
        s = self.body.state
        self.track.append((round(self.t, 3), s.x, s.y, s.z, s.psi))

    def velocity_loop(self, demands: dict[str, float]) -> tuple[float, float, float]:
        """Thrust (X, Z, N) for velocity demands: the model's feed-forward plus a PI."""
        m: Model = self.body.model
        s = self.body.state
        out = []
        for k, (dof, want, have) in enumerate(((m.surge, demands["x"], s.u),
                                               (m.heave, demands["z"], s.w),
                                               (m.yaw, demands["yaw"], s.r))):
            error = want - have
            self.integral[k] = clamp(self.integral[k] + 0.5 * self.gains[k] * error * DT,
                                     dof.limit)
            feed = (dof.beta_v + dof.beta_vv * abs(want)) * want
            out.append(clamp(feed + self.gains[k] * error + self.integral[k], dof.limit))
        return out[0], out[1], out[2]

    def move(self, tau: tuple[float, float, float]) -> None:
        self.body.step(DT, tau, self.world.scene.current)

    # -- for the vehicles -----------------------------------------------------------------------
    def sense(self) -> None:
        """Sample the sensors due at this tick (a vehicle's own)."""

    def perception(self) -> Perception:
        s = self.body.state
        return Perception(self.t, s.x, s.y, s.z, s.psi, s.u, 0.0, s.w, s.r)

    def payload(self, channel: str, message: str, t: float) -> dict[str, Any]:
        """What a message it sends says (its modem; nothing unless the vehicle says)."""
        return {}

    def heard(self, channel: str, message: str, data: dict[str, Any], t: float) -> None:
        """A message it heard at time t (its modem; ignored unless the vehicle says)."""

    def figures(self) -> dict[str, Any]:
        """The run's figures against ground truth (each vehicle says its own)."""
        return {}

    def position(self) -> tuple[float, float, float] | None:
        """Where the vehicle is ({E}, m): for the channel's travel time."""
        s = self.body.state
        return s.x, s.y, s.z

