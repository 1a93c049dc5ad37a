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

import os
from functools import lru_cache
from pathlib import Path
from typing import TYPE_CHECKING

import diagnostics
from diagnostics import Diagnostic, MclError, Source, Span, error, file_error, read_source
from petri import net as petri_net
from petri.net import POINT_FIELDS

from mcl import ast, cache, grammars
from mcl.declarations import (
    ACTION_KINDS,
    BUILTIN_SOURCES,
    DEFAULT_DOFS,
    ActionSpec,
    Behaviour,
    Estimate,
    Expr,
    Field,
    Formal,
    Library,
    TaskForm,
)
from mcl.library_builder import LibraryBuilder
from mcl.parser import check_depth, suggest
from mcl.syntax import Token, Tree
from mcl.values import UNITS, check, limits

if TYPE_CHECKING:
    from lark import Lark, UnexpectedInput

# The declarations, importable from here too (mcl.tasklib.Library, ...).
__all__ = ["ACTION_KINDS", "BUILTIN_SOURCES", "DEFAULT_DOFS", "SHIPPED", "ActionSpec",
           "Behaviour", "Estimate", "Expr", "Field", "Formal", "Library", "TaskForm",
           "LIBRARY_FILES", "is_library_file", "is_shipped", "load", "load_sources",
           "not_a_library", "parse_library", "shipped_source"]


@lru_cache(maxsize=1)
def _lark() -> Lark:
    return grammars.parser("tasks.lark", parser="lalr", propagate_positions=True,
                           maybe_placeholders=True, start="library")


SHIPPED = ("ictineu", "generic")
SHIPPED_PREFIX = "<mcl>/tasks/"  # the name of a shipped library's source
# The code a library is built by: the key of a cached library holds its text, with the
# grammar's and lark's version (mcl/cache.py).
BUILDER_CODE = (Path(__file__).parent, Path(diagnostics.__file__).parent,
                Path(petri_net.__file__))


def is_shipped(name: str) -> bool:
    """A library shipped with mcl, named without ``.tasks`` (``USES "ictineu";``)."""
    return name in SHIPPED


LIBRARY_FILES = "a task library is a file whose name ends in .tasks (its content was not read)"


def is_library_file(path: str) -> bool:
    """A path that may name a task library: a ``.tasks`` file. Nothing else is read as one,
    so that a syntax error never quotes a line of a file that is not (``/etc/passwd``)."""
    return not_a_library(path) is None


def not_a_library(path: str) -> str | None:
    """Why ``path`` is not read as a task library, or None: its name does not end in
    ``.tasks``, or it is a symbolic link to a file whose name does not (``evil.tasks`` ->
    ``/etc/shadow``: a syntax error would quote the file's first line)."""
    if not path.endswith(".tasks"):
        return LIBRARY_FILES
    target = os.path.realpath(path)
    if not target.endswith(".tasks"):
        return (f"a task library is a file whose name ends in .tasks, and this is a link to "
                f"{target!r} (its content was not read)")
    return None


def shipped_source(name: str) -> Source:
    """A file shipped in mcl/tasks/ (e.g. ``core.tasks``) as a source."""
    # beside this module (mcl is installed as files): importlib.resources cost 10 ms a call
    text = (Path(__file__).parent / "tasks" / name).read_text("utf-8")
    return Source(SHIPPED_PREFIX + name, text)


def load(paths: list[str] | None = None) -> Library:
    """The core library plus the given ``.tasks`` files (default: the Ictineu library)."""
    sources = [shipped_source("core.tasks")]
    paths = paths or ["ictineu"]
    for path in paths:
        if not (is_shipped(path) or is_library_file(path)):
            raise file_error(path, f"is not a task library: {not_a_library(path)}",
                             f"--tasks takes a .tasks file or a shipped library: "
                             f"{', '.join(SHIPPED)}", code="not-a-library")
    sources += [shipped_source(f"{p}.tasks") if is_shipped(p) else read_source(p)
                for p in paths]
    return load_sources(sources)


