"""The time bound of a run: how long a mission may run before the runner aborts it.

The default limit is derived from the mission's own timeouts: the longest it can last, proved
by :func:`mcl.analysis.duration.analyse` (docs/DURATION.md), plus 10 % and 60 s; a mission its
timeouts do not bound (a WHILE loop, a task that waits without a timeout) gets
:data:`UNBOUNDED`.
"""

from __future__ import annotations

import math

from diagnostics import file_error
from mcl.analysis.duration import analyse
from mcl.api import Compiled

UNBOUNDED = 7200.0  # s: the default limit of a mission its timeouts do not bound
MARGIN, SLACK = 0.10, 60.0  # the default limit: the bound + 10 % + 60 s


def max_time(compiled: Compiled, given: float | None) -> tuple[float, str]:
    """The mission time limit and where it comes from (``given``: the caller's limit in
    seconds, e.g. ``--max-time``; None: the default)."""
    if given is not None:
        if not math.isfinite(given) or given <= 0:
            raise file_error("--max-time", f"--max-time {given:g}: must be a positive number "
                             "of seconds", "e.g. --max-time 3600")
        return given, "--max-time"
    bound = mission_bound(compiled)
    if bound is None:
        return UNBOUNDED, (f"default: the mission's timeouts do not bound it, so "
                           f"{UNBOUNDED:g} s")
    limit = round(bound * (1 + MARGIN) + SLACK, 3)
    return limit, f"default: its timeouts bound it to {bound:g} s, + 10 % + {SLACK:g} s"


def mission_bound(compiled: Compiled) -> float | None:
    """The longest the mission can last, proved from its timeouts (None: they do not bound
    it)."""
    worst = analyse(compiled.checked).worst
    return worst if math.isfinite(worst) else None
