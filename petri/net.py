"""Place/transition nets: the one data structure that is verified and then executed.

A :class:`Net` is a list of places, a list of transitions with weighted input and output
arcs, an initial marking, and (for nets compiled from MCL) the proper final markings and the
degrees of freedom each behaviour drives. Transitions compiled from MCL also carry what the
player needs to run them: the actions they send, the event or timer they wait for, and the
MCL source they come from. Nets read from PNML carry none of that and are verified alike.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:  # numpy is loaded only by the code that needs arrays (startup time)
    import numpy as np
    import numpy.typing as npt

Json = Any


@dataclass(frozen=True)
class Origin:
    """Where in a mission a place or transition comes from (for messages and counterexamples)."""

    file: str
    line: int
    col: int
    text: str = ""  # the construct as written, e.g. "GoTo(initialPos)"
    kind: str = ""  # "task", "latch", or the construct: "TRY", "SEQ", "AND", "OR", ...

    def where(self) -> str:
        return f"{self.file}:{self.line}:{self.col}"


@dataclass(frozen=True)
class Action:
    """An order to the vehicle: enable, disable or configure one behaviour (docs/AAL.md);
    or, in a fleet's vehicle, ``send`` a message on a channel (``behaviour`` is the channel,
    ``params`` ``(("message", name),)``), which the player gives to the fleet's channels."""

    kind: str  # "enable" | "disable" | "configure" | "send"
    behaviour: str
    params: tuple[tuple[str, Json], ...] = ()

    def __str__(self) -> str:
        args = ", ".join(f"{k}={_short(v)}" for k, v in self.params)
        return f"{self.kind} {self.behaviour}" + (f"({args})" if args else "")


POINT_FIELDS = {"x": 0, "y": 1, "z": 2, "yaw": 3}


def resolve(value: Json, params: dict[str, Json]) -> Json:
    """An action parameter's value: a literal as it is, or ``{"param": name[, "field": f]}``
    (a mission parameter without a value when compiled) looked up in ``params``; None if
    the parameter has no value there."""
    if not (isinstance(value, dict) and "param" in value):
        return value
    v = params.get(value["param"])
    field_ = value.get("field")
    if field_ is None or v is None:
        return v
    index = POINT_FIELDS[field_]
    return v[index] if isinstance(v, list) and index < len(v) else None


def _short(value: Json) -> str:
    text = repr(value) if not isinstance(value, str) else value
    return text if len(text) <= 40 else text[:37] + "..."


# What a place is for, set by the template that makes it (never read back from its name).
# A block's interface: BEGIN, ABORT (a token asks the block to stop), OK, FAIL, ABORTED;
# RUN: a task is running; LATCH_OFF / LATCH_ON: a latched behaviour's state; END_OK /
# END_FAIL: the mission has ended; STOP_HANDLER: the mission's stop handler (MCL's ON STOP)
# is running, after a stop from outside; INNER: any other place of a template.
BEGIN, ABORT, OK, FAIL, ABORTED = "begin", "abort", "ok", "fail", "aborted"
RUN, LATCH_OFF, LATCH_ON, END_OK, END_FAIL, INNER = (
    "run", "latch-off", "latch-on", "end-ok", "end-fail", "inner")
STOP_HANDLER = "stop-handler"


@dataclass(frozen=True)
class Place:
    """A place of the net: its name, the behaviours a token in it keeps on, where it comes
    from and its role."""

    name: str
    # Behaviours that are switched on while this place holds a token (a running task's
    # place, or a latched behaviour's "on" place).
    behaviours: tuple[str, ...] = ()
    origin: Origin | None = None
    role: str = INNER


@dataclass(frozen=True)
class Transition:
    """A transition of the net: its input and output arcs, what fires it (an event, a timer, or
    nothing: immediate) and the actions it sends."""

    name: str
    inputs: tuple[tuple[int, int], ...]  # (place index, weight)
    outputs: tuple[tuple[int, int], ...]
    actions: tuple[Action, ...] = ()
    event: str | None = None  # e.g. "GoTo.reached": fires only when this event arrives
    timer: float | str | None = None  # seconds, or a mission parameter's name
    origin: Origin | None = None
    label: str = ""  # what firing it means, in the mission's words

    @property
    def immediate(self) -> bool:
        """Fires as soon as it is enabled (no event, no timer)."""
        return self.event is None and self.timer is None