def load_sources(sources: list[Source]) -> Library:
    """The library the sources declare, checked; :class:`MclError` lists its problems.
    Libraries shipped with mcl are parsed and checked once, then loaded from the cache
    (mcl/cache.py) under the key of their texts, the grammar's, lark's version and the code
    that builds them."""
    if not sources or not all(s.name.startswith(SHIPPED_PREFIX) for s in sources):
        return build_library(sources)
    name = "library-" + "+".join(s.name.removeprefix(SHIPPED_PREFIX).removesuffix(".tasks")
                                 for s in sources)
    return cached_library(name, sources)


def cached_library(name: str, sources: list[Source]) -> Library:
    """The library of ``sources`` (:func:`build_library`), kept in the cache's entry ``name``
    under the key of their names and texts, the grammar's, lark's version and the code that
    builds it: parsed and checked once for each."""
    def parts() -> list[str | bytes]:
        return [*(f"{s.name}\0{s.text}" for s in sources), grammars.grammar_text("tasks.lark"),
                grammars.lark_version(), cache.code_digest(BUILDER_CODE)]

    return cache.cached(name, parts, lambda: build_library(sources))


def build_library(sources: list[Source]) -> Library:
    """Parse and check the sources into a library (no cache)."""
    library = Library()
    pending: list[tuple[Source, TaskForm]] = []
    drivers: list[tuple[Source, Behaviour]] = []
    for source in sources:
        library.files.append(source.name)
        tree = parse_library(source)
        builder = LibraryBuilder(source)
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


def parse_library(source: Source) -> Tree[Token]:
    """The parse tree of a ``.tasks`` file; an :class:`MclError` at the first syntax error
    (what it declares is not checked: see :func:`build_library`)."""
    import lark  # lazy for start-up speed: the shipped libraries come from the cache

    try:
        tree = _lark().parse(source.text)
    except lark.UnexpectedInput as exc:
        raise error(source, "task library: " + _syntax_message(exc),
                    source.span(max(exc.line, 1), max(exc.column, 1)),
                    "see mcl/grammar/tasks.lark and docs/TASKS.md for the syntax",
                    code="library-syntax") from None
    check_depth(source, tree)
    return tree


def _check_dofs(library: Library, drivers: list[tuple[Source, Behaviour]]) -> None:
    """Every degree of freedom a behaviour drives must be declared (a misspelt one would
    silently take the behaviour out of the dof-exclusive proof)."""
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
    if token is not None and getattr(token, "type", None) == "$END":
        return "the file ends inside a declaration (a ';' or a '}' is missing)"
    if token is not None:
        return f"unexpected '{token}'"
    char = getattr(exc, "char", None)
    return f"unexpected character {char!r}" if char else "syntax error"


def _validate(source: Source, library: Library, form: TaskForm) -> None:
    """Every name a task declaration uses must exist and fit; MclError lists every problem."""
    check = _FormCheck(source, library, form)
    check.actions()
    check.events()
    check.timeout()
    check.estimate()
    check.latches()
    check.defaults_and_forms()
    if check.problems:
        raise MclError(check.problems)


