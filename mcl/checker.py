"""Check a mission against the task library: every call, every argument, every parameter.

The result, :class:`Checked`, is what the compiler needs: for each call the task form it
resolves to and its arguments by formal name, and the value of every mission parameter that
has one. All problems are collected and reported together.

Values are checked twice: their shape against the kind a formal declares (:func:`values.check`),
then, once every mission parameter that has a value has it (from ``PARAM``, ``--param`` or
``--params``), the numbers they carry (:func:`values.limits`: finite, durations not negative,
in the formal's declared range, points with every field the formal needs). A parameter left
without a value is checked when it gets one (``mcl run`` compiles with every value).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from diagnostics import Diagnostic, MclError, Source, Span

from mcl import ast
from mcl.parser import KEYWORDS, suggest
from mcl.declarations import Formal, Library, TaskForm
from mcl.fleet_tasks import FLEET_TASKS, FleetScope, Problem, fleet_form
from mcl.values import FIELDS, check, describe, limits, to_text


@dataclass(frozen=True)
class _Use:
    """A value given to a formal (or as a per-call timeout), to check once parameters are
    known."""

    call: ast.Call
    formal: Formal | None  # None: the per-call timeout
    value: ast.Value


@dataclass(frozen=True)
class Resolved:
    """A task call resolved against its library: the task form it calls and its arguments."""

    form: TaskForm
    args: dict[str, ast.Value]  # formal name -> value given (or its default)
    timeout: ast.Value | None = None  # a per-call timeout (named argument timeout = ...)


@dataclass
class Checked:
    """A mission checked against its task libraries, with what the checks resolved."""

    mission: ast.Mission
    library: Library
    source: Source
    calls: dict[int, Resolved] = field(default_factory=dict)  # id(Call) -> resolution
    params: dict[str, ast.Value] = field(default_factory=dict)  # parameter -> value
    param_kinds: dict[str, str] = field(default_factory=dict)
    diagnostics: list[Diagnostic] = field(default_factory=list)
    # what the analyses computed of this mission, kept so that each runs once per mission
    # (mcl.analysis.duration.analyse: the verifier, the duration report and the time limit)
    memo: dict[str, Any] = field(default_factory=dict, repr=False, compare=False)
    fleet: FleetScope | None = None  # a vehicle of a fleet: its channels

    def resolved(self, call: ast.Call) -> Resolved:
        return self.calls[id(call)]

    @property
    def unset(self) -> list[str]:
        return sorted(p for p in self.param_kinds if p not in self.params)


def check_mission(mission: ast.Mission, library: Library, source: Source,
                  overrides: dict[str, tuple[ast.Value, Source]] | None = None,
                  require_values: bool = False, fleet: FleetScope | None = None) -> Checked:
    """Raise MclError listing every error; warnings are kept in ``Checked.diagnostics``.
    ``fleet``: the mission is a vehicle's in a fleet (``Send`` and ``Receive`` are known)."""
    checked = Checked(mission, library, source, fleet=fleet)
    c = _Checker(checked, source)
    for call in mission.calls():
        c.call(call)
    if mission.on_stop is not None:
        c.stop_handler(mission.on_stop)
    c.parameters(overrides or {}, require_values)
    c.limits()
    if any(d.severity == "error" for d in c.diagnostics):
        raise MclError(sorted(c.diagnostics, key=_order))
    checked.diagnostics = sorted(c.diagnostics, key=_order)
    return checked


def _order(d: Diagnostic) -> tuple[int, int, int]:
    span = d.span or Span("", 0, 0)
    return (0 if d.severity == "error" else 1, span.line, span.col)


