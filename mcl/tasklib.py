"""The task library: behaviours and tasks declared in text (``*.tasks`` files), not in Python.

The syntax is ``mcl/grammar/tasks.lark``; the shipped libraries are ``mcl/tasks/core.tasks``
(timers, always loaded) and ``mcl/tasks/ictineu.tasks`` (the paper's nine tasks, the default
vehicle library). A user adds tasks for a new vehicle by writing a ``.tasks`` file and giving
it to ``mclc`` / ``mcl`` with ``--tasks FILE``.

What a library declares is checked when it loads: every behaviour a task names, every event,
every degree of freedom a behaviour drives (against the ``dofs`` declarations, or
:data:`DEFAULT_DOFS`), every range and default; see docs/TASKS.md.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import lru_cache
from importlib import resources

from lark import Lark, Token, Tree, UnexpectedInput

from diagnostics import Diagnostic, MclError, Source, Span, error, read_source
from petri.net import POINT_FIELDS

from mcl import ast
from mcl.values import FIELDS, KINDS, NUMERIC, UNITS, Range, check, limits, to_text

BUILTIN_SOURCES = ("Link", "Mission")  # events the player itself raises
ACTION_KINDS = ("enable", "disable", "configure")
# The degrees of freedom of a rigid body: what a behaviour may drive when no loaded library
# declares its own list with 'dofs NAME, ...;'.
DEFAULT_DOFS = ("x", "y", "z", "roll", "pitch", "yaw")


@dataclass(frozen=True)
class Field:
    """``target.x``: one coordinate of a point parameter."""

    formal: str
    field: str
    span: Span


Expr = ast.Value | Field


@dataclass(frozen=True)
class Formal:
    name: str
    kind: str | None  # None for a literal word (enable / disable)
    default: ast.Value | None
    span: Span
    range: Range | None = None  # numeric kinds: the values allowed
    field_defaults: tuple[tuple[str, ast.Value], ...] = ()  # point: trailing fields' defaults

    @property
    def fields(self) -> int:
        """How many fields a point given for this formal must have at least."""
        return len(FIELDS) - len(self.field_defaults)

    @property
    def text(self) -> str:
        if self.kind is None:
            return self.name
        kind = self.kind
        if self.field_defaults:
            kind += "(" + ", ".join(f"{k} = {to_text(v)}" for k, v in self.field_defaults) + ")"
        return (f"{self.name}: {kind}" + (f" {self.range.text}" if self.range else "")
                + (" = …" if self.default is not None else ""))


@dataclass(frozen=True)
class ActionSpec:
    kind: str
    behaviour: str
    bindings: tuple[tuple[str, Expr], ...]
    span: Span


@dataclass(frozen=True)
class Estimate:
    """``estimate:`` of a task (docs/DURATION.md): a nominal duration, never a proof.
    ``measure`` is "time" (``value`` is the duration), "distance" (from the previous point a
    task was sent to, to the point parameter ``formal``) or "length" (of the path parameter
    ``formal``); the last two are divided by ``speed`` (m/s)."""

    measure: str
    value: Expr | None = None
    formal: str = ""
    speed: float = 0.0
    span: Span = field(default=Span("<none>", 0, 0), compare=False)


@dataclass(frozen=True)
class TaskForm:
    """One call form of a task, e.g. ``KeepHeadDist(enable, heading, distance)``."""

    name: str
    formals: tuple[Formal, ...]
    start: tuple[ActionSpec, ...] = ()
    stop: tuple[ActionSpec, ...] = ()
    ok: tuple[str, ...] = ()
    fail: tuple[str, ...] = ()
    timeout: tuple[Expr, str] | None = None
    latch: str | None = None
    unlatch: str | None = None
    span: Span = field(default=Span("<none>", 0, 0), compare=False)
    estimate: Estimate | None = None

    @property
    def immediate(self) -> bool:
        """Ends at once (ok) after sending its start actions."""
        return not self.ok and not self.fail and self.timeout is None

    @property
    def signature(self) -> str:
        return f"{self.name}({', '.join(f.text for f in self.formals)})"

    def behaviours_on_while_running(self) -> tuple[str, ...]:
        return tuple(a.behaviour for a in self.start if a.kind == "enable")


@dataclass(frozen=True)
class Behaviour:
    name: str
    dofs: tuple[str, ...]
    events: tuple[str, ...]
    span: Span
    dof_spans: tuple[Span, ...] = field(default=(), compare=False)  # one per dof
    power: float | None = None  # watts drawn while on ('power N W'), None: not declared


@dataclass
class Library:
    behaviours: dict[str, Behaviour] = field(default_factory=dict)
    tasks: dict[str, list[TaskForm]] = field(default_factory=dict)
    files: list[str] = field(default_factory=list)
    declared_dofs: list[str] = field(default_factory=list)  # from 'dofs' declarations

    def dofs(self) -> dict[str, tuple[str, ...]]:
        return {b.name: b.dofs for b in self.behaviours.values()}

    @property
    def degrees_of_freedom(self) -> tuple[str, ...]:
        """The degrees of freedom behaviours may drive: those the libraries declare, or
        :data:`DEFAULT_DOFS` when none does."""
        return tuple(self.declared_dofs) or DEFAULT_DOFS


@lru_cache(maxsize=1)
def _lark() -> Lark:
    return Lark.open_from_package("mcl", "tasks.lark", ("grammar",), parser="lalr",
                                  propagate_positions=True, maybe_placeholders=True, cache=True,
                                  start="library")


SHIPPED = ("ictineu", "generic")


def is_shipped(name: str) -> bool:
    return name in SHIPPED


def _shipped(name: str) -> Source:
    text = resources.files("mcl").joinpath("tasks", name).read_text("utf-8")
    return Source(f"<mcl>/tasks/{name}", text)


def load(paths: list[str] | None = None) -> Library:
    """The core library plus the given ``.tasks`` files (default: the Ictineu library)."""
    sources = [_shipped("core.tasks")]
    paths = paths or ["ictineu"]
    sources += [_shipped(f"{p}.tasks") if is_shipped(p) else read_source(p) for p in paths]
    return load_sources(sources)


def load_sources(sources: list[Source]) -> Library:
    library = Library()
    pending: list[tuple[Source, TaskForm]] = []
    drivers: list[tuple[Source, Behaviour]] = []
    for source in sources:
        library.files.append(source.name)
        try:
            tree = _lark().parse(source.text)
        except UnexpectedInput as exc:
            raise error(source, "task library: " + _syntax_message(exc),
                        source.span(max(exc.line, 1), max(exc.column, 1)),
                        "see mcl/grammar/tasks.lark and docs/TASKS.md for the syntax",
                        code="library-syntax") from None
        from mcl.parser import _check_depth

        _check_depth(source, tree)
        builder = _Builder(source)
        for node in tree.children:
            assert isinstance(node, Tree)
            if node.data == "dofs":
                library.declared_dofs += [str(t) for t in node.children
                                          if str(t) not in library.declared_dofs]
            elif node.data == "behaviour":
                b = builder.behaviour(node)
                if b.name in library.behaviours:
                    raise error(source, f"behaviour {b.name} is declared twice", b.span,
                                code="library-duplicate")
                library.behaviours[b.name] = b
                drivers.append((source, b))
            else:
                pending.append((source, builder.task(node)))
    _check_dofs(library, drivers)  # 'dofs' may come after the behaviours, or in another file
    for source, form in pending:  # tasks may use behaviours declared in any file
        _validate(source, library, form)
        library.tasks.setdefault(form.name, []).append(form)
    return library


def _check_dofs(library: Library, drivers: list[tuple[Source, Behaviour]]) -> None:
    """Every degree of freedom a behaviour drives must be declared (a misspelt one would
    silently take the behaviour out of the dof-exclusive proof)."""
    from mcl.parser import suggest

    declared = library.degrees_of_freedom
    where = ("the declared ones: " if library.declared_dofs else
             "no library declares 'dofs NAME, ...;', so they are those of a rigid body: ")
    problems = []
    for source, b in drivers:
        seen: set[str] = set()
        for dof, span in zip(b.dofs, b.dof_spans):
            if dof in seen:
                problems.append(source.diagnostic(
                    "error", f"behaviour {b.name} drives '{dof}' twice", span,
                    "name each degree of freedom once", "library-dof"))
            elif dof not in declared:
                close = suggest(dof, list(declared))
                problems.append(source.diagnostic(
                    "error", f"behaviour {b.name} drives '{dof}', which is not a declared "
                    "degree of freedom", span,
                    (close + " " if close else "") + where + ", ".join(declared),
                    "library-dof"))
            seen.add(dof)
    if problems:
        raise MclError(problems)


def _syntax_message(exc: UnexpectedInput) -> str:
    token = getattr(exc, "token", None)
    if token is not None:
        return f"unexpected '{token}'"
    char = getattr(exc, "char", None)
    return f"unexpected character {char!r}" if char else "syntax error"


class _Builder:
    def __init__(self, source: Source):
        self.source = source

    def span(self, node: Tree[Token] | Token) -> Span:
        if isinstance(node, Token):
            return self.source.span(node.line or 1, node.column or 1,
                                    node.end_line or 0, node.end_column or 0)
        m = node.meta
        return self.source.span(getattr(m, "line", 1), getattr(m, "column", 1),
                                getattr(m, "end_line", 0), getattr(m, "end_column", 0))

    def behaviour(self, node: Tree[Token]) -> Behaviour:
        name, drives, events, power = node.children
        watts = None
        if isinstance(power, Tree):
            number = power.children[0]
            watts = float(str(number))
            if not 0 <= watts < float("inf"):
                raise error(self.source, f"behaviour {name}: power must be finite and >= 0 W, "
                            f"not {number} W", self.span(power), "e.g. 'power 120 W'",
                            code="library-power")
        tokens = [t for t in drives.children if isinstance(t, Token)] if isinstance(
            drives, Tree) else []
        evs = tuple(str(t) for t in events.children) if isinstance(events, Tree) else ()
        assert isinstance(name, Token)
        return Behaviour(str(name), tuple(str(t) for t in tokens), evs, self.span(name),
                         tuple(self.span(t) for t in tokens), watts)

    def task(self, node: Tree[Token]) -> TaskForm:
        name = node.children[0]
        assert isinstance(name, Token)
        formals: list[Formal] = []
        clauses: dict[str, object] = {}
        for child in node.children[1:]:
            if child is None:
                continue
            assert isinstance(child, Tree)
            if child.data == "formal":
                formals.append(self.formal(child))
                continue
            key = str(child.data)
            if key in clauses:
                raise error(self.source, f"task {name}: '{key}' is given twice",
                            self.span(child), "write each clause once", code="library-clause")
            clauses[key] = self.clause(child)
        timeout = clauses.get("timeout")
        return TaskForm(
            str(name), tuple(formals),
            start=tuple(clauses.get("start", ())),  # type: ignore[arg-type]
            stop=tuple(clauses.get("stop", ())),  # type: ignore[arg-type]
            ok=tuple(clauses.get("ok", ())),  # type: ignore[arg-type]
            fail=tuple(clauses.get("fail", ())),  # type: ignore[arg-type]
            timeout=timeout,  # type: ignore[arg-type]
            latch=clauses.get("latch"),  # type: ignore[arg-type]
            unlatch=clauses.get("unlatch"),  # type: ignore[arg-type]
            span=self.span(name),
            estimate=clauses.get("estimate"))  # type: ignore[arg-type]

    def formal(self, node: Tree[Token]) -> Formal:
        name, kind_node, range_node, default = node.children
        assert isinstance(name, Token)
        span = self.span(name)
        if kind_node is None:
            if str(name) not in ast.WORDS:
                raise error(self.source, f"parameter '{name}' has no kind",
                            span, f"write '{name}: KIND' with KIND one of {', '.join(KINDS)}",
                            code="library-kind")
            return Formal(str(name), None, None, span)
        assert isinstance(kind_node, Tree)
        kind, *defaults = kind_node.children
        assert isinstance(kind, Token)
        if str(kind) not in KINDS:
            from mcl.parser import suggest

            raise error(self.source, f"unknown kind '{kind}'", self.span(kind),
                        (suggest(str(kind), list(KINDS)) + " ").lstrip()
                        + f"kinds are {', '.join(KINDS)}", code="library-kind")
        value = self.value(default) if default is not None else None
        rng = self.range(str(name), str(kind), range_node) if range_node is not None else None
        fields = self.field_defaults(str(name), str(kind), kind,
                                     [d for d in defaults if isinstance(d, Tree)])
        return Formal(str(name), str(kind), value, span, rng, fields)

    def range(self, name: str, kind: str, node: Tree[Token] | Token) -> Range:
        """``in [LO, HI]``, ``>= LO`` or ``<= HI``: bounds of the formal's kind."""
        assert isinstance(node, Tree)
        if kind not in NUMERIC:
            raise error(self.source, f"parameter '{name}' is a {kind}: only a number, "
                        "length, angle or duration has a range", self.span(node),
                        "remove the range", code="library-range")
        bounds: list[float] = []
        for child in node.children:
            bound = self.value(child)
            assert isinstance(bound, ast.Number)
            problems = check(bound, kind, {}) + limits(bound, "list", {})
            if problems:
                raise error(self.source, f"range of '{name}': {problems[0].message}",
                            bound.span, f"a bound is a {kind}" + (
                                " (plain, or with a unit of the kind)" if kind != "number"
                                else " without a unit"), code="library-range")
            bounds.append(bound.value * UNITS[bound.unit][1] if bound.unit else bound.value)
        texts = [to_text(self.value(c)) for c in node.children]
        match node.data:
            case "range_in":
                if bounds[0] > bounds[1]:
                    raise error(self.source, f"range of '{name}' is empty: {texts[0]} is "
                                f"above {texts[1]}", self.span(node),
                                "write the lower bound first", code="library-range")
                return Range(bounds[0], bounds[1], f"in [{texts[0]}, {texts[1]}]")
            case "range_min":
                return Range(bounds[0], None, f">= {texts[0]}")
        return Range(None, bounds[0], f"<= {texts[0]}")

    def field_defaults(self, name: str, kind: str, kind_tok: Token,
                       nodes: list[Tree[Token]]) -> tuple[tuple[str, ast.Value], ...]:
        """``point(yaw = 0 deg)``: defaults of a point's last fields, in x, y, z, yaw order."""
        if not nodes:
            return ()
        if kind != "point":
            raise error(self.source, f"only a point has field defaults, not a {kind}",
                        self.span(kind_tok), f"write '{name}: {kind}'", code="library-kind")
        out: dict[str, ast.Value] = {}
        for node in nodes:
            key, value = node.children
            assert isinstance(key, Token)
            if str(key) not in FIELDS:
                raise error(self.source, f"a point has no field '{key}'", self.span(key),
                            f"its fields are {', '.join(FIELDS)}", code="library-kind")
            if str(key) in out:
                raise error(self.source, f"field '{key}' has two defaults", self.span(key),
                            code="library-kind")
            val = self.value(value)
            field_kind = "angle" if key == "yaw" else "length"
            problems = check(val, field_kind, {}) + limits(val, field_kind, {})
            if problems:
                raise error(self.source, f"default of {name}.{key}: {problems[0].message}",
                            problems[0].node.span, f"{key} is a {field_kind}",
                            code="library-kind")
            out[str(key)] = val
        first = len(FIELDS) - len(out)
        if set(out) != set(FIELDS[first:]):
            raise error(self.source, f"only the last fields of a point can have defaults "
                        f"(a point is written (x, y, z, yaw) in this order), not "
                        f"{', '.join(out)}", self.span(nodes[0]),
                        f"give defaults to {', '.join(FIELDS[first:])}", code="library-kind")
        return tuple((f, out[f]) for f in FIELDS[first:])

    def clause(self, node: Tree[Token]) -> object:
        kids = [c for c in node.children if c is not None]
        match node.data:
            case "start" | "stop":
                return [self.action(k) for k in kids if isinstance(k, Tree)]
            case "ok" | "fail":
                return [".".join(str(t) for t in k.children) for k in kids
                        if isinstance(k, Tree)]
            case "timeout":
                expr, status = kids
                if str(status) not in ("ok", "fail"):
                    raise error(self.source, f"a timeout ends 'ok' or 'fail', not '{status}'",
                                self.span(status), code="library-timeout")
                return (self.expr(expr), str(status))
            case "latch" | "unlatch":
                return str(kids[0])
            case "estimate":
                assert isinstance(kids[0], Tree)
                return self.estimate(kids[0])
        raise AssertionError(node.data)

    def estimate(self, node: Tree[Token]) -> Estimate:
        span = self.span(node)
        if node.data == "estimate_time":
            return Estimate("time", self.expr(node.children[0]), span=span)
        measure, formal, speed = (str(t) for t in node.children)
        if measure not in ("distance", "length"):
            raise error(self.source, f"estimate: unknown measure '{measure}'", span,
                        "write distance(POINT) / SPEED m/s or length(PATH) / SPEED m/s",
                        code="library-estimate")
        value = float(speed)
        if not 0 < value < float("inf"):
            raise error(self.source, f"estimate: a speed is finite and above 0 m/s, not {speed}",
                        span, code="library-estimate")
        return Estimate(measure, None, formal, value, span)

    def action(self, node: Tree[Token]) -> ActionSpec:
        kind, behaviour, *bindings = node.children
        assert isinstance(kind, Token) and isinstance(behaviour, Token)
        if str(kind) not in ACTION_KINDS:
            raise error(self.source, f"unknown action '{kind}'", self.span(kind),
                        "actions are enable, disable and configure", code="library-action")
        out: list[tuple[str, Expr]] = []
        for b in bindings:
            if b is None:
                continue
            assert isinstance(b, Tree)
            if b.data == "same_name":
                tok = b.children[0]
                assert isinstance(tok, Token)
                out.append((str(tok), ast.Ref(str(tok), self.span(tok))))
            else:
                key, expr = b.children
                out.append((str(key), self.expr(expr)))
        return ActionSpec(str(kind), str(behaviour), tuple(out), self.span(node))

    def expr(self, node: Tree[Token] | Token | None) -> Expr:
        if isinstance(node, Tree) and node.data == "field":
            formal, name = node.children
            return Field(str(formal), str(name), self.span(node))
        return self.value(node)

    def value(self, node: Tree[Token] | Token | None) -> ast.Value:
        # The value rules are the same as MCL's; reuse the mission builder.
        from mcl.parser import _Builder as MissionBuilder

        return MissionBuilder(self.source).value(node)


