"""The net as a time Petri net: its state-class graph, to settle races between timers.

The untimed model (petri/verification/reachability.py) lets any awaited event or timer happen at any
moment, so it reaches markings that the player can never reach because of the timers'
values: in ``PARALLEL { Wait(10 s); GoTo(p) } AND { Surface(timeout = 5 s) }`` Surface always
ends (its event, or its 5 s timeout) before GoTo starts at 10 s, yet the untimed graph has
both running. Here each transition gets a static firing interval, read off the player's rules
(petri/execution/player.py, petri/semantics.py):

==================  ===========  ==========================================================
transition          interval     why
==================  ===========  ==========================================================
event ``e``         [0, inf)     the environment may deliver it at any time
timer of d seconds  [d, d]       it fires exactly d after it became enabled (widened by
                                 ``slack``, see below); a timer naming a mission parameter
                                 takes its value from ``params``, or [0, inf) if it has none
immediate           [0, 0]       fires at once; urgent: time cannot pass while one is enabled
``Mission.abort``   never        the external stop, verified on its own
                                 (docs/SEMANTICS.md §3); with ``stop=True``, an event: the
                                 stop may come at any time, and then, as the player does,
                                 only what can fire in that same instant fires (time
                                 stops; no event is taken)
==================  ===========  ==========================================================

Strong semantics: time cannot pass beyond the upper bound of an enabled transition. A
transition is *newly enabled* by a firing when it is enabled after it and was not before
(the player's ``enabled_since``); its clock then restarts. Any other enabled transition
keeps its clock. Simultaneous deadlines may fire in either order (the player fires the
lower index first; both orders are kept, so the model is a superset), and an event may come
in the very instant a timer falls due, before or after it.

State classes (Berthomieu-Diaz; the DBM form of Berthomieu-Vernadat): a class is a marking
and a *firing domain*, the set of possible times-to-fire ``x_t`` of the enabled transitions,
kept as a canonical difference-bound matrix ``d`` (``d[i, j]`` bounds ``x_i - x_j``; index 0
is the constant 0). Transition ``t`` can fire first iff the domain allows ``x_t <= x_u`` for
every enabled ``u``, i.e. ``d[u, t] >= 0``. Firing it at time ``x_t`` gives, for the
transitions that stay enabled, ``x'_i = x_i - x_t``::

    d'[i, 0] = d[i, t]       d'[0, j] = min_u d[u, j]       d'[i, j] = min(d[i, j], d'[i, 0] + d'[0, j])

and each newly enabled transition its static interval. Event transitions need no variable:
an unbounded ``[0, inf)`` clock constrains nothing, so firing an event is "let any time pass
that no deadline forbids". The immediate transitions share one clock, ``URGENT``, always 0:
a domain spans the enabled timers and, if some immediate transition is enabled, that clock.

A class whose domain lies inside the domain of a class already kept for the same marking is
not kept (its successors lie inside that one's): the markings and firings found are the same,
and a loop racing a long timer (``WHILE ... OR Wait(5 min)``) does not give one class per
round (missions/every_construct.mcl: 3,602 classes instead of 464,405).

Times are integer nanoseconds. Each timer's interval is widened by ``slack`` seconds either
way (default 1 us): the player computes deadlines in floating point and lets an event
delivered up to 1 ns after a deadline go first, so exact values could refute a marking that
a run reaches. Bounds are exact Python integers, ``math.inf`` when there is none.

The markings found are exactly those the time Petri net reaches; a
firing sequence of the player, with any timing of the events, is one of its runs
(tests/petri/verification/test_timed.py checks it on random missions).
"""

from __future__ import annotations

import math
from collections import deque
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import numpy.typing as npt

from petri.net import Net
from petri.semantics import Semantics

INF = math.inf  # "no bound" in a DBM (finite bounds are exact integers)
NS = 1_000_000_000  # nanoseconds per second
DEFAULT_SLACK = 1e-6  # seconds either side of a timer's value
DEFAULT_MAX_CLASSES = 500_000
URGENT = -1  # the clock of the immediate transitions

Dbm = list[list[float]]  # integer nanoseconds, or INF


