"""What every behaviour shares: one lifecycle, what it perceives, what it answers.

A behaviour is enabled (``initialise`` with the action's parameters), ticked (``update``
with the latest perception, returning its response — the velocities it wants on the degrees
of freedom it drives — and the events it raises), and disabled (``terminate``). The vehicle
loop owns the tick; the coordinator merges the responses of the enabled behaviours.

Degrees of freedom: ``x`` surge, ``y`` sway, ``z`` heave, ``yaw`` yaw rate (body frame; facing
the wall with yaw 0, surge moves towards the wall and sway along it, as in paper 002 §3.1).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from collections.abc import Iterable
from typing import Any, ClassVar

DOFS = ("x", "y", "z", "yaw")


@dataclass(frozen=True)
class Perception:
    """The vehicle's estimate of itself and its surroundings at time t (world frame, z down)."""

    t: float
    x: float
    y: float
    z: float
    psi: float  # heading, rad
    u: float = 0.0
    v: float = 0.0
    w: float = 0.0
    r: float = 0.0
    wall_distance: float | None = None  # m, from the wall tracker; None when not tracked
    wall_heading: float | None = None  # rad, heading relative to the wall normal
    wall_normal: float | None = None  # rad, world direction of the wall's normal (static)
    altitude: float | None = None  # m above the floor, from the DVL; None without bottom lock
    area: tuple[float, float, float, float] | None = None  # the working area the vehicle is
    # given (x_min, x_max, y_min, y_max, m, world frame); None: not limited
    leak: bool = False
    temperature: float = 20.0  # deg C inside the pressure vessels
    pressure: float = 1.0  # bar inside the pressure vessels
    line: Any = None  # behaviours.seabed.LineView: the seabed line as the running tracker
    # sees it (FollowPipeline, FollowCable, SearchLine); None when none runs
    wall_point: tuple[float, float] | None = None  # (x, y) of the wall's foot, last seen (a
    # vehicle that reports the wall as a distance sensor: ArduSub's DISTANCE_SENSOR)
    wall_seen_at: float = -math.inf  # s, when the wall was last seen (with wall_point)
    alarms: frozenset[str] = frozenset()  # the alarms the vehicle's own autopilot reported
    # ("leak", "overtemperature", "overpressure": ArduSub's STATUSTEXTs)


@dataclass
class Response:
    """What a behaviour asks of the degrees of freedom it drives: velocity ``demands`` (m/s,
    rad/s, body frame) for a vehicle whose controller takes velocities (the simulated Ictineu),
    or position ``setpoints`` (x, y, z m in the world frame, z down; yaw rad) for one whose
    autopilot holds positions (ArduSub in GUIDED). The coordinator gives each degree of freedom
    to one behaviour, whichever of the two it asks for."""

    demands: dict[str, float] = field(default_factory=dict)
    setpoints: dict[str, float] = field(default_factory=dict)