class _Checker:
    def __init__(self, checked: Checked, source: Source):
        self.checked = checked
        self.source = source
        self.diagnostics: list[Diagnostic] = []
        self.uses: list[_Use] = []
        self.sources = {source.name: source}  # where the spans of values come from

    def error(self, message: str, span: Span, hint: str = "", code: str = "",
              source: Source | None = None) -> None:
        self.diagnostics.append((source or self.source).diagnostic("error", message, span,
                                                                    hint, code))

    def warn(self, message: str, span: Span, hint: str = "", code: str = "") -> None:
        self.diagnostics.append(self.source.diagnostic("warning", message, span, hint, code))

    # -- the stop handler -------------------------------------------------------------------
    def stop_handler(self, handler: ast.Block) -> None:
        """ON STOP runs once the mission's blocks have stopped and switched off every latched
        behaviour: it may not latch one itself (what it switches on, it must switch off)."""
        for call in ast.calls(handler):
            if id(call) not in self.checked.calls:
                continue  # an unknown task: already reported
            form = self.checked.resolved(call).form
            if form.latch:
                message = (f"{call.name}(...) switches {form.latch} on and leaves it on: ON "
                           "STOP cannot latch a behaviour")
            elif form.unlatch:
                message = (f"{call.name}(...) switches {form.unlatch} off: in ON STOP every "
                           "behaviour of the mission is off already")
            else:
                continue
            self.error(message, call.span, "the stop handler runs once every block of the "
                       "mission has stopped and switched off what it had on; use tasks that "
                       "end by themselves, such as Surface()", code="stop-handler-latch")

    # -- calls ------------------------------------------------------------------------------
    def call(self, call: ast.Call) -> None:
        if self.checked.fleet is not None and call.name in FLEET_TASKS:
            self.fleet_call(call, self.checked.fleet)
            return
        forms = self.checked.library.tasks.get(call.name)
        if forms is None:
            if call.name.upper() in KEYWORDS:
                self.error(f"keywords are upper case: write {call.name.upper()}", call.span,
                           code="lower-case-keyword")
                return
            hint = suggest(call.name, list(self.checked.library.tasks))
            self.error(f"unknown task '{call.name}'", _name_span(call),
                       hint or "declare it in a task library and pass it with --tasks FILE",
                       code="unknown-task")
            return
        positional = [a for a in call.args if a.name is None]
        named: dict[str | None, ast.Arg] = {}
        for a in call.args:
            if a.name is not None:
                if a.name in named:
                    self.error(f"argument '{a.name}' is given twice", a.span,
                               "give each argument once", code="duplicate-argument")
                    return
                named[a.name] = a
        for i, a in enumerate(call.args):
            if a.name is None and any(b.name is not None for b in call.args[:i]):
                self.error("a positional argument after a named one", a.span,
                           "put named arguments (name = value) last", code="arg-order")
                return
        candidates = [f for f in forms if _fits(f, positional, named)]
        if not candidates:
            signatures = " | ".join(f.signature for f in forms)
            self.error(f"no form of {call.name} takes these arguments", _name_span(call),
                       f"{call.name} is called as: {signatures}", code="bad-arguments")
            return
        form = candidates[0]
        for formal, _ in zip(form.formals, positional):
            if formal.name in named:
                self.error(f"argument '{formal.name}' is given twice", named[formal.name].span,
                           "it is already given by position", code="duplicate-argument")
                return
        args: dict[str, ast.Value] = {}
        for formal, arg in zip(form.formals, positional):
            if formal.kind is not None:
                args[formal.name] = arg.value
        timeout = None
        for name, arg in named.items():
            if name == "timeout" and name not in {f.name for f in form.formals}:
                if form.immediate:
                    self.error(f"{call.name} ends at once: a timeout means nothing here",
                               arg.span, "remove 'timeout = ...'", code="bad-timeout")
                timeout = arg.value
                problems = check(arg.value, "duration", self.checked.param_kinds)
                for p in problems:
                    self.error(p.message, p.node.span, code="bad-argument")
                if not problems:
                    self.uses.append(_Use(call, None, arg.value))
            elif name is not None:
                args[name] = arg.value
        for formal in form.formals:
            if formal.kind is None:
                continue
            if formal.name not in args:
                assert formal.default is not None
                args[formal.name] = formal.default
                if formal.field_defaults:  # a default point may leave fields to defaults
                    self.uses.append(_Use(call, formal, formal.default))
                continue
            problems = check(args[formal.name], formal.kind, self.checked.param_kinds)
            for p in problems:
                self.error(f"argument '{formal.name}' of {call.name}: {p.message}",
                           p.node.span, f"{call.name} takes {formal.text}",
                           code="bad-argument")
            if not problems:
                self.uses.append(_Use(call, formal, args[formal.name]))
        self.checked.calls[id(call)] = Resolved(form, args, timeout)

    def fleet_call(self, call: ast.Call, scope: FleetScope) -> None:
        """``Send`` and ``Receive`` in a fleet's vehicle (mcl/fleet_tasks.py)."""
        resolved = fleet_form(call, scope, _name_span(call))
        if isinstance(resolved, Problem):
            self.error(resolved.message, resolved.span, resolved.hint, code=resolved.code)
            return
        form, timeout = resolved
        if timeout is not None:
            problems = check(timeout, "duration", self.checked.param_kinds)
            for p in problems:
                self.error(p.message, p.node.span, code="bad-argument")
            if not problems:
                self.uses.append(_Use(call, None, timeout))
        self.checked.calls[id(call)] = Resolved(form, {}, timeout)

    # -- the numbers values carry -----------------------------------------------------------
    def limits(self) -> None:
        """Check every value given to a formal, as it is once parameters have their values;
        fill in the fields a point leaves to the defaults its formal declares."""
        params = self.checked.params
        reported: set[tuple[str, int, int, str]] = set()
        for use in self.uses:
            formal = use.formal
            kind = formal.kind if formal is not None and formal.kind else "duration"
            rng = formal.range if formal is not None else None
            fields = formal.fields if formal is not None else len(FIELDS)
            what = (f"argument '{formal.name}' of {use.call.name}" if formal is not None
                    else f"timeout of {use.call.name}")
            for p in limits(use.value, kind, params, rng, fields):
                span = p.node.span
                key = (span.file, span.line, span.col, p.message)
                if key in reported:
                    continue
                reported.add(key)
                via = f" (the value of parameter '{p.param}')" if p.param else ""
                self.error(f"{what}: {p.message}{via}", span,
                           _limit_hint(p.code, formal, use.call), code=p.code,
                           source=self.sources.get(span.file))
            if formal is not None and formal.field_defaults:
                self._fill(use, formal)

    def _fill(self, use: _Use, formal: Formal) -> None:
        """A point with fewer fields than four gets the defaults of the rest."""
        value = use.value
        for _ in range(len(self.checked.params) + 1):
            if not isinstance(value, ast.Ref) or value.name not in self.checked.params:
                break
            value = self.checked.params[value.name]
        if not isinstance(value, ast.Point) or not formal.fields <= len(value.items) < 4:
            return
        defaults = dict(formal.field_defaults)
        filled = value.items + tuple(defaults[f] for f in FIELDS[len(value.items):])
        resolved = self.checked.calls.get(id(use.call))
        if resolved is not None:
            resolved.args[formal.name] = ast.Point(filled, value.span)

    # -- parameters -------------------------------------------------------------------------
    def _cycles(self, declared: dict[str, ast.Param]) -> None:
        """A parameter whose value refers, directly or not, to itself has no value."""
        params = self.checked.params
        for start in sorted(params):
            if start not in params:  # already dropped as part of an earlier cycle
                continue
            stack = [(start, iter(_refs(params[start])))]
            seen = {start}
            while stack:  # depth first over references; each parameter is entered once
                nxt = next(stack[-1][1], None)
                if nxt is None:
                    stack.pop()
                elif nxt == start:
                    chain = " -> ".join([*(n for n, _ in stack), start])
                    span = declared[start].span if start in declared else None
                    self.error(f"parameter '{start}' refers to itself ({chain})",
                               span or self.checked.mission.span,
                               "give it a value that does not depend on itself",
                               code="param-cycle")
                    for name, _ in stack:
                        params.pop(name, None)
                    break
                elif nxt in params and nxt not in seen:
                    seen.add(nxt)
                    stack.append((nxt, iter(_refs(params[nxt]))))

    def parameters(self, overrides: dict[str, tuple[ast.Value, Source]],
                   require_values: bool) -> None:
        kinds = self.checked.param_kinds
        params = self.checked.params
        declared: dict[str, ast.Param] = {}
        for _, origin in overrides.values():
            self.sources.setdefault(origin.name, origin)
        for p in self.checked.mission.params:
            if p.name in declared:
                self.error(f"parameter '{p.name}' is declared twice (first at "
                           f"{declared[p.name].span})", p.span, code="duplicate-param")
                continue
            declared[p.name] = p
            if p.name in ast.WORDS:
                self.error(f"'{p.name}' is a reserved word", p.span, code="reserved-word")
            if p.value is not None:
                params[p.name] = p.value
        for name, (value, origin) in overrides.items():
            if name not in kinds:
                hint = suggest(name, sorted(kinds)) or (
                    f"the mission's parameters: {', '.join(sorted(kinds)) or 'none'}")
                self.error(f"unknown parameter '{name}'", origin.span(value.span.line, 1), hint,
                           code="unknown-param", source=origin)
                continue
            params[name] = value
        # A parameter whose value names another passes its kind on (PARAM b = a;).
        for _ in range(len(params) + 1):
            before = dict(kinds)
            for name, value in params.items():
                if name in kinds:
                    check(value, kinds[name], kinds)
            if kinds == before:
                break
        for p in declared.values():
            if p.name not in kinds:
                self.warn(f"parameter '{p.name}' is declared but never used", p.span,
                          code="unused-param")
        self._cycles(declared)
        # Each value must suit the way the parameter is used.
        for name, value in list(params.items()):
            if name not in kinds:
                continue
            for problem in check(value, kinds[name], {}):
                where = declared[name].span if name in declared and value is declared[
                    name].value else problem.node.span
                self.error(f"parameter '{name}' is used as a {kinds[name]} but its value "
                           f"is {describe(value)}: {problem.message}", where,
                           code="bad-param-value", source=self.sources.get(where.file))
        uses = _first_uses(self.checked.mission)
        for name in sorted(kinds):
            if name not in params:
                span = uses.get(name, self.checked.mission.span)
                text = f"parameter '{name}' has no value"
                hint = f"declare it (PARAM {name} = ...;) or give --param {name}=VALUE"
                if require_values:
                    self.error(text, span, hint, code="unset-param")
                else:
                    self.warn(text, span, hint, code="unset-param")


