"""Kinds of values, units, and turning MCL values into the JSON that actions carry.

Kinds a task parameter can declare:

==========  ============================================  ==========================
kind        written as                                    carried as
==========  ============================================  ==========================
number      ``3``, ``-1.5``                               float
length      ``1.5 m``, ``20 cm`` (plain numbers: metres)  float, metres
angle       ``90 deg``, ``1.2 rad`` (plain: degrees)      float, degrees
duration    ``30 s``, ``2 min`` (plain: seconds)          float, seconds
point       ``(x, y, z, yaw)``: every field, or those    list of floats
            before a field the library gives a default
path        ``[(y, z), ...]`` (2–4 numbers each); a path   list of points
            parameter inside
            a list is spliced in: ``[path]``
list        ``[a, b, ...]``                               list
==========  ============================================  ==========================

Every number must be finite once converted to its base unit (``1e308 h`` is not), a duration
is never negative, and a task library may declare a closed range for a numeric formal
(:class:`Range`, checked by :func:`limits`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from mcl import ast

KINDS = ("number", "length", "angle", "duration", "point", "path", "list")
UNITS: dict[str, tuple[str, float]] = {
    "m": ("length", 1.0), "cm": ("length", 0.01), "mm": ("length", 0.001),
    "km": ("length", 1000.0),
    "deg": ("angle", 1.0), "rad": ("angle", 57.29577951308232),
    "s": ("duration", 1.0), "ms": ("duration", 0.001), "min": ("duration", 60.0),
    "h": ("duration", 3600.0),
}
NUMERIC = ("number", "length", "angle", "duration")
BASE_UNIT = {"number": "", "length": "metres", "angle": "degrees", "duration": "seconds"}
FIELDS = ("x", "y", "z", "yaw")  # the fields of a point, in order


@dataclass(frozen=True)
class Problem:
    """A value that does not fit what it is given for: why, the value, and the parameter it came
    from."""

    message: str
    node: ast.Value
    param: str | None = None  # the mission parameter whose value it is, if any
    code: str = ""  # the kind of problem (limits): number-out-of-range, negative-duration, ...


@dataclass(frozen=True)
class Range:
    """A closed range a task library declares for a numeric formal, in base units (None:
    unbounded on that side). ``text`` is the range as written, e.g. ``in [0 m, 100 m]``."""

    low: float | None
    high: float | None
    text: str

    def __contains__(self, x: float) -> bool:
        return (self.low is None or x >= self.low) and (self.high is None or x <= self.high)


def base(number: ast.Number) -> float:
    """A number in its base unit (metres, degrees, seconds)."""
    return number.value * UNITS[number.unit][1] if number.unit in UNITS else number.value


def describe(value: ast.Value) -> str:
    match value:
        case ast.Number(unit=None):
            return "a number"
        case ast.Number(unit=u):
            return f"a {UNITS[u][0]} ({u})" if u in UNITS else "a number"
        case ast.Ref(name=n):
            return f"'{n}'"
        case ast.ListValue():
            return "a list"
        case ast.Point(items=items):
            return f"a point of {len(items)}"
    return "a value"


def check(value: ast.Value, kind: str, param_kinds: dict[str, str]) -> list[Problem]:
    """Problems with giving ``value`` where ``kind`` is expected. References to mission
    parameters are recorded in ``param_kinds`` (their kind is the kind of their first use)."""
    if isinstance(value, ast.Ref):
        if value.name in ast.WORDS:
            return [Problem(f"'{value.name}' is a word, but a {kind} is expected here", value)]
        known = param_kinds.setdefault(value.name, kind)
        if known != kind and not (kind == "list" or {known, kind} <= {"path", "list"}):
            return [Problem(f"parameter '{value.name}' is used as a {kind} here but as a "
                            f"{known} elsewhere", value)]
        return []
    if kind in NUMERIC:
        if not isinstance(value, ast.Number):
            return [Problem(f"expected a {kind}, got {describe(value)}", value)]
        if value.unit is None:
            return []
        unit_kind = UNITS[value.unit][0]
        if kind == "number" or unit_kind != kind:
            return [Problem(f"expected a {kind}, got {describe(value)}", value)]
        return []
    if kind == "point":
        if not isinstance(value, ast.Point) or not 2 <= len(value.items) <= 4:
            return [Problem(f"expected a point (x, y, z, yaw) of 2 to 4 numbers, got "
                            f"{describe(value)}", value)]
        problems = []
        for i, item in enumerate(value.items):
            item_kind = "angle" if i == 3 else "length"
            problems += check(item, item_kind, param_kinds)
        return problems
    if kind == "path":
        if not isinstance(value, ast.ListValue):
            return [Problem(f"expected a path [(y, z), ...], got {describe(value)}", value)]
        problems = []
        for item in value.items:
            if isinstance(item, ast.Ref):  # a path parameter spliced into the list
                problems += check(item, "path", param_kinds)
            else:
                problems += check(item, "point", param_kinds)
        return problems
    if kind == "list":
        if not isinstance(value, ast.ListValue):
            return [Problem(f"expected a list [a, b, ...], got {describe(value)}", value)]
        return []
    raise ValueError(f"unknown kind {kind}")


def limits(value: ast.Value, kind: str, env: dict[str, ast.Value], rng: Range | None = None,
           fields: int = len(FIELDS)) -> list[Problem]:
    """Problems with the value ``value`` takes (following mission parameters through
    ``env``) where a ``kind`` is expected: a number not finite in its base unit, a negative
    duration, a number outside ``rng``, a point with fewer than ``fields`` fields. A value
    whose parameter has no value yet has no problem yet: it is checked when it gets one.
    Call after :func:`check` found the value's shape right (a wrong shape is skipped)."""
    if isinstance(value, ast.Number):  # the common case first
        return _number(value, kind, rng) if kind in NUMERIC else _limits(value, kind, env,
                                                                          rng, fields)
    param = None
    for _ in range(len(env) + 1):
        if not isinstance(value, ast.Ref) or value.name in ast.WORDS:
            break
        if value.name not in env:
            return []
        param, value = value.name, env[value.name]
    else:
        return []  # a cycle: reported by the checker
    found = _limits(value, kind, env, rng, fields)
    return [Problem(p.message, p.node, p.param or param, p.code) for p in found]


