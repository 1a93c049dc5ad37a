"""A scripted vehicle: answers actions with events as a TOML file says, in simulated time.

For tests, and for mission authors who want to try a mission without a vehicle::

    [behaviours.GoTo]
    on_enable = { after = 5.0, event = "reached" }      # GoTo.reached 5 s after enable GoTo
    [behaviours.WallInspection]
    on_enable = [{ after = 60.0, event = "done" }]      # a list: several answers
    [[at]]                                              # events at given mission times
    time = 40.0
    event = "Alarms.leak"

    tasks = ["ictineu"]                                 # what this vehicle can do (below)

What the vehicle can do is declared in the task library's own form: ``tasks`` names the
libraries (shipped ones by name, other ``.tasks`` files relative to this file; default
``["ictineu"]``) whose ``behaviour NAME ... events ...;`` statements this vehicle has. A
behaviour or an event the file names that those libraries do not declare is an error with its
``file:line:col`` (:func:`check_script`), and the player refuses a mission that needs a
behaviour or an event the libraries do not declare.

A behaviour the file does not mention never answers. Disabling a behaviour cancels its
answers that have not come yet; enabling it again schedules them anew. Staleness is judged
when an answer is delivered, one at a time: an answer of a behaviour disabled (and perhaps
enabled again) in the same instant is never delivered to its next enable. An ``[[at]]`` event
comes at its time whatever the vehicle is doing.
"""

from __future__ import annotations

import heapq
import os
import re
import tomllib
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

from aal.messages import ActionMessage, EventMessage
from diagnostics import MclError, Span, read_limited

Key = tuple[str | int, ...]  # where in the TOML document: ("at", 2, "time")


class ScriptError(MclError, ValueError):
    """A scripted-vehicle file that cannot be used; the message says where and why (and
    ``place``, ``hint``: the 1-based line and column of a name the task libraries do not
    declare, and what to do). Every error from :func:`load_script` carries its
    ``file:line:col`` (:meth:`format`); ``str()`` keeps the text it always had."""

    def __init__(self, message: str, place: tuple[str, int, int] | None = None,
                 hint: str = "", *, key: Key = (), span: Span | None = None,
                 detail: str = "", source_line: str = "", code: str = "script") -> None:
        self.place, self.hint, self.key = place, hint, key
        if span is None and place is not None:
            span = Span(*place)
        super().__init__(detail or message, span=span, hint=hint, source_line=source_line,
                         code=code, text=message)

    def located(self, path: str, text: str) -> ScriptError:
        """This error with the place of its ``key`` in the file's ``text``."""
        line, col = _key_place(text, self.key)
        lines = text.split("\n")
        detail = str(self).removeprefix(f"{path}: ")
        return ScriptError(str(self), self.place, self.hint, key=self.key,
                           span=Span(path, line, col), detail=detail,
                           source_line=lines[line - 1] if 0 < line <= len(lines) else "")


def _unknown(script: Script, line: int, col: int, message: str, hint: str) -> ScriptError:
    lines = script.text.split("\n")
    return ScriptError(f"{script.path}:{line}:{col}: error: {message}\n  hint: {hint}",
                       (script.path, line, col), hint, detail=message,
                       source_line=lines[line - 1] if 0 < line <= len(lines) else "",
                       code="script-unknown-name")


@dataclass(frozen=True)
class Answer:
    after: float
    event: str  # the event's name (the behaviour is the source)
    data: dict[str, Any] = field(default_factory=dict)


@dataclass
class Script:
    answers: dict[str, list[Answer]] = field(default_factory=dict)  # behaviour -> answers
    at: list[tuple[float, str, dict[str, Any]]] = field(default_factory=list)  # (t, "S.e", data)
    tasks: list[str] = field(default_factory=lambda: ["ictineu"])  # what the vehicle can do
    path: str = "<script>"
    text: str = ""  # the file's text, for the lines of errors


