"""What a vehicle can do, from the one declaration the task library is checked against.

The Ictineu stack's behaviours and their events are declared once, in the shipped task library
``mcl/tasks/ictineu.tasks`` (``behaviour GoTo drives x, y, z, yaw events reached, failed;``),
and the parameters each behaviour takes by that library's actions (``enable GoTo(x = ..., y =
..., z = ..., yaw = ..., tolerance = ...)``). A vehicle serving that stack (in process, over
Zenoh, or the MAVLink adapter, which maps all of them) declares that library; one that maps
only some behaviours would declare just their statements. The player parses the
declaration with the task library's own parser and refuses, before the first action, a mission
that needs a behaviour or an event the vehicle does not declare.
"""

from __future__ import annotations

import re
from collections.abc import Iterable
from pathlib import Path

from .aal import Declaration

ICTINEU_TASKS = Path(__file__).resolve().parents[1] / "mcl" / "tasks" / "ictineu.tasks"
_STATEMENT = re.compile(r"^[ \t]*(?:behaviour[ \t]+([A-Za-z_]\w*)\b|dofs\b)[^;]*;",
                        re.MULTILINE)


def behaviour_statements(text: str, only: Iterable[str] | None = None) -> str:
    """The ``dofs ...;`` and ``behaviour ...;`` statements of a task library text (of the
    behaviours in ``only``, if given), one a line, as written there."""
    keep = None if only is None else set(only)
    return "".join(m.group(0).strip() + "\n" for m in _STATEMENT.finditer(text)
                   if keep is None or m.group(1) is None or m.group(1) in keep)


def simulated(vehicle: str, only: Iterable[str] | None = None) -> Declaration:
    """The simulated stack's declaration: the Ictineu library's behaviours and the seabed ones
    it also runs (``behaviours/seabed.py``: KeepAltitude, FollowPipeline, FollowCable,
    SearchLine; see docs/SEABED.md)."""
    from behaviours.seabed import statements

    base = ictineu(vehicle, only)
    seabed = behaviour_statements(statements(), only)
    return Declaration(base.vehicle, base.source + " and behaviours/seabed.py",
                       base.text + seabed)


def ictineu(vehicle: str, only: Iterable[str] | None = None) -> Declaration:
    """The simulated Ictineu's declaration: the whole library, whose task actions also say
    which parameters each behaviour takes; of ``only`` some behaviours, just their
    statements (their parameters are then not declared)."""
    text = ICTINEU_TASKS.read_text("utf-8")
    every = {m.group(1) for m in _STATEMENT.finditer(text) if m.group(1)}
    if only is None or every <= set(only):
        return Declaration(vehicle, "<mcl>/tasks/ictineu.tasks", text)
    return Declaration(vehicle, "<mcl>/tasks/ictineu.tasks", behaviour_statements(text, only))
