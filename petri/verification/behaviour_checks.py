"""The behaviours in a net's markings and transitions: which are on in each marking, which two
places hold one at once, which two drive one degree of freedom together, and the static check
that each firing sends the actions that switch them (``actions-match-behaviours``,
:mod:`petri.verification.actions`, which needs no numpy).

A behaviour is on in a marking when a place that records it (``Place.behaviours``) is marked.
Behaviours are numbered by name: column i of :func:`behaviours_on` is ``behaviour_names(net)[i]``.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from petri.net import Net
from petri.verification.actions import actions_match
from petri.verification.graph import Marked, Mask, Rows

__all__ = ["actions_match", "behaviour_names", "behaviours_on", "dof_conflicts", "dof_groups",
           "names_on", "shared_owner", "some_group"]


def behaviour_names(net: Net) -> list[str]:
    """Every behaviour some place records, sorted by name."""
    return sorted({b for p in net.places for b in p.behaviours})


def behaviours_on(net: Net, marked: Marked) -> npt.NDArray[np.bool_]:
    """Which behaviours are on in each marking (a column per behaviour, sorted by name)."""
    behaviours = behaviour_names(net)
    on = np.zeros((len(marked), len(behaviours)), bool)
    for i, b in enumerate(behaviours):
        cols = [p for p, place in enumerate(net.places) if b in place.behaviours]
        on[:, i] = marked[:, cols].any(axis=1)
    return on


def names_on(net: Net, row: Mask) -> list[str]:
    """The behaviours on in one row of :func:`behaviours_on`."""
    return [b for b, on in zip(behaviour_names(net), row) if on]


def some_group(marked: Marked | Mask, groups: list[list[int]]) -> Rows:
    """Rows in which two columns of some group are true."""
    bad = np.zeros(len(marked), bool)
    for cols in groups:
        bad |= marked[:, cols].sum(axis=1) > 1
    return np.flatnonzero(bad)


def dof_groups(net: Net) -> list[list[int]]:
    """For each degree of freedom, the columns of :func:`behaviours_on` that drive it."""
    behaviours = behaviour_names(net)
    dofs = sorted({d for b in behaviours for d in net.dofs.get(b, ())})
    return [[i for i, b in enumerate(behaviours) if d in net.dofs.get(b, ())] for d in dofs]


def shared_owner(net: Net, marked: Marked) -> tuple[Rows, str]:
    """The markings in which two places hold the same behaviour driving a degree of freedom
    (for the behaviour with the nearest such marking), and that behaviour."""
    first: Rows = np.array([], np.int64)
    who = ""
    for b in behaviour_names(net):
        if not net.dofs.get(b):  # a watcher: several holders share it (on until the last)
            continue
        cols = [p for p, place in enumerate(net.places) if b in place.behaviours]
        if len(cols) < 2:
            continue
        bad = np.flatnonzero(marked[:, cols].sum(axis=1) > 1)
        if len(bad) and (len(first) == 0 or bad.min() < first.min()):
            first, who = bad, b
    return first, who


def dof_conflicts(net: Net, on: Mask) -> tuple[Rows, str]:
    """The markings in which two behaviours driving one degree of freedom are on (for the
    degree of freedom with the nearest such marking), and what: "z (GoTo and Surface)"."""
    behaviours = behaviour_names(net)
    first: Rows = np.array([], np.int64)
    what = ""
    for d, cols in zip(sorted({d for b in behaviours for d in net.dofs.get(b, ())}),
                       dof_groups(net)):
        if len(cols) < 2:
            continue
        bad = np.flatnonzero(on[:, cols].sum(axis=1) > 1)
        if len(bad) and (len(first) == 0 or bad.min() < first.min()):
            first = bad
            row = on[bad.min()]
            what = f"{d} ({' and '.join(behaviours[c] for c in cols if row[c])})"
    return first, what