@dataclass
class TimedSpace:
    """The markings of the time Petri net's state-class graph, in breadth-first order."""

    markings: npt.NDArray[np.uint8]  # (n, places), one row per distinct marking; row 0 initial
    complete: bool  # False: max_classes (or 255 tokens in a place) stopped the search
    classes: int  # state classes explored (a marking may have several)
    stop_reason: str = ""
    stop: bool = False  # whether the external stop (Mission.abort) is in the model
    index: dict[bytes, int] = field(default_factory=dict, repr=False)  # marking -> row
    # (t, row reached) -> the first class it was fired from
    firings: dict[tuple[int, int], int] = field(default_factory=dict, repr=False)
    _first: list[int] = field(default_factory=list, repr=False)  # row -> its first class
    _parent: list[int] = field(default_factory=list, repr=False)  # class -> parent class
    _via: list[int] = field(default_factory=list, repr=False)  # class -> transition fired

    @property
    def n_markings(self) -> int:
        return int(self.markings.shape[0])

    def row_of(self, marking: Sequence[int] | npt.NDArray[np.integer]) -> int | None:
        """The row of a marking (a full vector of token counts), None if not reachable."""
        values = np.asarray(marking)
        if values.size and (values.min() < 0 or values.max() > 255):
            return None
        return self.index.get(values.astype(np.uint8).tobytes())

    def path_to(self, row: int) -> list[int]:
        """Transition indices of a firing sequence from the initial marking to ``row``, that
        the time Petri net can fire with some timing (the first found, breadth first)."""
        return self._path(self._first[row])

    def witness(self, markings_rows: npt.ArrayLike, via: Sequence[int] | None = None
                ) -> tuple[int, list[int]] | None:
        """The first of the given markings (rows of token counts) that the time Petri net
        reaches (with ``via``: reaches by firing ``via[k]``), as (k, a firing sequence to it
        that some timing allows); None if it reaches none of them."""
        for k, marking in enumerate(np.atleast_2d(np.asarray(markings_rows))):
            row = self.row_of(marking)
            if row is None:
                continue
            if via is None:
                return k, self.path_to(row)
            source = self.firings.get((int(via[k]), row))
            if source is not None:
                return k, self._path(source) + [int(via[k])]
        return None

    def _path(self, c: int) -> list[int]:
        path: list[int] = []
        for _ in range(len(self._parent)):  # each class is visited at most once
            if c == 0:
                break
            path.append(self._via[c])
            c = self._parent[c]
        return path[::-1]


def intervals(net: Net, params: dict[str, Any] | None = None,
              slack: float = DEFAULT_SLACK) -> list[tuple[float, float] | None]:
    """Each transition's static firing interval in ns ([lo, INF] when unbounded); None for
    an event transition, which needs no clock, and for ``Mission.abort``, left out. The
    kinds of transition and the timers' seconds are the player's (:class:`Semantics`)."""
    params = params or {}
    rules = Semantics(net)
    out: list[tuple[float, float] | None] = []
    for t, tr in enumerate(net.transitions):
        if rules.immediate[t]:
            out.append((0, 0))
            continue
        if tr.timer is None:  # event-driven
            out.append(None)
            continue
        try:
            d = rules.delay(t, params)
        except ValueError:  # a delay the player refuses: assume nothing
            out.append((0, INF))
            continue
        if d is None:  # a parameter without a value: any delay
            out.append(None if tr.event is not None else (0, INF))
            continue
        hi = math.ceil((d + slack) * NS)
        out.append((0, hi) if tr.event is not None  # an event may end it earlier
                   else (max(0, math.floor((d - slack) * NS)), hi))
    return out