MAX_SCRIPT_BYTES = 1 << 20  # a scripted vehicle's file: 1 MiB is far more than any needs


def load_script(path: str) -> Script:
    if not os.path.exists(path):
        raise ScriptError(f"{path}: no such file", span=Span.of_file(path),
                          detail="no such file")
    try:
        raw = read_limited(path, MAX_SCRIPT_BYTES, "a scripted vehicle's TOML file")
    except MclError as exc:
        message = exc.diagnostics[0].message
        raise ScriptError(f"{path}: {message}", span=Span.of_file(path), detail=message,
                          hint=exc.diagnostics[0].hint) from None
    try:
        doc = tomllib.loads(raw.decode("utf-8"))
    except tomllib.TOMLDecodeError as exc:
        raise _toml_error(path, raw.decode("utf-8"), exc) from None
    except RecursionError:  # tables or arrays nested thousands deep
        raise ScriptError(f"{path}: not valid TOML: nested too deeply", span=Span.of_file(path),
                          detail="not valid TOML: nested too deeply", code="toml") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise ScriptError(f"{path}: cannot be read: {exc}", span=Span.of_file(path),
                          detail=f"cannot be read: {exc}") from None
    text = raw.decode("utf-8")
    try:
        script = parse_script(doc, path)
    except ScriptError as exc:
        raise exc.located(path, text) from None
    script.text = text
    base = os.path.dirname(path)
    script.tasks = [t if "/" not in t and not t.endswith(".tasks") else os.path.join(base, t)
                    for t in script.tasks]
    return script


def parse_script(doc: dict[str, Any], path: str = "<script>") -> Script:
    script = Script(path=path)
    unknown = set(doc) - {"behaviours", "at", "tasks"}
    if unknown:
        raise ScriptError(f"{path}: unknown section(s) {sorted(unknown)}: "
                          "use tasks = [...], [behaviours.NAME] and [[at]]",
                          key=(sorted(unknown)[0],))
    tasks = doc.get("tasks", ["ictineu"])
    if isinstance(tasks, str):
        tasks = [tasks]
    if not isinstance(tasks, list) or not tasks or not all(
            isinstance(t, str) and t for t in tasks):
        raise ScriptError(f"{path}: tasks: must be a list of task libraries, e.g. "
                          "tasks = [\"ictineu\", \"seabed.tasks\"]", key=("tasks",))
    script.tasks = list(tasks)
    for name, table in (doc.get("behaviours") or {}).items():
        where = f"{path}: behaviours.{name}"
        key: Key = ("behaviours", name)
        if not isinstance(table, dict):
            raise ScriptError(f"{where}: must be a table", key=key)
        extra = set(table) - {"on_enable"}
        if extra:
            raise ScriptError(f"{where}: unknown key(s) {sorted(extra)}: use on_enable",
                              key=(*key, sorted(extra)[0]))
        spec = table.get("on_enable", [])
        items = spec if isinstance(spec, list) else [spec]
        script.answers[name] = [_answer(item, f"{where}.on_enable", (*key, "on_enable"))
                                for item in items]
    for i, item in enumerate(doc.get("at") or []):
        where = f"{path}: at[{i}]"
        if not isinstance(item, dict):
            raise ScriptError(f"{where}: must be a table with time and event", key=("at", i))
        t = _number(item.get("time"), f"{where}.time", ("at", i, "time"))
        event = item.get("event")
        if not isinstance(event, str) or event.count(".") != 1 or not all(
                p.isidentifier() for p in event.split(".")):
            raise ScriptError(f"{where}.event: must be 'Source.name', e.g. 'Alarms.leak'",
                              key=("at", i, "event"))
        script.at.append((t, event, _data(item.get("data"), f"{where}.data",
                                          ("at", i, "data"))))
    return script


