"""What stands at a place of a mission: a task call, a parameter (declared or used), a
``USES`` or a block, found in the syntax tree by the spans the parser gave its nodes."""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass

from diagnostics import Span
from mcl import ast


@dataclass(frozen=True)
class Found:
    """The innermost thing at a place: ``kind`` is "call", "param" (a use of a parameter, or
    its declaration), "uses" or "block"; ``span`` the range of its name (or of the block)."""

    kind: str
    name: str
    span: Span
    node: object


def inside(span: Span, line: int, col: int) -> bool:
    """Whether 1-based ``line:col`` lies in ``span`` (its end exclusive; a span without an
    end is the one line's rest)."""
    if line < span.line or (line == span.line and col < span.col):
        return False
    if span.end_line <= 0:
        return line == span.line
    return line < span.end_line or (line == span.end_line and col <= span.end_col)


def name_span(call: ast.Call) -> Span:
    """The task's name in a call (``GoTo`` of ``GoTo(a)``)."""
    s = call.span
    return Span(s.file, s.line, s.col, s.line, s.col + len(call.name))


def refs(value: ast.Value) -> Iterator[ast.Ref]:
    """The parameters a value names (not the words ``enable`` / ``disable``)."""
    match value:
        case ast.Ref(name=n) if n not in ast.WORDS:
            yield value
        case ast.ListValue(items=items) | ast.Point(items=items):
            for item in items:
                yield from refs(item)


def param_uses(mission: ast.Mission) -> Iterator[ast.Ref]:
    """Every use of a parameter: in task calls and in other parameters' values."""
    for p in mission.params:
        if p.value is not None:
            yield from refs(p.value)
    for call in mission.calls():
        for arg in call.args:
            yield from refs(arg.value)


def at(mission: ast.Mission, line: int, col: int) -> Found | None:
    """What stands at 1-based ``line:col`` of ``mission``, None if nothing of note."""
    for use in mission.uses:
        if inside(use.span, line, col):
            return Found("uses", use.library, use.span, use)
    for p in mission.params:
        if inside(p.span, line, col):
            return Found("param", p.name, p.span, p)
    for ref in param_uses(mission):
        if inside(ref.span, line, col):
            return Found("param", ref.name, ref.span, ref)
    for call in mission.calls():
        if inside(name_span(call), line, col):
            return Found("call", call.name, name_span(call), call)
    blocks = [b for part in mission.parts() for b in ast.walk(part)
              if not isinstance(b, (ast.Call, ast.Sequence)) and b.span.line == line
              and inside(b.span, line, col)]
    if blocks:
        block = blocks[-1]  # walk lists parents first: the last is the innermost
        return Found("block", type(block).__name__, block.span, block)
    return None


def declaration(mission: ast.Mission, name: str) -> ast.Param | None:
    """The ``PARAM`` that declares ``name``."""
    return next((p for p in mission.params if p.name == name), None)
