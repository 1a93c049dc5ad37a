"""Hypothesis strategies for MCL: random *valid* missions as ASTs, and random text mutations.

Three families of missions:

* :func:`ictineu_missions`: task calls of the shipped library (``core.tasks`` and
  ``ictineu.tasks``) with valid arguments, literal or through mission parameters (every
  parameter a mission refers to is declared, with a value of the right kind or none), an
  optional mission name and an optional ``USES "ictineu";``.
* :func:`generic_missions`: calls of ``tests.support.GENERIC_TASKS`` (A() .. D(), Now(),
  Lamp(enable) / Lamp(disable)), small enough for the verifier to explore.
* :func:`route_missions` over :func:`route_libraries`: random task libraries whose behaviours
  share degrees of freedom, latch, or watch (drive nothing), with 0 s and 1 s timers.

Block shapes follow the AST's rules: a Sequence has two or more items and is never an item of
another Sequence (a braced block of several items is only ever the child of a construct);
PARALLEL has two or more branches; IF with and without ELSE. Size is bounded by a budget of
task calls, depth by a number of nested constructs.
"""

from __future__ import annotations

import re
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from hypothesis import strategies as st

from mcl import ast
from mcl.parser import KEYWORDS

# -- numbers and values -------------------------------------------------------------------
# Finite floats only: every one of them prints (repr) and parses back to itself.
NUMBERS = st.one_of(
    st.integers(-1000, 1000).map(float),
    st.floats(-1e4, 1e4, allow_nan=False, allow_infinity=False),
    # bounded so that any unit (km, h, rad) keeps them finite in base units
    st.floats(-1e300, 1e300, allow_nan=False, allow_infinity=False),
)
NON_NEGATIVE = st.one_of(
    st.integers(0, 1000).map(float),
    st.floats(0, 1e6, allow_nan=False, allow_infinity=False),
)

UNITS_OF = {
    "length": (None, "m", "cm", "mm", "km"),
    "angle": (None, "deg", "rad"),
    "duration": (None, "s", "ms", "min", "h"),
}

# Mission parameters by the kind of their use. Each name has one kind, so uses never clash.
# 'm' and 's' look like units: they are names wherever a value is expected.
PARAMS_OF = {
    "length": ("d", "m", "altitude"),
    "angle": ("h", "heading"),
    "duration": ("maxTime", "s"),
    "point": ("initialPos", "home"),
    "path": ("lane", "survey"),
}
KIND_OF_PARAM = {name: kind for kind, names in PARAMS_OF.items() for name in names}


def literal(kind: str) -> st.SearchStrategy[ast.Value]:
    """A literal value of a kind (no parameter references)."""
    if kind in UNITS_OF:
        # lengths too: the shipped library declares tolerance, distance >= 0 m
        numbers = NON_NEGATIVE if kind in ("duration", "length") else NUMBERS
        return st.builds(ast.Number, numbers, st.sampled_from(UNITS_OF[kind]))
    if kind == "point":  # every field: (x, y, z, yaw)
        return st.tuples(*[literal("angle" if i == 3 else "length")
                           for i in range(4)]).map(ast.Point)
    if kind == "path":
        return st.lists(literal("point"), max_size=4).map(lambda ps: ast.ListValue(tuple(ps)))
    raise ValueError(kind)


def value(kind: str, with_params: bool) -> st.SearchStrategy[ast.Value]:
    """A value that the checker accepts where a ``kind`` is expected."""
    refs = (st.sampled_from(PARAMS_OF[kind]).map(ast.Ref) if with_params else st.nothing())
    if kind in UNITS_OF:
        return st.one_of(literal(kind), refs)
    # (x, y, z, yaw): lengths and an angle, each literal or a parameter
    point = st.integers(2, 4).flatmap(lambda n: st.tuples(
        *[value("angle" if i == 3 else "length", with_params) for i in range(n)])).map(ast.Point)
    if kind == "point":  # a point argument has every field (x, y, z, yaw)
        return st.one_of(st.tuples(*[value("angle" if i == 3 else "length", with_params)
                                     for i in range(4)]).map(ast.Point), refs)
    if kind == "path":
        # a path parameter may also be spliced into a list: [lane, (1, 2)] (a name in the
        # list is always a path, never a point parameter)
        items = st.lists(st.one_of(point, refs), max_size=4)
        return st.one_of(items.map(lambda xs: ast.ListValue(tuple(xs))), refs)
    raise ValueError(kind)