class Behaviour:
    """One behaviour, one lifecycle (``initialise`` -> ``update``... -> ``terminate``), on every
    vehicle. A class declares what the registry (behaviours/registry.py) lists: its ``name``,
    the degrees of freedom it ``drives``, the ``parameters`` it takes, the ``events`` it raises and
    its ``priority`` in the coordinator (higher wins an overlap; 0: ranked last).

    What a vehicle reads of the class, never of a list of names: a behaviour that ``drives`` a
    degree of freedom moves the vehicle (a disarmed vehicle stops it); ``switches`` names a
    device of the vehicle that runs while it is enabled ("camera", "logs"); ``tracker`` the
    seabed vision's line tracker it needs ("pipeline", "cable", "search"); ``surveys`` says it
    is the wall survey (its ``path`` is the plan the run's figures and the mosaic are measured
    against). Two control laws: :meth:`on_update` answers velocity demands (a vehicle whose
    controller takes velocities, the simulated Ictineu); :meth:`on_setpoints`, when the class
    has one, position setpoints (a vehicle whose autopilot holds positions, ArduSub in GUIDED:
    the MAVLink adapter offers exactly the registered behaviours that have it)."""

    name: ClassVar[str] = ""
    drives: ClassVar[tuple[str, ...]] = ()
    events: ClassVar[tuple[str, ...]] = ()
    parameters: ClassVar[tuple[str, ...]] = ()
    priority: ClassVar[int] = 0
    switches: ClassVar[str] = ""
    tracker: ClassVar[str] = ""
    surveys: ClassVar[bool] = False

    def __init__(self) -> None:
        self.active = False
        self.params: dict[str, Any] = {}
        self.raised: list[tuple[str, dict[str, Any]]] = []
        self._taken = 0
        self.seen: Perception | None = None  # the last perception it was ticked with

    @classmethod
    def statement(cls) -> str:
        """What the class declares, as a task library writes it: ``behaviour GoTo drives x, y,
        z, yaw events reached, failed;`` (one line; parameters and priority are not part of
        the statement)."""
        text = f"behaviour {cls.name}"
        if cls.drives:
            text += " drives " + ", ".join(cls.drives)
        if cls.events:
            text += " events " + ", ".join(cls.events)
        return text + ";\n"

    # -- the lifecycle ------------------------------------------------------------------------
    def initialise(self, params: dict[str, Any], t: float) -> None:
        """Enable (again): take the action's parameters."""
        self.active = True
        self.params = dict(params)
        self.raised = []
        self._taken = 0
        self.on_initialise(t)

    def configure(self, params: dict[str, Any], t: float) -> None:
        self.params.update(params)

    def update(self, p: Perception) -> Response:
        """One tick: the response; events go to ``raised`` (collected by the vehicle loop)."""
        if not self.active:
            return Response()
        self.seen = p
        return self.on_update(p)

    def update_setpoints(self, p: Perception) -> Response:
        """One tick on a vehicle whose autopilot holds positions: the response of the position
        law (:meth:`on_setpoints`); events go to ``raised`` as with :meth:`update`."""
        if not self.active:
            return Response()
        self.seen = p
        return self.on_setpoints(p)

    def terminate(self, t: float) -> None:
        self.active = False

    @classmethod
    def has_position_law(cls) -> bool:
        """Whether the class answers position setpoints (it overrides :meth:`on_setpoints`)."""
        return cls.on_setpoints is not Behaviour.on_setpoints

    # -- for subclasses -----------------------------------------------------------------------
    def on_initialise(self, t: float) -> None:
        pass

    def on_update(self, p: Perception) -> Response:
        """The velocity law: velocity ``demands`` on the degrees of freedom it drives."""
        return Response()

    def on_setpoints(self, p: Perception) -> Response:
        """The position law: position ``setpoints`` (x, y, z m world frame, z down; yaw rad) on
        the degrees of freedom it drives. A class without one is not offered on a vehicle whose
        autopilot holds positions (a class that drives nothing and needs nothing of such a
        vehicle writes ``return self.on_update(p)``)."""
        raise NotImplementedError(f"{self.name} has no position law")

    def progress_report(self) -> dict[str, float | int] | None:
        """How far along it is, for an operator (``mcl run``'s timeline, ``mcl monitor``, the
        mission status): e.g. ``{"waypoint": 12, "of": 84, "to_go": 96.3}`` (``to_go`` in
        metres); None for a behaviour that has no progress to tell."""
        return None

    def take_events(self) -> list[tuple[str, dict[str, Any]]]:
        """The events raised since the last call (the vehicle loop sends them on)."""
        new = self.raised[self._taken:]
        self._taken = len(self.raised)
        return new

    def raise_event(self, name: str, **data: Any) -> None:
        """Raise an event once per enable (a behaviour says 'reached' once)."""
        if name not in [n for n, _ in self.raised]:
            self.raised.append((name, data))

    def param(self, key: str, default: float) -> float:
        value = self.params.get(key, default)
        return float(value) if isinstance(value, (int, float)) else default

    def angle(self, key: str, default: float) -> float:
        """An angle parameter, in rad: the action gives it in degrees (as MCL writes angles,
        :func:`from_degrees`); ``default`` (rad) when it is not given or not a number."""
        value = self.params.get(key)
        return from_degrees(value) if isinstance(value, (int, float)) else default


# -- units, angles and limits: the one home of these helpers (behaviours/ and vehicle/) --------
def from_degrees(value: float) -> float:
    """An angle as the AAL carries it (a parameter, deg) -> rad, as the behaviours use it."""
    return math.radians(float(value))


def to_degrees(angle: float) -> float:
    """rad -> deg: an angle as an action parameter carries it (e.g. GoTo's ``yaw``)."""
    return math.degrees(angle)


def wrap(angle: float) -> float:
    """An angle in (-pi, pi]."""
    a = math.fmod(angle + math.pi, 2 * math.pi)
    if a <= 0:
        a += 2 * math.pi
    return a - math.pi


def progress_of(behaviours: Iterable[Behaviour]) -> dict[str, dict[str, float | int]]:
    """The progress of each active behaviour that tells one, by its name (JSON-ready)."""
    out: dict[str, dict[str, float | int]] = {}
    for b in behaviours:
        report = b.progress_report() if b.active else None
        if report:
            out[b.name] = report
    return out


def path_left(path: list[tuple[float, float]], index: int, here: tuple[float, float]) -> float:
    """The length (m) of the path still to go from ``here`` through waypoints ``index`` on."""
    if index >= len(path):
        return 0.0
    legs = sum(math.dist(path[i], path[i + 1]) for i in range(index, len(path) - 1))
    return math.dist(here, path[index]) + legs


def clamp(value: float, limit: float) -> float:
    """``value`` limited to [-limit, limit]."""
    return max(-limit, min(limit, value))