class _Net:
    """The net as the search needs it: the player's rules (:class:`Semantics`: arcs,
    readers, the firing rule, the kinds of transition) over markings kept as ``bytes``, and
    each transition's static interval and clock."""

    def __init__(self, net: Net, params: dict[str, Any] | None, slack: float, stop: bool):
        self.rules = rules = Semantics(net)
        self.inputs, self.outputs, self.readers = rules.inputs, rules.outputs, rules.readers
        self.static = intervals(net, params, slack)
        stops = set(rules.stops)
        self.stops = [t in stops for t in range(len(net.transitions))]
        self.skip = [s and not stop for s in self.stops]
        # the clock each transition fires by: its own for a timer, one shared URGENT clock
        # (always 0) for every immediate one, none for an event
        self.clock: list[int | None] = [
            None if s is None else URGENT if rules.immediate[t] else t
            for t, s in enumerate(self.static)]

    def clocks(self, enabled: list[int], stopped: bool) -> list[int]:
        """The clocks of a class: URGENT if an immediate transition is enabled or the
        mission was stopped from outside (time cannot pass), then the enabled timers."""
        return sorted({c for t in enabled if (c := self.clock[t]) is not None}
                      | ({URGENT} if stopped else set()))

    def interval(self, t: int) -> tuple[float, float]:
        if t == URGENT:
            return (0, 0)
        static = self.static[t]
        assert static is not None, "an event transition has no clock"
        return static

    def enabled(self, m: bytes | bytearray, t: int) -> bool:
        return not self.skip[t] and self.rules.enabled(m, t)

    def all_enabled(self, m: bytes) -> list[int]:
        return [t for t in range(len(self.inputs)) if self.enabled(m, t)]

    def fire(self, m: bytes, t: int) -> bytes | None:
        """The marking after firing ``t``; None if a place would hold more than 255 tokens."""
        after = bytearray(m)
        try:
            self.rules.fire(after, t)
        except ValueError:  # a byte above 255
            return None
        return bytes(after)


def _initial_domain(n: _Net, clocks: list[int]) -> Dbm:
    """Independent static intervals: x_i - x_j <= hi_i - lo_j (and 0 on the diagonal)."""
    lo = [0] + [n.interval(t)[0] for t in clocks]
    hi = [0] + [n.interval(t)[1] for t in clocks]
    return [[0 if i == j else hi[i] - lo[j] for j in range(len(lo))] for i in range(len(lo))]


def _successor(n: _Net, d: Dbm, clocks: list[int], t: int, after: list[int]) -> Dbm:
    """The firing domain after firing ``t`` (the column of its clock, or for an event column
    0) over ``clocks``, giving one over ``after``, the clocks of the new class."""
    c = n.clock[t]
    a = 0 if c is None else clocks.index(c) + 1
    col = [row[a] for row in d]  # d'[i, 0] = d[i, t]
    m = [min(d[u][j] for u in range(1, len(d))) for j in range(len(d))] if clocks else [0]
    m[0] = 0  # d'[0, j] = min_u d[u, j]
    where = {u: i + 1 for i, u in enumerate(clocks)}
    keep = [0] + [where.get(u, -1) for u in after]  # a clock kept, or -1: a new one
    lo = [0] + [0 if k > 0 else n.interval(u)[0] for u, k in zip(after, keep[1:])]
    hi = [0] + [0 if k > 0 else n.interval(u)[1] for u, k in zip(after, keep[1:])]
    up = [col[k] if k > 0 else hi[i] for i, k in enumerate(keep)]  # x'_i <= up[i]
    down = [m[k] if k > 0 else -lo[i] for i, k in enumerate(keep)]  # -x'_j <= down[j]
    new = []
    for i, ki in enumerate(keep):
        row = []
        for j, kj in enumerate(keep):
            bound = up[i] + down[j]
            if i == j:
                bound = 0
            elif ki > 0 and kj > 0:  # both persist: min(d[i, j], d'[i, 0] + d'[0, j])
                bound = min(d[ki][kj], bound)
            elif i == 0 or j == 0:
                bound = down[j] if i == 0 else up[i]
            row.append(bound)
        new.append(row)
    return new


def _inside(a: tuple[float, ...], b: tuple[float, ...]) -> bool:
    """Domain ``a`` lies inside domain ``b`` (canonical DBMs over the same clocks)."""
    return all(x <= y for x, y in zip(a, b))