# -- task calls of the shipped library ---------------------------------------------------
def _call(name: str, positional: list[ast.Value],
          named: list[tuple[str, ast.Value]] | None = None) -> ast.Call:
    named = named or []
    args = [ast.Arg(v) for v in positional] + [ast.Arg(v, n) for n, v in named]
    return ast.Call(name, tuple(args))


def _word(w: str) -> ast.Value:
    return ast.Ref(w)


@st.composite
def _optional_named(draw: st.DrawFn, options: dict[str, st.SearchStrategy[ast.Value]]
                    ) -> list[tuple[str, ast.Value]]:
    """Some of the named arguments, in any order (each at most once)."""
    chosen = [n for n in options if draw(st.booleans())]
    chosen = draw(st.permutations(chosen)) if chosen else []
    return [(n, draw(options[n])) for n in chosen]


@st.composite
def ictineu_calls(draw: st.DrawFn, with_params: bool = True) -> ast.Call:
    """One call of a task of core.tasks / ictineu.tasks, with arguments that fit its form."""
    def v(kind: str) -> st.SearchStrategy[ast.Value]:
        return value(kind, with_params)

    timeout = {"timeout": v("duration")}
    kind = draw(st.sampled_from([
        "Surface", "Alarms", "KeepHeadDistException", "Wait", "Timeout", "GoTo",
        "AchieveHeadDist", "KeepHeadDist(enable)", "KeepHeadDist(disable)",
        "StartCamera", "StartLogs", "WallInspect"]))
    match kind:
        case "Surface" | "Alarms" | "KeepHeadDistException":
            return _call(kind, [], draw(_optional_named(timeout)))
        case "Wait" | "Timeout":
            if draw(st.booleans()):
                return _call(kind, [draw(v("duration"))])
            return _call(kind, [], [("duration", draw(v("duration")))])
        case "GoTo":
            how = draw(st.sampled_from(["positional", "tolerance", "named"]))
            if how == "positional":
                return _call(kind, [draw(v("point"))], draw(_optional_named(
                    {"tolerance": v("length"), **timeout})))
            if how == "tolerance":
                return _call(kind, [draw(v("point")), draw(v("length"))],
                             draw(_optional_named(timeout)))
            named = [("target", draw(v("point")))] + draw(_optional_named(
                {"tolerance": v("length"), **timeout}))
            return _call(kind, [], draw(st.permutations(named)))
        case "AchieveHeadDist":
            return _call(kind, [draw(v("angle")), draw(v("length"))],
                         draw(_optional_named(timeout)))
        case "KeepHeadDist(enable)":
            return _call("KeepHeadDist", [_word("enable"), draw(v("angle")), draw(v("length"))])
        case "KeepHeadDist(disable)":
            return _call("KeepHeadDist", [_word("disable")])
        case "StartCamera" | "StartLogs":
            return _call(kind, [_word(draw(st.sampled_from(ast.WORDS)))])
        case "WallInspect":
            return _call(kind, [draw(v("path"))], draw(_optional_named(timeout)))
    raise AssertionError(kind)


# -- generic calls (tests.support.GENERIC_TASKS) ------------------------------------------
LAMP_ON = ast.Call("Lamp", (ast.Arg(ast.Ref("enable")),))
LAMP_OFF = ast.Call("Lamp", (ast.Arg(ast.Ref("disable")),))


def generic_calls(lone_lamp_on: bool) -> st.SearchStrategy[ast.Call]:
    names = st.sampled_from(["A", "B", "C", "D", "Now"]).map(lambda n: ast.Call(n, ()))
    lamps = [LAMP_OFF] + ([LAMP_ON] if lone_lamp_on else [])
    return st.one_of(names, st.sampled_from(lamps))


# -- blocks -------------------------------------------------------------------------------
# construct -> the number of child blocks (each holds at least one call)
CONSTRUCTS = {"TRY": 3, "AND": 2, "OR": 2, "IF": 2, "IFELSE": 3, "WHILE": 2}


