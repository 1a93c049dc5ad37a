"""The one registry of behaviours: name -> class, each class declaring its ``name``, the degrees
of freedom it ``drives``, the ``parameters`` it takes, the ``events`` it raises and its
``priority`` in the coordinator (behaviours/base.py). The task libraries are checked against it
(tests/behaviours/test_registry.py), every vehicle declares from it (behaviours/capabilities.py), the
coordinator ranks by it, the simulated stack runs one of each.

Every other list of behaviours is derived from it and from what the classes declare, never
kept by hand: which move the vehicle (``drives``: what a disarmed ArduSub-like vehicle stops),
which switch a device (``switches``: the camera's and the logger's hooks, :func:`switching`),
which the MAVLink adapter runs (those with a position law, :func:`with_position_law`), the
paper's stack (``behaviours.ALL``).

Registering a behaviour is one line below (docs/EXTENDING.md, "Add a behaviour")::

    register(HoldDepth)
"""

from __future__ import annotations

from collections.abc import Iterator

from behaviours.base import DOFS, Behaviour
from behaviours.motion import AchieveHeadDist, GoTo, Surface, WallInspection
from behaviours.seabed import FollowCable, FollowPipeline, KeepAltitude, SearchLine
from behaviours.sensing import Alarms, StartCamera, StartLogs

REGISTRY: dict[str, type[Behaviour]] = {}


def register(cls: type[Behaviour]) -> type[Behaviour]:
    """Add a behaviour class (usable as a class decorator); ValueError when it is not a
    well-formed declaration: no name, a name taken by another class, a degree of freedom
    not in :data:`DOFS`, an event or a parameter named twice."""
    name = cls.name
    if not name.isidentifier():
        raise ValueError(f"{cls.__qualname__}: a behaviour needs a name (class attribute "
                         f"'name'), not {name!r}")
    if REGISTRY.get(name, cls) is not cls:
        raise ValueError(f"behaviour {name} is registered twice "
                         f"({REGISTRY[name].__qualname__} and {cls.__qualname__})")
    wrong = [d for d in cls.drives if d not in DOFS]
    if wrong:
        raise ValueError(f"behaviour {name} drives {', '.join(wrong)}: the degrees of freedom "
                         f"are {', '.join(DOFS)}")
    for what, names in (("drives", cls.drives), ("events", cls.events),
                        ("parameters", cls.parameters)):
        if len(set(names)) != len(names):
            raise ValueError(f"behaviour {name}: {what} names one twice: {', '.join(names)}")
    REGISTRY[name] = cls
    return cls


def unregister(name: str) -> None:
    """Take a behaviour out again (a test that registered one for a while)."""
    REGISTRY.pop(name, None)


def behaviour(name: str) -> type[Behaviour]:
    """The registered class of that name; KeyError naming those there are."""
    try:
        return REGISTRY[name]
    except KeyError:
        raise KeyError(f"no behaviour {name!r} is registered: {', '.join(REGISTRY)}") from None


def behaviours() -> Iterator[type[Behaviour]]:
    """The registered classes, in the order they were registered."""
    return iter(tuple(REGISTRY.values()))


def rank(name: str) -> int:
    """A behaviour's priority in the coordinator (higher wins an overlap); an unregistered
    name ranks with the lowest."""
    cls = REGISTRY.get(name)
    return cls.priority if cls is not None else 0


def switching(device: str) -> tuple[str, ...]:
    """The behaviours that switch ``device`` ("camera", "logs") while enabled, by name."""
    return tuple(cls.name for cls in REGISTRY.values() if device and cls.switches == device)


def with_position_law() -> tuple[type[Behaviour], ...]:
    """The behaviours that answer position setpoints (an autopilot that holds positions)."""
    return tuple(cls for cls in REGISTRY.values() if cls.has_position_law())


def priority() -> tuple[str, ...]:
    """The behaviours with a priority (> 0), highest first: who wins an overlap."""
    ranked = [cls for cls in REGISTRY.values() if cls.priority > 0]
    return tuple(cls.name for cls in sorted(ranked, key=lambda c: -c.priority))


# -- the behaviours every vehicle has: one line each ----------------------------------------------
register(GoTo)
register(WallInspection)
register(AchieveHeadDist)
register(Surface)
register(StartCamera)
register(Alarms)
register(StartLogs)
register(KeepAltitude)
register(FollowPipeline)
register(FollowCable)
register(SearchLine)