def _validate(source: Source, library: Library, form: TaskForm) -> None:
    """Every name a task declaration uses must exist and fit."""
    formals = {f.name: f for f in form.formals if f.kind is not None}
    problems: list[Diagnostic] = []

    def fail(message: str, span: Span, hint: str = "") -> None:
        problems.append(source.diagnostic("error", f"task {form.name}: {message}", span, hint,
                                          "library-check"))

    def check_expr(expr: Expr) -> None:
        if isinstance(expr, Field):
            f = formals.get(expr.formal)
            if f is None:
                fail(f"'{expr.formal}' is not a parameter of this task", expr.span)
            elif f.kind != "point" or expr.field not in POINT_FIELDS:
                fail(f"'{expr.formal}.{expr.field}': only the x, y, z, yaw of a point "
                     "parameter can be taken", expr.span)
        elif isinstance(expr, ast.Ref):
            if expr.name not in formals and expr.name not in ast.WORDS:
                fail(f"'{expr.name}' is not a parameter of this task", expr.span,
                     f"parameters: {', '.join(formals) or 'none'}")

    from mcl.parser import suggest

    behaviours = list(library.behaviours)
    for action in form.start + form.stop:
        if action.behaviour not in library.behaviours:
            fail(f"unknown behaviour '{action.behaviour}'", action.span,
                 (suggest(action.behaviour, behaviours) + " ").lstrip()
                 + "declare it with 'behaviour NAME drives ... events ...;'")
        for _, expr in action.bindings:
            check_expr(expr)
            if isinstance(expr, ast.Number | ast.ListValue | ast.Point):
                for p in limits(expr, "list", {}):
                    fail(p.message, p.node.span)
    for event in form.ok + form.fail:
        src, _, name = event.partition(".")
        b = library.behaviours.get(src)
        if src in BUILTIN_SOURCES:
            continue
        if b is None:
            fail(f"event '{event}' comes from an unknown behaviour", form.span,
                 (suggest(src, behaviours) + " ").lstrip()
                 + f"behaviours: {', '.join(behaviours) or 'none'}")
        elif name not in b.events:
            fail(f"behaviour {src} has no event '{name}'", form.span,
                 (suggest(name, list(b.events)) + " ").lstrip()
                 + f"its events: {', '.join(b.events) or 'none'}")
    if form.timeout is not None:
        expr, _ = form.timeout
        if isinstance(expr, ast.Ref):
            f = formals.get(expr.name)
            if f is None or f.kind != "duration":
                fail(f"timeout '{expr.name}' must be a duration parameter", expr.span)
        elif isinstance(expr, ast.Number):
            if expr.unit is not None and UNITS[expr.unit][0] != "duration":
                fail("a timeout is a duration (s, min, h)", expr.span)
            for p in limits(expr, "duration", {}):
                fail(f"timeout: {p.message}", expr.span)
        else:
            fail("a timeout is a duration or a duration parameter", form.span)
    est = form.estimate
    if est is not None:
        if est.measure == "time":
            if isinstance(est.value, ast.Ref):
                f = formals.get(est.value.name)
                if f is None or f.kind != "duration":
                    fail(f"estimate '{est.value.name}' must be a duration parameter", est.span)
            elif isinstance(est.value, ast.Number):
                if est.value.unit is None or UNITS[est.value.unit][0] != "duration":
                    fail("an estimate is a duration (s, min, h)", est.span)
                for p in limits(est.value, "duration", {}):
                    fail(f"estimate: {p.message}", est.span)
            else:
                fail("an estimate is a duration, a duration parameter, distance(POINT) / "
                     "SPEED m/s or length(PATH) / SPEED m/s", est.span)
        else:
            want = "point" if est.measure == "distance" else "path"
            f = formals.get(est.formal)
            if f is None or f.kind != want:
                fail(f"estimate: {est.measure}() takes a {want} parameter of this task, not "
                     f"'{est.formal}'", est.span)
    for latched in (form.latch, form.unlatch):
        if latched is not None and latched not in library.behaviours:
            fail(f"latch of unknown behaviour '{latched}'", form.span)
    if form.latch and not form.immediate:
        fail("a task that latches a behaviour must end at once (no ok, fail or timeout)",
             form.span)
    for f in form.formals:
        if f.default is not None and f.kind is not None:
            wrong = check(f.default, f.kind, {})
            for p in wrong or limits(f.default, f.kind, {}, f.range, f.fields):
                fail(f"default of '{f.name}': {p.message}", p.node.span)
    words = tuple((i, f.name) for i, f in enumerate(form.formals) if f.kind is None)
    for other in library.tasks.get(form.name, []):
        other_words = tuple((i, f.name) for i, f in enumerate(other.formals) if f.kind is None)
        if other_words == words and _arity(other) == _arity(form):
            fail(f"this call form is the same as the one at {other.span}", form.span,
                 "give each form of a task different words (enable / disable) or arities")
    if problems:
        raise MclError(problems)


def _arity(form: TaskForm) -> tuple[int, int]:
    required = sum(1 for f in form.formals if f.kind is None or f.default is None)
    return required, len(form.formals)