class _Shape:
    """Draws blocks within a budget of task calls and a depth of nested constructs."""

    def __init__(self, draw: st.DrawFn, leaf: st.SearchStrategy[ast.Call], max_depth: int,
                 lamp_pairs: bool):
        self.draw, self.leaf, self.max_depth, self.lamp_pairs = draw, leaf, max_depth, lamp_pairs

    def block(self, depth: int, budget: int) -> tuple[ast.Block, int]:
        """A braced block using 1..budget calls: one item, or a Sequence of several."""
        draw = self.draw
        pair = self.lamp_pairs and budget >= 2 and draw(st.booleans())
        if pair:
            budget -= 2
        n = draw(st.integers(0 if pair else 1, min(3, budget))) if budget else 0
        items: list[ast.Block] = []
        used = 0
        for i in range(n):
            item, u = self.item(depth, budget - used - (n - i - 1))
            items.append(item)
            used += u
        if pair:
            # Lamp(enable) somewhere in the sequence, Lamp(disable) somewhere after it: the
            # sequence runs every item whatever the status of the one before, so only an
            # abort can stop it in between, and an abort must switch the lamp off.
            on = draw(st.integers(0, len(items)))
            off = draw(st.integers(on, len(items)))
            items.insert(off, LAMP_OFF)
            items.insert(on, LAMP_ON)
            used += 2
        return (items[0] if len(items) == 1 else ast.Sequence(tuple(items))), used

    def item(self, depth: int, budget: int) -> tuple[ast.Block, int]:
        """One item of a block (never a Sequence) using 1..budget calls."""
        draw = self.draw
        kinds = ["call"]
        if depth < self.max_depth:
            kinds += [k for k, n in CONSTRUCTS.items() if n <= budget]
            kinds += ["AND3", "OR3"] if budget >= 3 else []
        kind = draw(st.sampled_from(kinds))
        if kind == "call":
            return draw(self.leaf), 1
        n = {"AND3": 3, "OR3": 3}.get(kind, CONSTRUCTS.get(kind, 0))
        children: list[ast.Block] = []
        used = 0
        for i in range(n):
            child, u = self.block(depth + 1, budget - used - (n - i - 1))
            children.append(child)
            used += u
        match kind:
            case "TRY":
                return ast.TryCatchDo(children[0], children[1], children[2]), used
            case "AND" | "AND3":
                return ast.ParallelAnd(tuple(children)), used
            case "OR" | "OR3":
                return ast.ParallelOr(tuple(children)), used
            case "IF":
                return ast.IfThenElse(children[0], children[1], None), used
            case "IFELSE":
                return ast.IfThenElse(children[0], children[1], children[2]), used
            case "WHILE":
                return ast.WhileDo(children[0], children[1]), used
        raise AssertionError(kind)


def bodies(leaf: st.SearchStrategy[ast.Call], max_depth: int, max_calls: int,
           lamp_pairs: bool = False) -> st.SearchStrategy[ast.Block]:
    @st.composite
    def body(draw: st.DrawFn) -> ast.Block:
        budget = draw(st.integers(1, max_calls))
        return _Shape(draw, leaf, max_depth, lamp_pairs).block(0, budget)[0]
    return body()


# -- missions -----------------------------------------------------------------------------
NAMES = st.from_regex(r"\A[A-Za-z_][A-Za-z0-9_]{0,12}\Z").filter(
    lambda n: n not in KEYWORDS)


def refs_in(v: ast.Value) -> list[str]:
    match v:
        case ast.Ref(name=n):
            return [] if n in ast.WORDS else [n]
        case ast.ListValue(items=items) | ast.Point(items=items):
            return [r for i in items for r in refs_in(i)]
    return []


def used_params(body: ast.Block) -> list[str]:
    """Mission parameters a body refers to, in order of first use."""
    seen: dict[str, None] = {}
    for c in ast.calls(body):
        for a in c.args:
            for r in refs_in(a.value):
                seen.setdefault(r, None)
    return list(seen)