def check_script(script: Script, declared: Mapping[str, Sequence[str]],
                 builtin: Sequence[str] = ("Link", "Mission")) -> None:
    """Every behaviour and event the script names must be declared (``declared``: behaviour
    -> its events, from the libraries in ``script.tasks``); else ScriptError at its line."""
    libraries = ", ".join(script.tasks)
    for name, answers in script.answers.items():
        named = re.escape(name)  # a name is never a pattern: "Go(To", "(x+x+)+y"
        line, col = _place(script.text, rf"^\s*\[\s*behaviours\.{named}\s*\]|(?<!\w){named}(?!\w)")
        if name not in declared:
            raise _unknown(script, line, col, f"behaviour '{name}' is not declared by this "
                           f"vehicle's task libraries ({libraries})",
                           f"declared behaviours: {', '.join(sorted(declared))}; declare "
                           "more with tasks = [...]")
        for answer in answers:
            if answer.event not in declared[name]:
                eline, ecol = _place(script.text, rf'"{re.escape(answer.event)}"', after=line)
                raise _unknown(script, eline, ecol, f"behaviour {name} has no event "
                               f"'{answer.event}' ({libraries})",
                               f"its events: {', '.join(declared[name]) or 'none'}")
    for _, event, _ in script.at:
        source, _, name = event.partition(".")
        if source in builtin:
            continue
        if source not in declared or name not in declared[source]:
            line, col = _place(script.text, rf'"{re.escape(event)}"')
            if source not in declared:
                raise _unknown(script, line, col, f"event {event}: behaviour '{source}' is "
                               f"not declared by this vehicle's task libraries ({libraries})",
                               f"declared behaviours: {', '.join(sorted(declared))}")
            raise _unknown(script, line, col, f"event {event}: behaviour {source} has no "
                           f"event '{name}' ({libraries})",
                           f"its events: {', '.join(declared[source]) or 'none'}")


def _place(text: str, pattern: str, after: int = 0) -> tuple[int, int]:
    """The 1-based line and column of the first match of ``pattern`` on or after line
    ``after`` (1, 1 if none: the file itself)."""
    for number, line in enumerate(text.splitlines(), start=1):
        if number < after:
            continue
        m = re.search(pattern, line)
        if m:
            return number, m.start() + 1 + (len(m.group(0)) - len(m.group(0).lstrip()))
    return 1, 1


def _answer(item: Any, where: str, key: Key = ()) -> Answer:
    if not isinstance(item, dict):
        raise ScriptError(f"{where}: must be {{ after = SECONDS, event = NAME }}", key=key)
    event = item.get("event")
    if not isinstance(event, str) or not event.isidentifier():
        raise ScriptError(f"{where}.event: must be an event name such as 'reached'",
                          key=(*key, "event"))
    return Answer(_number(item.get("after", 0.0), f"{where}.after", (*key, "after")), event,
                  _data(item.get("data"), f"{where}.data", (*key, "data")))


def _data(value: Any, where: str, key: Key) -> dict[str, Any]:
    """An event's ``data``: a table (none: empty)."""
    if value is None:
        return {}
    if not isinstance(value, dict):
        raise ScriptError(f"{where}: must be a table, e.g. data = {{ depth = 5.0 }}, got "
                          f"{type(value).__name__} {str(value)[:40]!r}", key=key)
    return dict(value)


def _number(value: Any, where: str, key: Key = ()) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or value < 0 \
            or value != value or value == float("inf"):
        raise ScriptError(f"{where}: must be a number of seconds >= 0, got {value!r}",
                          key=key)
    return float(value)


_TOML_AT = re.compile(r"\s*\(at line (\d+), column (\d+)\)$")