class _FormCheck:
    """The checks of one call form against the whole library, each clause on its own."""

    def __init__(self, source: Source, library: Library, form: TaskForm):
        self.source, self.library, self.form = source, library, form
        self.formals = {f.name: f for f in form.formals if f.kind is not None}
        self.behaviours = list(library.behaviours)
        self.problems: list[Diagnostic] = []

    def fail(self, message: str, span: Span, hint: str = "") -> None:
        self.problems.append(self.source.diagnostic(
            "error", f"task {self.form.name}: {message}", span, hint, "library-check"))

    def expr(self, expr: Expr) -> None:
        """An action's parameter: a point's field, a parameter of the task, or a value."""
        if isinstance(expr, Field):
            f = self.formals.get(expr.formal)
            if f is None:
                self.fail(f"'{expr.formal}' is not a parameter of this task", expr.span)
            elif f.kind != "point" or expr.field not in POINT_FIELDS:
                self.fail(f"'{expr.formal}.{expr.field}': only the x, y, z, yaw of a point "
                          "parameter can be taken", expr.span)
        elif isinstance(expr, ast.Ref):
            if expr.name not in self.formals and expr.name not in ast.WORDS:
                self.fail(f"'{expr.name}' is not a parameter of this task", expr.span,
                          f"parameters: {', '.join(self.formals) or 'none'}")

    def actions(self) -> None:
        for action in self.form.start + self.form.stop:
            if action.behaviour not in self.library.behaviours:
                self.fail(f"unknown behaviour '{action.behaviour}'", action.span,
                          (suggest(action.behaviour, self.behaviours) + " ").lstrip()
                          + "declare it with 'behaviour NAME drives ... events ...;'")
            for _, expr in action.bindings:
                self.expr(expr)
                if isinstance(expr, ast.Number | ast.ListValue | ast.Point):
                    for p in limits(expr, "list", {}):
                        self.fail(p.message, p.node.span)

    def events(self) -> None:
        form = self.form
        for event in form.ok + form.fail:
            src, _, name = event.partition(".")
            b = self.library.behaviours.get(src)
            if src in BUILTIN_SOURCES:
                continue
            if b is None:
                self.fail(f"event '{event}' comes from an unknown behaviour", form.span,
                          (suggest(src, self.behaviours) + " ").lstrip()
                          + f"behaviours: {', '.join(self.behaviours) or 'none'}")
            elif name not in b.events:
                self.fail(f"behaviour {src} has no event '{name}'", form.span,
                          (suggest(name, list(b.events)) + " ").lstrip()
                          + f"its events: {', '.join(b.events) or 'none'}")

    def timeout(self) -> None:
        if self.form.timeout is None:
            return
        expr, _ = self.form.timeout
        if isinstance(expr, ast.Ref):
            f = self.formals.get(expr.name)
            if f is None or f.kind != "duration":
                self.fail(f"timeout '{expr.name}' must be a duration parameter", expr.span)
        elif isinstance(expr, ast.Number):
            if expr.unit is not None and UNITS[expr.unit][0] != "duration":
                self.fail("a timeout is a duration (s, min, h)", expr.span)
            for p in limits(expr, "duration", {}):
                self.fail(f"timeout: {p.message}", expr.span)
        else:
            self.fail("a timeout is a duration or a duration parameter", self.form.span)

    def estimate(self) -> None:
        est = self.form.estimate
        if est is None:
            return
        if est.measure != "time":
            want = "point" if est.measure == "distance" else "path"
            f = self.formals.get(est.formal)
            if f is None or f.kind != want:
                self.fail(f"estimate: {est.measure}() takes a {want} parameter of this task, "
                          f"not '{est.formal}'", est.span)
        elif isinstance(est.value, ast.Ref):
            f = self.formals.get(est.value.name)
            if f is None or f.kind != "duration":
                self.fail(f"estimate '{est.value.name}' must be a duration parameter",
                          est.span)
        elif isinstance(est.value, ast.Number):
            if est.value.unit is None or UNITS[est.value.unit][0] != "duration":
                self.fail("an estimate is a duration (s, min, h)", est.span)
            for p in limits(est.value, "duration", {}):
                self.fail(f"estimate: {p.message}", est.span)
        else:
            self.fail("an estimate is a duration, a duration parameter, distance(POINT) / "
                      "SPEED m/s or length(PATH) / SPEED m/s", est.span)

    def latches(self) -> None:
        form = self.form
        for latched in (form.latch, form.unlatch):
            if latched is not None and latched not in self.library.behaviours:
                self.fail(f"latch of unknown behaviour '{latched}'", form.span)
        if form.latch and not form.immediate:
            self.fail("a task that latches a behaviour must end at once (no ok, fail or "
                      "timeout)", form.span)

    def defaults_and_forms(self) -> None:
        """Each default fits its formal; no two call forms of the task look alike."""
        form = self.form
        for f in form.formals:
            if f.default is not None and f.kind is not None:
                wrong = check(f.default, f.kind, {})
                for p in wrong or limits(f.default, f.kind, {}, f.range, f.fields):
                    self.fail(f"default of '{f.name}': {p.message}", p.node.span)
        words = tuple((i, f.name) for i, f in enumerate(form.formals) if f.kind is None)
        for other in self.library.tasks.get(form.name, []):
            other_words = tuple((i, f.name) for i, f in enumerate(other.formals)
                                if f.kind is None)
            if other_words == words and _arity(other) == _arity(form):
                self.fail(f"this call form is the same as the one at {other.span}", form.span,
                          "give each form of a task different words (enable / disable) or "
                          "arities")


def _arity(form: TaskForm) -> tuple[int, int]:
    required = sum(1 for f in form.formals if f.kind is None or f.default is None)
    return required, len(form.formals)