@st.composite
def ictineu_missions(draw: st.DrawFn, max_depth: int = 3, max_calls: int = 10,
                     with_params: bool = True) -> ast.Mission:
    body = draw(bodies(ictineu_calls(with_params), max_depth, max_calls))
    names = used_params(body)
    names = draw(st.permutations(names)) if names else []
    params = tuple(ast.Param(n, draw(st.one_of(st.none(), literal(KIND_OF_PARAM[n]))))
                   for n in names)
    name = draw(st.one_of(st.none(), NAMES))
    uses = (ast.Uses("ictineu"),) if draw(st.booleans()) else ()
    return ast.Mission(name, body, params, uses=uses)


def generic_missions(max_depth: int = 3, max_calls: int = 6,
                     lamps: str = "paired") -> st.SearchStrategy[ast.Mission]:
    """``lamps``: "paired" (every Lamp(enable) followed later in its own sequence by a
    Lamp(disable); lone Lamp(disable) allowed) or "free" (lone Lamp(enable) allowed)."""
    leaf = generic_calls(lone_lamp_on=lamps == "free")
    return st.builds(ast.Mission, st.one_of(st.none(), NAMES),
                     bodies(leaf, max_depth, max_calls, lamp_pairs=lamps == "paired"))


# -- mutations of program text ------------------------------------------------------------
TOKEN = re.compile(r'"[^"\n]*"|//[^\n]*|/\*|\*/|[A-Za-z_][A-Za-z0-9_]*'
                   r"|[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?|\S")
KEYWORD = re.compile(r"\b(?:" + "|".join(KEYWORDS) + r")\b")
# characters worth trying: controls (no NUL), line and paragraph separators, a BOM, letters
# and symbols outside ASCII, and MCL's own punctuation
ODD_CHARACTERS = (
    [chr(c) for c in range(1, 32)] + ["\x7f", "\x85", "\xa0", "\u2028", "\u2029", "\ufeff",
                                      "é", "ß", "Ω", "→", "°", "µ", "中", "😀", "\u200b"]
    + list("{}()[];,=.\"/*-+_#$@'")
)
CHARACTERS = st.one_of(
    st.sampled_from(ODD_CHARACTERS),
    st.characters(codec="utf-8", exclude_characters="\x00"),  # no surrogates
)

Draw = Callable[..., Any]  # st.DrawFn, or st.DataObject.draw
Mutation = Callable[[Draw, str], str]


def _tokens(text: str) -> list[re.Match[str]]:
    return list(TOKEN.finditer(text))


def _delete_char(draw: Draw, text: str) -> str:
    if not text:
        return text
    i = draw(st.integers(0, len(text) - 1))
    return text[:i] + text[i + 1:]


def _delete_token(draw: Draw, text: str) -> str:
    toks = _tokens(text)
    if not toks:
        return text
    t = draw(st.sampled_from(toks))
    return text[:t.start()] + text[t.end():]


def _duplicate_token(draw: Draw, text: str) -> str:
    toks = _tokens(text)
    if not toks:
        return text
    t: re.Match[str] = draw(st.sampled_from(toks))
    sep: str = draw(st.sampled_from(["", " "]))
    return text[:t.end()] + sep + t.group() + text[t.end():]


def _swap_tokens(draw: Draw, text: str) -> str:
    toks = _tokens(text)
    if len(toks) < 2:
        return text
    i = draw(st.integers(0, len(toks) - 2))
    j = draw(st.integers(i + 1, len(toks) - 1))
    a, b = toks[i], toks[j]
    return (text[:a.start()] + b.group() + text[a.end():b.start()] + a.group()
            + text[b.end():])


def _lower_keyword(draw: Draw, text: str) -> str:
    found = list(KEYWORD.finditer(text))
    if not found:
        return text
    k = draw(st.sampled_from(found))
    word: str = draw(st.sampled_from([k.group().lower(), k.group().capitalize()]))
    return text[:k.start()] + word + text[k.end():]


def _insert_char(draw: Draw, text: str) -> str:
    i = draw(st.integers(0, len(text)))
    char: str = draw(CHARACTERS)
    return text[:i] + char + text[i:]


def _token_class(tok: str) -> str:
    if tok[0].isalpha() or tok[0] == "_":
        return "name"
    if tok[0].isdigit() or tok[0] in "+-." and len(tok) > 1:
        return "number"
    return "other"


