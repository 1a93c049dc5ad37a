"""What a vehicle can do, declared from the one registry of behaviours (behaviours/registry.py).

A declaration is text in the task library's own form, which the player parses with the task
library's parser and checks a mission against before the first action (a behaviour, an event
or a parameter the vehicle does not have is refused)::

    dofs x, y, z, yaw;
    behaviour GoTo drives x, y, z, yaw events reached, failed;
    task GoTo(x: number, y: number, z: number, yaw: number, tolerance: number) {
        start: enable GoTo(x, y, z, yaw, tolerance);
    }

one ``behaviour`` statement per behaviour (:meth:`Behaviour.statement`) and one task per
behaviour whose only action enables it with every parameter the class takes: that is how a
task library says which parameters a behaviour takes (the kinds and ranges of the parameters
are the mission's task library's, not the vehicle's, so each is declared a ``number``).
tests/behaviours/test_registry.py checks that the shipped task libraries agree with the registry.
"""

from __future__ import annotations

import re
from collections.abc import Iterable

from aal.messages import Declaration

from behaviours import ALL, registry
from behaviours.base import DOFS, Behaviour

SOURCE = "behaviours/registry.py"
_STATEMENT = re.compile(r"^[ \t]*(?:behaviour[ \t]+([A-Za-z_]\w*)\b|dofs\b)[^;]*;",
                        re.MULTILINE)


def behaviour_statements(text: str, only: Iterable[str] | None = None) -> str:
    """The ``dofs ...;`` and ``behaviour ...;`` statements of a task library text (of the
    behaviours in ``only``, if given), one a line, as written there (a scripted vehicle
    declares those of its ``tasks`` libraries)."""
    keep = None if only is None else set(only)
    return "".join(m.group(0).strip() + "\n" for m in _STATEMENT.finditer(text)
                   if keep is None or m.group(1) is None or m.group(1) in keep)


def parameters_task(cls: type[Behaviour]) -> str:
    """The task that says which parameters ``cls`` takes (see the module's docstring)."""
    formals = ", ".join(f"{p}: number" for p in cls.parameters)
    given = f"({', '.join(cls.parameters)})" if cls.parameters else ""
    return f"task {cls.name}({formals}) {{ start: enable {cls.name}{given}; }}\n"


def declaration_text(classes: Iterable[type[Behaviour]]) -> str:
    """The declaration of these behaviours: the degrees of freedom, their statements and the
    parameters they take."""
    chosen = list(classes)
    return ("// declared from behaviours/registry.py\n"
            f"dofs {', '.join(DOFS)};\n"
            + "".join(cls.statement() for cls in chosen)
            + "// the parameters each behaviour takes (kinds and ranges: the task library's)\n"
            + "".join(parameters_task(cls) for cls in chosen))


def _chosen(among: Iterable[str], only: Iterable[str] | None) -> list[type[Behaviour]]:
    keep = None if only is None else set(only)
    return [registry.behaviour(n) for n in among if keep is None or n in keep]


def registered(vehicle: str, only: Iterable[str] | None = None) -> Declaration:
    """The declaration of every registered behaviour, or of those of them in ``only`` (in the
    registry's order): what a vehicle that runs the registry's classes declares."""
    return Declaration(vehicle, SOURCE,
                       declaration_text(_chosen(list(registry.REGISTRY), only)))


def simulated(vehicle: str, only: Iterable[str] | None = None) -> Declaration:
    """The simulated stack's declaration: every registered behaviour (the Ictineu's and the
    seabed ones, docs/SEABED.md), or those of them in ``only``."""
    return registered(vehicle, only)


def ictineu(vehicle: str, only: Iterable[str] | None = None) -> Declaration:
    """The Ictineu's declaration: the behaviours of the paper's stack (``behaviours.ALL``:
    GoTo, WallInspection, AchieveHeadDist, Surface, StartCamera, Alarms, StartLogs), or
    those of them in ``only`` (a vehicle that maps just some of them)."""
    return Declaration(vehicle, SOURCE, declaration_text(_chosen([c.name for c in ALL], only)))
