"""A scripted vehicle: answers actions with events as a TOML file says, in simulated time.

For tests, and for mission authors who want to try a mission without a vehicle::

    [behaviours.GoTo]
    on_enable = { after = 5.0, event = "reached" }      # GoTo.reached 5 s after enable GoTo
    [behaviours.WallInspection]
    on_enable = [{ after = 60.0, event = "done" }]      # a list: several answers
    [[at]]                                              # events at given mission times
    time = 40.0
    event = "Alarms.leak"

A behaviour the file does not mention never answers. Disabling a behaviour cancels its
answers that have not come yet; enabling it again schedules them anew. An ``[[at]]`` event
comes at its time whatever the vehicle is doing.
"""

from __future__ import annotations

import heapq
import tomllib
from dataclasses import dataclass, field
from typing import Any

from .aal import ActionMessage, EventMessage


class ScriptError(ValueError):
    """A scripted-vehicle file that cannot be used; the message says where and why."""


@dataclass(frozen=True)
class Answer:
    after: float
    event: str  # the event's name (the behaviour is the source)
    data: dict[str, Any] = field(default_factory=dict)


@dataclass
class Script:
    answers: dict[str, list[Answer]] = field(default_factory=dict)  # behaviour -> answers
    at: list[tuple[float, str, dict[str, Any]]] = field(default_factory=list)  # (t, "S.e", data)


def load_script(path: str) -> Script:
    try:
        with open(path, "rb") as f:
            doc = tomllib.load(f)
    except FileNotFoundError:
        raise ScriptError(f"{path}: no such file") from None
    except tomllib.TOMLDecodeError as exc:
        raise ScriptError(f"{path}: not valid TOML: {exc}") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise ScriptError(f"{path}: cannot be read: {exc}") from None
    return parse_script(doc, path)


def parse_script(doc: dict[str, Any], path: str = "<script>") -> Script:
    script = Script()
    unknown = set(doc) - {"behaviours", "at"}
    if unknown:
        raise ScriptError(f"{path}: unknown section(s) {sorted(unknown)}: "
                          "use [behaviours.NAME] and [[at]]")
    for name, table in (doc.get("behaviours") or {}).items():
        where = f"{path}: behaviours.{name}"
        if not isinstance(table, dict):
            raise ScriptError(f"{where}: must be a table")
        extra = set(table) - {"on_enable"}
        if extra:
            raise ScriptError(f"{where}: unknown key(s) {sorted(extra)}: use on_enable")
        spec = table.get("on_enable", [])
        items = spec if isinstance(spec, list) else [spec]
        script.answers[name] = [_answer(item, f"{where}.on_enable") for item in items]
    for i, item in enumerate(doc.get("at") or []):
        where = f"{path}: at[{i}]"
        if not isinstance(item, dict):
            raise ScriptError(f"{where}: must be a table with time and event")
        t = _number(item.get("time"), f"{where}.time")
        event = item.get("event")
        if not isinstance(event, str) or event.count(".") != 1 or not all(
                p.isidentifier() for p in event.split(".")):
            raise ScriptError(f"{where}.event: must be 'Source.name', e.g. 'Alarms.leak'")
        script.at.append((t, event, dict(item.get("data") or {})))
    return script


def _answer(item: Any, where: str) -> Answer:
    if not isinstance(item, dict):
        raise ScriptError(f"{where}: must be {{ after = SECONDS, event = NAME }}")
    event = item.get("event")
    if not isinstance(event, str) or not event.isidentifier():
        raise ScriptError(f"{where}.event: must be an event name such as 'reached'")
    return Answer(_number(item.get("after", 0.0), f"{where}.after"), event,
                  dict(item.get("data") or {}))


def _number(value: Any, where: str) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or value < 0 \
            or value != value or value == float("inf"):
        raise ScriptError(f"{where}: must be a number of seconds >= 0, got {value!r}")
    return float(value)


@dataclass
class ScriptedVehicle:
    """The vehicle stack side: takes actions, produces events at simulated times."""

    script: Script
    _queue: list[tuple[float, int, str, str, dict[str, Any]]] = field(default_factory=list)
    _order: int = 0
    _generation: dict[str, int] = field(default_factory=dict)
    _seq: int = 0

    def __post_init__(self) -> None:
        for t, event, data in self.script.at:
            source, name = event.split(".")
            self._push(t, "", source, name, data)

    def _push(self, t: float, tag: str, source: str, name: str, data: dict[str, Any]) -> None:
        self._order += 1
        heapq.heappush(self._queue, (t, self._order, tag, f"{source}.{name}", data))

    def on_action(self, action: ActionMessage, now: float) -> None:
        b = action.behaviour
        # a new generation: answers scheduled by an earlier enable no longer count
        self._generation[b] = self._generation.get(b, 0) + 1
        if action.kind == "enable":
            for answer in self.script.answers.get(b, []):
                self._push(now + answer.after, f"{b}#{self._generation[b]}", b, answer.event,
                           answer.data)

    def next_time(self) -> float | None:
        self._drop_stale()
        return self._queue[0][0] if self._queue else None

    def due(self, t: float) -> list[EventMessage]:
        """Events scheduled at or before t, earliest first."""
        out = []
        while True:
            self._drop_stale()
            if not self._queue or self._queue[0][0] > t + 1e-9:
                break
            when, _, _, event, data = heapq.heappop(self._queue)
            source, name = event.split(".")
            out.append(EventMessage(self._seq, when, source, name, data))
            self._seq += 1
        return out

    def _drop_stale(self) -> None:
        while self._queue:
            tag = self._queue[0][2]
            if tag:
                behaviour, gen = tag.split("#")
                if self._generation.get(behaviour) != int(gen):
                    heapq.heappop(self._queue)
                    continue
            break