def _substitute_token(draw: Draw, text: str) -> str:
    """Replace a token by another of the same class found in the text (a name by a name, a
    number by a number): mostly still parses, so the checker and the compiler get tried."""
    toks = [t for t in _tokens(text) if _token_class(t.group()) != "other"]
    if not toks:
        return text
    t = draw(st.sampled_from(toks))
    others = sorted({u.group() for u in toks
                     if _token_class(u.group()) == _token_class(t.group())} - {t.group()})
    if not others:
        return text
    other: str = draw(st.sampled_from(others))
    return text[:t.start()] + other + text[t.end():]


def _truncate(draw: Draw, text: str) -> str:
    return text[:draw(st.integers(0, len(text)))]


MUTATIONS: dict[str, Mutation] = {
    "delete-char": _delete_char,
    "delete-token": _delete_token,
    "duplicate-token": _duplicate_token,
    "swap-tokens": _swap_tokens,
    "substitute-token": _substitute_token,
    "lower-keyword": _lower_keyword,
    "insert-char": _insert_char,
    "truncate": _truncate,
}


@st.composite
def mutated(draw: st.DrawFn, texts: st.SearchStrategy[str], max_mutations: int = 3
            ) -> tuple[str, list[str]]:
    """A text from ``texts`` after 1..max_mutations random mutations (and their names)."""
    text = draw(texts)
    applied = []
    for name in draw(st.lists(st.sampled_from(sorted(MUTATIONS)), min_size=1,
                              max_size=max_mutations)):
        text = MUTATIONS[name](draw, text)
        applied.append(name)
    return text, applied


def concurrency(block: ast.Block) -> int:
    """At most how many waiting tasks (not Now() nor Lamp(...)) can run at the same time: the
    state space grows with it (four generic tasks, nested in two PARALLELs, reach 290,000
    markings; with two more calls in sequence, 900,000)."""
    match block:
        case ast.Call(name=n):
            return 0 if n in ("Now", "Lamp") else 1
        case ast.ParallelAnd(branches=bs) | ast.ParallelOr(branches=bs):
            return sum(concurrency(b) for b in bs)
    return max(concurrency(c) for c in ast.children(block))


# -- arbitrary (mostly invalid) missions: for the checker ---------------------------------
TASK_NAMES = ("Surface", "Alarms", "KeepHeadDistException", "Wait", "Timeout", "GoTo",
              "AchieveHeadDist", "KeepHeadDist", "StartCamera", "StartLogs", "WallInspect",
              "Surfce", "goto", "try", "Lamp")
ARG_NAMES = ("target", "tolerance", "timeout", "duration", "heading", "distance", "path",
             "enable", "x")
ANY_NAMES = tuple(KIND_OF_PARAM) + ast.WORDS + ("undeclared",)

any_values: st.SearchStrategy[ast.Value] = st.recursive(
    st.one_of(
        st.builds(ast.Number, NUMBERS, st.sampled_from((None, "m", "cm", "mm", "km", "deg",
                                                         "rad", "s", "ms", "min", "h"))),
        st.sampled_from(ANY_NAMES).map(ast.Ref)),
    lambda inner: st.one_of(
        st.lists(inner, max_size=4).map(lambda xs: ast.ListValue(tuple(xs))),
        st.lists(inner, min_size=2, max_size=5).map(lambda xs: ast.Point(tuple(xs)))),
    max_leaves=6)


@st.composite
def any_calls(draw: st.DrawFn) -> ast.Call:
    positional = draw(st.lists(any_values, max_size=4))
    named = draw(st.lists(st.tuples(st.sampled_from(ARG_NAMES), any_values), max_size=2))
    args = [ast.Arg(v) for v in positional] + [ast.Arg(v, n) for n, v in named]
    if draw(st.booleans()):  # now and then a positional argument after a named one
        args = draw(st.permutations(args))
    return ast.Call(draw(st.sampled_from(TASK_NAMES)), tuple(args))