def _limits(value: ast.Value, kind: str, env: dict[str, ast.Value], rng: Range | None,
            fields: int) -> list[Problem]:
    if kind in NUMERIC:
        return _number(value, kind, rng) if isinstance(value, ast.Number) else []
    if kind == "point":
        if not isinstance(value, ast.Point):
            return []
        problems = []
        if len(value.items) < fields:
            missing = FIELDS[len(value.items):fields]
            verb = "is" if len(missing) == 1 else "are"
            shape = ", ".join(FIELDS[:fields]) + "".join(f"[, {f}]" for f in FIELDS[fields:])
            problems.append(Problem(f"the point {to_text(value)} has {len(value.items)} "
                                    f"fields: {_and(missing)} {verb} missing (a point here "
                                    f"is ({shape}))", value, code="missing-field"))
        for i, item in enumerate(value.items):
            item_kind = "angle" if i == 3 else "length"
            problems += (_number(item, item_kind, None) if isinstance(item, ast.Number)
                         else limits(item, item_kind, env))
        return problems
    if kind in ("path", "list") and isinstance(value, ast.ListValue | ast.Point):
        problems = []
        for item in value.items:
            if kind == "path" and isinstance(item, ast.Ref):  # a spliced path parameter
                problems += limits(item, "path", env)
            elif kind == "path" and isinstance(item, ast.Point):
                problems += limits(item, "point", env, fields=0)
            else:
                problems += limits(item, "list", env)
        return problems
    if kind == "list" and isinstance(value, ast.Number):
        return _number(value, UNITS[value.unit][0] if value.unit in UNITS else "number", None)
    return []


def _and(words: tuple[str, ...]) -> str:
    return words[0] if len(words) == 1 else ", ".join(words[:-1]) + " and " + words[-1]


def _number(value: ast.Number, kind: str, rng: Range | None) -> list[Problem]:
    x = value.value * UNITS[value.unit][1] if value.unit in UNITS else value.value
    if -math.inf < x < math.inf and (x >= 0 or kind != "duration") and rng is None:
        return []  # the common case: nothing to say
    if not math.isfinite(x):
        unit = BASE_UNIT.get(kind, "")
        return [Problem(f"{to_text(value)} is too large: it is not a finite number"
                        + (f" of {unit}" if unit else ""), value, code="number-out-of-range")]
    if kind == "duration" and x < 0:
        return [Problem(f"a duration cannot be negative, got {to_text(value)}", value,
                        code="negative-duration")]
    if rng is not None and x not in rng:
        return [Problem(f"{to_text(value)} is out of range: it must be {rng.text}", value,
                        code="value-out-of-range")]
    return []


class Unresolved(Exception):
    """A parameter has no value yet (fine when only checking a mission)."""

    def __init__(self, name: str):
        super().__init__(name)
        self.name = name


def evaluate(value: ast.Value, kind: str, env: dict[str, ast.Value]) -> object:
    """The JSON value of an MCL value, in base units; raises Unresolved for a parameter
    without a value."""
    for _ in range(len(env) + 1):  # follow a chain of parameters without recursing
        if not isinstance(value, ast.Ref):
            break
        if value.name not in env:
            raise Unresolved(value.name)
        value = env[value.name]
    else:
        raise ValueError("parameters refer to each other in a cycle")
    match value:
        case ast.Number(value=v, unit=u):
            return v * UNITS[u][1] if u else v
        case ast.Point(items=items):
            return [evaluate(it, "angle" if i == 3 else "length", env)
                    for i, it in enumerate(items)]
        case ast.ListValue(items=items):
            out: list[object] = []
            for it in items:
                if kind == "path" and isinstance(it, ast.Ref):
                    spliced = evaluate(it, "path", env)
                    out.extend(spliced if isinstance(spliced, list) else [spliced])
                else:
                    out.append(evaluate(it, "point" if kind == "path" else "list", env))
            return out
    raise ValueError(f"cannot evaluate {value!r}")


def to_text(value: ast.Value) -> str:
    """MCL source for a value (used by the pretty-printer and in messages)."""
    match value:
        case ast.Number(value=v, unit=u):
            num = repr(int(v)) if v == int(v) and abs(v) < 1e15 else repr(v)
            return f"{num} {u}" if u else num
        case ast.Ref(name=n):
            return n
        case ast.ListValue(items=items):
            return "[" + ", ".join(to_text(i) for i in items) + "]"
        case ast.Point(items=items):
            return "(" + ", ".join(to_text(i) for i in items) + ")"
    raise ValueError(f"not a value: {value!r}")