@dataclass
class Net:
    """A place/transition net (one compiled from a mission, or read from PNML): its places,
    transitions, initial and final markings, and the degrees of freedom of its behaviours."""

    name: str
    places: list[Place] = field(default_factory=list)
    transitions: list[Transition] = field(default_factory=list)
    initial: dict[int, int] = field(default_factory=dict)
    # Proper final markings (MCL nets): each a full marking as {place: tokens}.
    finals: list[dict[int, int]] = field(default_factory=list)
    # Degrees of freedom each behaviour drives (from the task library).
    dofs: dict[str, tuple[str, ...]] = field(default_factory=dict)
    _index: dict[str, int] = field(default_factory=dict, repr=False)

    # -- building -------------------------------------------------------------------------
    def add_place(self, name: str, behaviours: tuple[str, ...] = (),
                  origin: Origin | None = None, role: str = INNER) -> int:
        if name in self._index:
            raise ValueError(f"duplicate place name {name!r}")
        self._index[name] = len(self.places)
        self.places.append(Place(name, behaviours, origin, role))
        return self._index[name]

    def places_with(self, *roles: str) -> list[int]:
        """Indices of the places that play one of ``roles``."""
        return [i for i, p in enumerate(self.places) if p.role in roles]

    def add_transition(self, name: str, inputs: list[int] | dict[int, int],
                       outputs: list[int] | dict[int, int], **kw: Any) -> int:
        self.transitions.append(
            Transition(name, _arcs(inputs), _arcs(outputs), **kw))
        return len(self.transitions) - 1

    def place(self, name: str) -> int:
        return self._index[name]

    # -- views ----------------------------------------------------------------------------
    # Arcs are kept sparse, as (place, weight) lists on each transition: a mission net has a
    # few arcs per transition, so any place x transition matrix would be almost all zeros
    # (and, for a survey of thousands of waypoints, larger than memory).
    def effect(self, t: int) -> dict[int, int]:
        """The non-zero change firing transition ``t`` makes, {place: post - pre}."""
        out: dict[int, int] = {}
        tr = self.transitions[t]
        for p, w in tr.inputs:
            out[p] = out.get(p, 0) - w
        for p, w in tr.outputs:
            out[p] = out.get(p, 0) + w
        return {p: d for p, d in out.items() if d}

    def initial_vector(self) -> npt.NDArray[np.int64]:
        import numpy as np

        v = np.zeros(len(self.places), dtype=np.int64)
        for p, n in self.initial.items():
            v[p] = n
        return v

    def arc_count(self) -> int:
        return sum(len(t.inputs) + len(t.outputs) for t in self.transitions)

    def describe_marking(self, marking: dict[int, int] | npt.NDArray[np.int64]) -> str:
        items = marking.items() if isinstance(marking, dict) else enumerate(marking)
        parts = [self.places[p].name + (f"×{n}" if n > 1 else "")
                 for p, n in items if n]
        return "{" + ", ".join(parts) + "}"

    def to_dict(self) -> dict[str, Json]:
        """A JSON-ready description of the whole net (used by --json and by tests)."""
        def origin(o: Origin | None) -> Json:
            return None if o is None else {"file": o.file, "line": o.line, "col": o.col,
                                           "text": o.text, "kind": o.kind}
        return {
            "name": self.name,
            "places": [{"name": p.name, "behaviours": list(p.behaviours), "role": p.role,
                        "origin": origin(p.origin)} for p in self.places],
            "transitions": [{
                "name": t.name,
                "inputs": {self.places[p].name: w for p, w in t.inputs},
                "outputs": {self.places[p].name: w for p, w in t.outputs},
                "actions": [{"kind": a.kind, "behaviour": a.behaviour,
                             "params": dict(a.params)} for a in t.actions],
                "event": t.event, "timer": t.timer, "label": t.label,
                "origin": origin(t.origin)} for t in self.transitions],
            "initial": {self.places[p].name: n for p, n in self.initial.items() if n},
            "finals": [{self.places[p].name: n for p, n in f.items() if n}
                       for f in self.finals],
            "dofs": {b: list(d) for b, d in self.dofs.items()},
        }


def triggers(net: Net) -> list[int]:
    """For each transition, the input place an explorer looks it up by (-1: no input): the
    input read by the fewest transitions, so that a marked place that many transitions read
    (a latch's "off" place) does not make every marking examine all of them."""
    readers = [0] * len(net.places)
    for tr in net.transitions:
        for p, _ in tr.inputs:
            readers[p] += 1
    return [min((readers[p], p) for p, _ in tr.inputs)[1] if tr.inputs else -1
            for tr in net.transitions]


def _arcs(spec: list[int] | dict[int, int]) -> tuple[tuple[int, int], ...]:
    if isinstance(spec, list):  # the usual case, made fast: one or two distinct places
        if len(spec) == 1:
            return ((spec[0], 1),)
        if len(spec) == 2 and spec[0] != spec[1]:
            a, b = spec
            return ((a, 1), (b, 1)) if a < b else ((b, 1), (a, 1))
    if isinstance(spec, dict):
        return tuple(sorted((p, w) for p, w in spec.items() if w))
    counts: dict[int, int] = {}
    for p in spec:
        counts[p] = counts.get(p, 0) + 1
    return tuple(sorted(counts.items()))