@st.composite
def any_missions(draw: st.DrawFn) -> ast.Mission:
    """Well-formed syntax, arbitrary meaning: unknown tasks, wrong arguments, parameters
    undeclared, declared twice, unused, of the wrong kind, or defined by other parameters."""
    body = draw(bodies(st.one_of(any_calls(), ictineu_calls()), max_depth=2, max_calls=4))
    names = used_params(body) + draw(st.lists(st.sampled_from(ANY_NAMES[:-1]), max_size=3))
    names = draw(st.permutations(names)) if names else []

    def any_value_for(name: str) -> st.SearchStrategy[ast.Value | None]:
        right = literal(KIND_OF_PARAM[name]) if name in KIND_OF_PARAM else st.nothing()
        return st.one_of(st.none(), right, any_values)

    params = tuple(ast.Param(n, draw(any_value_for(n))) for n in names)
    on_stop = draw(st.one_of(st.none(), bodies(st.one_of(any_calls(), ictineu_calls()),
                                               max_depth=1, max_calls=2)))  # ON STOP
    return ast.Mission(draw(st.one_of(st.none(), NAMES)), body, params, on_stop=on_stop)


# -- custom task libraries: degrees of freedom shared, latches, watchers (tests/mcl/test_routes.py)
ROUTE_DOFS = ("x", "z", "yaw")


@dataclass(frozen=True)
class RouteLibrary:
    """A random task library (``text``, a .tasks file) and the calls a mission may make of
    it: waiting tasks that switch on one or two behaviours (which may share a degree of
    freedom), latches and unlatches, watchers (behaviours that drive nothing), an immediate
    task, and core timers of 0 s and 1 s."""

    text: str
    calls: tuple[ast.Call, ...]


@st.composite
def route_libraries(draw: st.DrawFn) -> RouteLibrary:
    n = draw(st.integers(2, 4))
    dofs = [draw(st.lists(st.sampled_from(ROUTE_DOFS), max_size=2, unique=True))
            for _ in range(n)]
    lines = [f"behaviour B{i}" + (f" drives {', '.join(d)}" if d else "") + " events ok, fail;"
             for i, d in enumerate(dofs)]
    calls: list[ast.Call] = [ast.Call("Now", ()),
                             ast.Call("Wait", (ast.Arg(ast.Number(0.0, "s")),)),
                             ast.Call("Wait", (ast.Arg(ast.Number(1.0, "s")),))]
    lines.append("task Now() { }")
    for j in range(draw(st.integers(1, 3))):
        on = draw(st.lists(st.integers(0, n - 1), min_size=1, max_size=2, unique=True))
        first = f"B{on[0]}"
        clauses = [f"start: {', '.join(f'enable B{i}' for i in on)};"]
        ok, fail = draw(st.booleans()), draw(st.booleans())
        timeout = draw(st.sampled_from([None, "0 s -> ok", "0 s -> fail", "1 s -> ok",
                                        "1 s -> fail"]))
        if not (ok or fail or timeout):
            ok = True  # a task that waits (one that ends at once cannot hold a behaviour)
        clauses += [f"ok: {first}.ok;"] if ok else []
        clauses += [f"fail: {first}.fail;"] if fail else []
        clauses += [f"timeout: {timeout};"] if timeout else []
        clauses.append(f"stop: {', '.join(f'disable B{i}' for i in on)};")
        lines.append(f"task T{j}() {{ {' '.join(clauses)} }}")
        calls.append(ast.Call(f"T{j}", ()))
    for i in draw(st.lists(st.integers(0, n - 1), max_size=2, unique=True)):
        lines.append(f"task L{i}(enable) {{ start: enable B{i}; latch: B{i}; }}")
        lines.append(f"task L{i}(disable) {{ start: disable B{i}; unlatch: B{i}; }}")
        calls += [ast.Call(f"L{i}", (ast.Arg(ast.Ref("enable")),)),
                  ast.Call(f"L{i}", (ast.Arg(ast.Ref("disable")),))]
    return RouteLibrary("\n".join(lines) + "\n", tuple(calls))


def route_missions(library: RouteLibrary, max_depth: int = 2, max_calls: int = 5
                   ) -> st.SearchStrategy[ast.Mission]:
    """Missions over a :func:`route_libraries` library (small enough to enumerate)."""
    return bodies(st.sampled_from(library.calls), max_depth, max_calls).map(
        lambda body: ast.Mission(None, body))
