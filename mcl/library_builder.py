"""Read one task library: from the parse tree of a ``*.tasks`` file to its declarations.

The syntax is ``mcl/grammar/tasks.lark``; :class:`LibraryBuilder` makes the
:mod:`mcl.declarations` values of each ``behaviour`` and ``task``, checking each clause on its
own. What needs the whole library (behaviours named by tasks, degrees of freedom, call forms
that collide) is checked by the loader, mcl/tasklib.py.
"""

from __future__ import annotations


from diagnostics import Source, Span, error

from mcl import ast
from mcl.declarations import (
    ACTION_KINDS,
    ActionSpec,
    Behaviour,
    Estimate,
    Expr,
    Field,
    Formal,
    TaskForm,
)
from mcl.ast_builder import AstBuilder
from mcl.parser import suggest
from mcl.syntax import Token, Tree
from mcl.values import FIELDS, KINDS, NUMERIC, UNITS, Range, check, limits, to_text

# The event sources the player itself raises (mcl.declarations.BUILTIN_SOURCES), with what:
# a behaviour of one of these names would have its events taken for the player's.
RESERVED_BEHAVIOURS = {"Link": "Link.lost, when the link to the vehicle is lost",
                       "Mission": "Mission.abort, the external stop"}


class LibraryBuilder:
    """Turns the lark parse tree of one ``*.tasks`` file into declarations, refusing what
    the grammar lets through but the language does not (unknown kinds and actions, empty
    ranges, defaults of the wrong kind, a clause given twice)."""

    def __init__(self, source: Source):
        self.source = source
        self.values = AstBuilder(source)  # the value rules are the same as MCL's

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
        if str(name) in RESERVED_BEHAVIOURS:
            raise error(self.source, f"behaviour {name}: the name is reserved: the player "
                        f"itself raises {RESERVED_BEHAVIOURS[str(name)]}", self.span(name),
                        "give the behaviour another name", code="library-reserved")
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
        return self.values.value(node)