def explore_timed(net: Net, params: dict[str, Any] | None = None,
                  max_classes: int = DEFAULT_MAX_CLASSES,
                  slack: float = DEFAULT_SLACK, stop: bool = False) -> TimedSpace:
    """Breadth-first state-class graph of ``net`` read as a time Petri net (module doc).
    ``stop``: include the external stop (``Mission.abort``) as an event."""
    n = _Net(net, params, slack, stop)
    initial = n.rules.initial()
    if max(initial, default=0) > 255:
        raise ValueError("the initial marking has more than 255 tokens in one place")
    m0 = bytes(initial)
    en0 = n.all_enabled(m0)
    clocks0 = n.clocks(en0, False)
    d0 = _initial_domain(n, clocks0)
    space = TimedSpace(np.zeros((0, len(net.places)), np.uint8), True, 1, stop=stop)
    rows: list[bytes] = [m0]
    space.index[m0] = 0
    space._first.append(0)
    space._parent.append(-1)
    space._via.append(-1)
    # per marking (and whether the mission was stopped), the domains kept: (flat DBM,
    # class); a domain inside one of them adds nothing (its successors lie inside that
    # one's), and one it contains is dropped
    kept: dict[tuple[bytes, bool], list[tuple[tuple[float, ...], int]]] = {
        (m0, False): [(tuple(x for row in d0 for x in row), 0)]}
    dropped: set[int] = set()
    queue: deque[tuple[int, bytes, bool, list[int], Dbm]] = deque([(0, m0, False, en0, d0)])
    while queue:
        c, m, stopped, enabled, d = queue.popleft()
        if c in dropped:
            continue
        clocks = n.clocks(enabled, stopped)
        before = set(enabled)
        for t in enabled:
            ck = n.clock[t]
            if stopped and ck is None:
                continue  # after the external stop no event is taken
            if ck is not None and any(d[u][clocks.index(ck) + 1] < 0 for u in range(1, len(d))):
                continue  # some other deadline always comes first
            m2 = n.fire(m, t)
            if m2 is None:
                space.complete, space.stop_reason = False, "more than 255 tokens in a place"
                continue
            touched = {u for p, _ in n.inputs[t] + n.outputs[t] for u in n.readers[p]}
            en2 = sorted([u for u in before if u not in touched]
                         + [u for u in touched if n.enabled(m2, u)])
            stopped2 = stopped or n.stops[t]
            d2 = _successor(n, d, clocks, t, n.clocks(en2, stopped2))
            flat = tuple(x for row in d2 for x in row)
            domains = kept.setdefault((m2, stopped2), [])
            if not any(_inside(flat, other) for other, _ in domains):
                if len(space._parent) >= max_classes:
                    space.complete = False
                    space.stop_reason = f"more than {max_classes} state classes"
                    queue.clear()
                    break
                new = len(space._parent)
                dropped.update(k for other, k in domains if _inside(other, flat))
                domains[:] = [(o, k) for o, k in domains if k not in dropped] + [(flat, new)]
                space._parent.append(c)
                space._via.append(t)
                queue.append((new, m2, stopped2, en2, d2))
            row = space.index.get(m2)
            if row is None:
                row = space.index[m2] = len(rows)
                rows.append(m2)
                space._first.append(len(space._parent) - 1)
            space.firings.setdefault((t, row), c)
    space.classes = len(space._parent)
    space.markings = np.frombuffer(b"".join(rows), np.uint8).reshape(len(rows), len(net.places))
    return space


def timed_refutes(net: Net, markings_rows: npt.ArrayLike, params: dict[str, Any] | None = None,
                  via: Sequence[int] | None = None, space: TimedSpace | None = None,
                  max_classes: int = DEFAULT_MAX_CLASSES, stop: bool = True) -> bool | None:
    """Whether the time Petri net reaches none of the given markings (rows of token counts,
    e.g. ``StateSpace.markings[bad]``): True if none is reachable, False if one is, None if
    the timed exploration stopped at its limit before finding one. ``via`` (one transition
    per row): ask instead whether row k is reached *by firing via[k]* (a bad firing, e.g. a
    disable while another holder is marked). ``stop``: the external stop may come at any
    time, as in :func:`petri.verification.reachability.explore` (so any of its markings may be passed);
    False: only markings of the main model. ``space``: reuse an exploration (made with the
    same ``stop``). For a counterexample that respects the timers: ``space.witness``."""
    if space is None:
        space = explore_timed(net, params, max_classes, stop=stop)
    if space.stop != stop:
        raise ValueError(f"the timed space was explored with stop={space.stop}, not {stop}")
    if space.witness(markings_rows, via) is not None:
        return False
    return True if space.complete else None