def _limit_hint(code: str, formal: Formal | None, call: ast.Call) -> str:
    if code == "missing-field" and formal is not None:
        example = "(x, y, z, yaw), e.g. (0 m, 0 m, 2 m, 0 deg)"
        if formal.field_defaults:
            given = ", ".join(f"{k} = {to_text(v)}" for k, v in formal.field_defaults)
            return f"write {example}; the task library gives defaults only for {given}"
        return (f"write every field {example}; a task library may give the last fields "
                f"defaults: '{formal.name}: point(yaw = 0 deg)'")
    if code == "negative-duration":
        return "a duration is a time from now: 0 s or more"
    if code == "value-out-of-range" and formal is not None:
        return f"{call.name} takes {formal.text}"
    return "numbers must be finite in metres, degrees and seconds: use a smaller value"


def _refs(value: ast.Value) -> list[str]:
    match value:
        case ast.Ref(name=n) if n not in ast.WORDS:
            return [n]
        case ast.ListValue(items=items) | ast.Point(items=items):
            return [r for i in items for r in _refs(i)]
    return []


def _fits(form: TaskForm, positional: list[ast.Arg], named: dict[str | None, ast.Arg]) -> bool:
    if len(positional) > len(form.formals):
        return False
    for formal, arg in zip(form.formals, positional):
        is_word = isinstance(arg.value, ast.Ref) and arg.value.name in ast.WORDS
        if formal.kind is None:
            if not (is_word and isinstance(arg.value, ast.Ref)
                    and arg.value.name == formal.name):
                return False
        elif is_word:
            return False
    rest = form.formals[len(positional):]
    names = {f.name for f in form.formals if f.kind is not None}
    if any(n not in names and n != "timeout" for n in named):
        return False
    return all(f.kind is not None and (f.default is not None or f.name in named) for f in rest)


def _name_span(call: ast.Call) -> Span:
    s = call.span
    return Span(s.file, s.line, s.col, s.line, s.col + len(call.name))


def _first_uses(mission: ast.Mission) -> dict[str, Span]:
    uses: dict[str, Span] = {}

    def visit(v: ast.Value) -> None:
        match v:
            case ast.Ref(name=n) if n not in ast.WORDS:
                uses.setdefault(n, v.span)
            case ast.ListValue(items=items) | ast.Point(items=items):
                for i in items:
                    visit(i)

    for call in mission.calls():
        for a in call.args:
            visit(a.value)
    return uses
