"""The architecture abstraction layer (docs/AAL.md): actions out, events in, as versioned JSON.

An action is an order from the player to the vehicle: enable, disable or configure one
behaviour. An event is a fact from the vehicle (``GoTo.reached``). Both are small JSON objects
with a schema version ``v``, a per-sender sequence number ``seq`` and the sender's clock ``t``.
Every receiver validates what arrives; an invalid message raises :class:`InvalidMessage`,
which receivers log and drop — it never crashes them.
"""

from __future__ import annotations

import json
import math
import re
from dataclasses import dataclass, field
from typing import Any, Protocol

from diagnostics import MclError, Span

VERSION = 1
ACTION_KINDS = ("enable", "disable", "configure")
MAX_MESSAGE = 64 * 1024


MESSAGE = "<message>"  # the file name of a message's place: <message>:line:col


class InvalidMessage(MclError, ValueError):
    """A message that does not follow the schema; says which field is wrong, and where in the
    message's text it is (``<message>:line:col`` in :meth:`format`; ``str()`` is the reason)."""

    def __init__(self, message: str, span: Span | None = None) -> None:
        super().__init__(message, span=span, code="invalid-message", text=message)


def _at(text: str | bytes, key: str) -> Span | None:
    """Where the field ``key`` is written in a message's text (None if it is not)."""
    if isinstance(text, bytes):
        text = text.decode("utf-8", "replace")
    m = re.search(rf'"{re.escape(key)}"\s*:', text)
    if m is None:
        return None
    line = text.count("\n", 0, m.start()) + 1
    return Span(MESSAGE, line, m.start() - (text.rfind("\n", 0, m.start()) + 1) + 1)


@dataclass(frozen=True)
class ActionMessage:
    seq: int
    t: float
    mission: str
    task: str  # e.g. "GoTo@12:9" — the task call that sends it
    kind: str
    behaviour: str
    params: dict[str, Any] = field(default_factory=dict)
    run: str = ""  # optional: which run of a player sent it (a vehicle drops a stale run's)

    def to_json(self) -> str:
        d = {"v": VERSION, "seq": self.seq, "t": self.t, "mission": self.mission,
             "task": self.task, "kind": self.kind, "behaviour": self.behaviour,
             "params": self.params}
        if self.run:
            d["run"] = self.run
        return json.dumps(d, separators=(",", ":"))

    @staticmethod
    def from_json(text: str | bytes) -> ActionMessage:
        d = _load(text)
        _require(d, {"seq": int, "t": (int, float), "mission": str, "task": str, "kind": str,
                     "behaviour": str, "params": dict}, text)
        if d["kind"] not in ACTION_KINDS:
            raise InvalidMessage(f"action kind {d['kind']!r} is not one of {ACTION_KINDS}",
                                 _at(text, "kind"))
        run = d.get("run", "")
        if not isinstance(run, str):
            raise InvalidMessage(f"field 'run' has the wrong type ({type(run).__name__})",
                                 _at(text, "run"))
        return ActionMessage(d["seq"], float(d["t"]), d["mission"], d["task"], d["kind"],
                             d["behaviour"], d["params"], run)


@dataclass(frozen=True)
class EventMessage:
    seq: int
    t: float
    source: str  # the behaviour (or "Link", "Mission") that raises it
    name: str
    data: dict[str, Any] = field(default_factory=dict)

    @property
    def event(self) -> str:
        """The name used in task declarations: ``Source.name``."""
        return f"{self.source}.{self.name}"

    def to_json(self) -> str:
        return json.dumps({"v": VERSION, "seq": self.seq, "t": self.t, "source": self.source,
                           "name": self.name, "data": self.data}, separators=(",", ":"))

    @staticmethod
    def from_json(text: str | bytes) -> EventMessage:
        d = _load(text)
        _require(d, {"seq": int, "t": (int, float), "source": str, "name": str, "data": dict},
                 text)
        for key in ("source", "name"):
            if not d[key].isidentifier():
                raise InvalidMessage(f"event {key} {d[key]!r} is not a name", _at(text, key))
        return EventMessage(d["seq"], float(d["t"]), d["source"], d["name"], d["data"])


def _load(text: str | bytes) -> dict[str, Any]:
    if len(text) > MAX_MESSAGE:
        raise InvalidMessage(f"message of {len(text)} bytes is larger than {MAX_MESSAGE}",
                             Span.of_file(MESSAGE))
    try:
        d = json.loads(text)
    except json.JSONDecodeError as exc:
        raise InvalidMessage(f"not JSON: {exc}", Span(MESSAGE, exc.lineno, exc.colno)) from None
    except UnicodeDecodeError as exc:
        raise InvalidMessage(f"not JSON: {exc}", Span(MESSAGE, 1, exc.start + 1)) from None
    if not isinstance(d, dict):
        raise InvalidMessage("not a JSON object", Span(MESSAGE, 1, 1))
    if d.get("v") != VERSION:
        raise InvalidMessage(f"schema version {d.get('v')!r}, expected {VERSION}",
                             _at(text, "v") or Span(MESSAGE, 1, 1))
    return d


def _require(d: dict[str, Any], fields: dict[str, type | tuple[type, ...]],
             text: str | bytes = "") -> None:
    for key, types in fields.items():
        if key not in d:
            raise InvalidMessage(f"field {key!r} is missing", Span(MESSAGE, 1, 1))
        value = d[key]
        if isinstance(value, bool) or not isinstance(value, types):
            raise InvalidMessage(f"field {key!r} has the wrong type ({type(value).__name__})",
                                 _at(text, key))
        if isinstance(value, float) and not math.isfinite(value):
            raise InvalidMessage(f"field {key!r} is not finite", _at(text, key))
    if d["seq"] < 0:
        raise InvalidMessage("field 'seq' is negative", _at(text, "seq"))


@dataclass(frozen=True)
class Declaration:
    """What a vehicle can do, said in the task library's own form: ``behaviour NAME drives
    ... events ...;`` statements (``mcl/grammar/tasks.lark``), the same declarations a task
    library is checked against. ``vehicle`` names the vehicle in messages, ``source`` where
    the text comes from (a file, or the vehicle's own answer over its link)."""

    vehicle: str
    source: str
    text: str


class Vehicle(Protocol):
    """What the player needs from any vehicle adapter (a context manager).

    ``send`` delivers one action; ``receive(until)`` returns the events that arrived, waiting
    at most until the clock reads ``until`` (never forever); ``now`` is the clock the player
    runs on (the vehicle's simulated clock, or wall time)."""

    def __enter__(self) -> Vehicle: ...
    def __exit__(self, *exc: object) -> None: ...
    def send(self, action: ActionMessage) -> None: ...
    def receive(self, until: float) -> list[EventMessage]: ...
    def now(self) -> float: ...
    def idle(self) -> bool:
        """True when nothing will ever arrive unless an action is sent (simulated vehicles:
        no event scheduled). Real vehicles answer False."""
        ...