def _toml_error(path: str, text: str, exc: tomllib.TOMLDecodeError) -> ScriptError:
    """Invalid TOML: tomllib says the line and column at the end of its message."""
    m = _TOML_AT.search(str(exc))
    if m is None:  # "(at end of document)"
        lines = text.split("\n")
        line, col = len(lines), len(lines[-1]) + 1
        reason = re.sub(r"\s*\(at end of document\)$", "", str(exc))
    else:
        line, col, reason = int(m.group(1)), int(m.group(2)), str(exc)[:m.start()]
        lines = text.split("\n")
    return ScriptError(f"{path}: not valid TOML: {exc}", span=Span(path, line, col),
                       detail=f"not valid TOML: {reason}",
                       source_line=lines[line - 1] if 0 < line <= len(lines) else "",
                       hint="a scripted vehicle's file is TOML (https://toml.io), as "
                            "docs/VEHICLES.md describes", code="toml")


def _key_place(text: str, key: Key) -> tuple[int, int]:
    """The 1-based line and column where the TOML ``key`` (("at", 2, "time"),
    ("behaviours", "GoTo", "on_enable")) is written in ``text``; found key by key, each on or
    after the line of the one before; (1, 1) when the first is not found."""
    lines = text.split("\n")
    line, col, i = 1, 1, 0
    while i < len(key):
        part = key[i]
        if isinstance(part, int):  # an index not after an array name: skip it
            i += 1
            continue
        name = re.escape(part)
        if i + 1 < len(key) and isinstance(key[i + 1], int):  # the n-th [[name]]
            found = _find(lines, rf"^\s*\[\[\s*(?:[\w-]+\.)*({name})\s*\]\]", line,
                          nth=int(key[i + 1]))
            i += 2
        else:
            found = None
            for pattern in (rf"^\s*\[\s*(?:[\w-]+\.)*({name})\s*\]",  # [table.name]
                            rf"(?:^|[{{,.\s])({name})\s*=",  # name = ..., {{ name = ... }}
                            rf"\b({name})\b"):
                found = _find(lines, pattern, line)
                if found:
                    break
            i += 1
        if found is None:
            break
        line, col = found
    return line, col


def _find(lines: list[str], pattern: str, start: int, nth: int = 0) -> tuple[int, int] | None:
    """The line and column of group 1 of the ``nth`` match (from 0) on or after ``start``."""
    regex = re.compile(pattern)
    for number in range(max(start, 1), len(lines) + 1):
        m = regex.search(lines[number - 1])
        if m:
            if nth == 0:
                return number, m.start(1) + 1
            nth -= 1
    return None


@dataclass
class ScriptedVehicle:
    """The vehicle stack side: takes actions, produces events at simulated times."""

    script: Script
    _queue: list[tuple[float, int, str, str, dict[str, Any]]] = field(default_factory=list)
    _order: int = 0
    _generation: dict[str, int] = field(default_factory=dict)
    _seq: int = 0
    _on: set[str] = field(default_factory=set)  # behaviours enabled and not disabled

    def active(self) -> list[str]:
        """The behaviours on (enabled and not disabled since)."""
        return sorted(self._on)

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
        if action.kind == "disable":
            self._on.discard(b)
        if action.kind == "enable":
            self._on.add(b)
            for answer in self.script.answers.get(b, []):
                self._push(now + answer.after, f"{b}#{self._generation[b]}", b, answer.event,
                           answer.data)

    def next_time(self) -> float | None:
        self._drop_stale()
        return self._queue[0][0] if self._queue else None

    def due(self, t: float) -> list[EventMessage]:
        """The earliest event scheduled at or before t, if any: one at a time, so that an
        action the player sends on receiving it (a disable, a new enable) is applied before
        the next one is judged stale or not."""
        self._drop_stale()
        if not self._queue or self._queue[0][0] > t + 1e-9:
            return []
        when, _, _, event, data = heapq.heappop(self._queue)
        source, name = event.split(".")
        self._seq += 1
        return [EventMessage(self._seq - 1, when, source, name, data)]

    def _drop_stale(self) -> None:
        while self._queue:
            tag = self._queue[0][2]
            if tag:
                behaviour, gen = tag.split("#")
                if self._generation.get(behaviour) != int(gen):
                    heapq.heappop(self._queue)
                    continue
            break
