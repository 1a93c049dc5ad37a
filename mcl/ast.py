"""The abstract syntax tree of an MCL mission: frozen dataclasses, each with its source span.

Equality ignores spans (``compare=False``), so a mission parsed from its pretty-printed form
equals the original.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Union

from diagnostics import Span

_NOWHERE = Span("<none>", 0, 0)


# -- values ---------------------------------------------------------------------------------
@dataclass(frozen=True)
class Number:
    """A number with its unit, if any: ``1.5 m``, ``90 deg``, ``3``."""

    value: float
    unit: str | None = None
    span: Span = field(default=_NOWHERE, compare=False)


@dataclass(frozen=True)
class Ref:
    """An identifier: a mission parameter, or one of the words ``enable`` / ``disable``."""

    name: str
    span: Span = field(default=_NOWHERE, compare=False)


@dataclass(frozen=True)
class ListValue:
    """A list of values: ``[a, b, c]``."""

    items: tuple[Value, ...]
    span: Span = field(default=_NOWHERE, compare=False)


@dataclass(frozen=True)
class Point:
    """A point or pose: ``(x, y, z)``, ``(x, y, z, heading)``."""

    items: tuple[Value, ...]
    span: Span = field(default=_NOWHERE, compare=False)


Value = Union[Number, Ref, ListValue, Point]
WORDS = ("enable", "disable")


# -- blocks ---------------------------------------------------------------------------------
@dataclass(frozen=True)
class Arg:
    """One argument of a task call, positional or named (``timeout = 2 min``)."""

    value: Value
    name: str | None = None  # for named arguments such as timeout = 2 min
    span: Span = field(default=_NOWHERE, compare=False)


@dataclass(frozen=True)
class Call:
    """A task call: ``Name(args)``."""

    name: str
    args: tuple[Arg, ...]
    span: Span = field(default=_NOWHERE, compare=False)


@dataclass(frozen=True)
class Sequence:
    """``A ; B ; ...``: each item starts when the one before it ends."""

    items: tuple[Block, ...]
    span: Span = field(default=_NOWHERE, compare=False)


@dataclass(frozen=True)
class TryCatchDo:
    """``TRY { try_ } CATCH { catch } DO { do }``."""

    try_: Block
    catch: Block
    do: Block
    span: Span = field(default=_NOWHERE, compare=False)


@dataclass(frozen=True)
class ParallelAnd:
    """``PARALLEL { a } AND { b } ...``: every branch must end ok."""

    branches: tuple[Block, ...]
    span: Span = field(default=_NOWHERE, compare=False)


@dataclass(frozen=True)
class ParallelOr:
    """``PARALLEL { a } OR { b } ...``: the first branch to end decides."""

    branches: tuple[Block, ...]
    span: Span = field(default=_NOWHERE, compare=False)


@dataclass(frozen=True)
class IfThenElse:
    """``IF { condition } THEN { then } ELSE { else_ }`` (``else_`` may be absent)."""

    condition: Block
    then: Block
    else_: Block | None
    span: Span = field(default=_NOWHERE, compare=False)


@dataclass(frozen=True)
class WhileDo:
    """``WHILE { condition } DO { body }``."""

    condition: Block
    body: Block
    span: Span = field(default=_NOWHERE, compare=False)


Block = Union[Call, Sequence, TryCatchDo, ParallelAnd, ParallelOr, IfThenElse, WhileDo]


@dataclass(frozen=True)
class Param:
    """``PARAM name = value;`` (the value may be left to the command line)."""

    name: str
    value: Value | None
    span: Span = field(default=_NOWHERE, compare=False)


@dataclass(frozen=True)
class Uses:
    """``USES "file.tasks";``: the task library the mission is written against."""

    library: str
    span: Span = field(default=_NOWHERE, compare=False)


@dataclass(frozen=True)
class Mission:
    """A mission: its name, its parameters, its body, the task libraries it uses and its stop
    handler (``ON STOP``), if any."""

    name: str | None
    body: Block
    params: tuple[Param, ...] = ()
    span: Span = field(default=_NOWHERE, compare=False)
    uses: tuple[Uses, ...] = ()
    # ON STOP { ... }: what the mission does when it is stopped from outside (None: nothing)
    on_stop: Block | None = None
    stop_span: Span = field(default=_NOWHERE, compare=False)  # where ON STOP stands

    def parts(self) -> tuple[Block, ...]:
        """The mission's blocks: its body, then its stop handler if it has one."""
        return (self.body,) if self.on_stop is None else (self.body, self.on_stop)

    def calls(self) -> list[Call]:
        """Every task call of the mission, its stop handler's included, in source order."""
        return [c for part in self.parts() for c in calls(part)]


def children(block: Block) -> tuple[Block, ...]:
    """The blocks directly inside a block, in source order."""
    match block:
        case Call():
            return ()
        case Sequence(items=items):
            return items
        case TryCatchDo(try_=t, catch=c, do=d):
            return (t, c, d)
        case ParallelAnd(branches=b) | ParallelOr(branches=b):
            return b
        case IfThenElse(condition=c, then=t, else_=e):
            return (c, t) if e is None else (c, t, e)
        case WhileDo(condition=c, body=b):
            return (c, b)
    raise TypeError(f"not a block: {block!r}")


def walk(block: Block) -> list[Block]:
    """Every block in the tree, parents before children (iterative: deep trees are fine)."""
    out: list[Block] = []
    stack = [block]
    while stack:
        b = stack.pop()
        out.append(b)
        stack.extend(reversed(children(b)))
    return out


def calls(block: Block) -> list[Call]:
    return [b for b in walk(block) if isinstance(b, Call)]


# -- fleets (docs/LANGUAGE.md, "Fleets") ----------------------------------------------------
LINKS = ("acoustic", "radio", "tether")


@dataclass(frozen=True)
class ChannelDecl:
    """``CHANNEL name FROM a TO b, c LINK DELAY lo .. hi [EVERY d] [LOSSY] MESSAGES m, n;``:
    a directed channel from one vehicle to one or more. Names are :class:`Ref` (name and
    span) so that messages can point at each."""

    name: Ref
    sender: Ref
    receivers: tuple[Ref, ...]
    link: str  # one of LINKS
    delay_min: Number
    delay_max: Number
    every: Number | None
    lossy: bool
    messages: tuple[Ref, ...]
    span: Span = field(default=_NOWHERE, compare=False)


@dataclass(frozen=True)
class Vehicle:
    """``VEHICLE name { USES ...; PARAM ...; MISSION ... ON STOP ... }``: one vehicle of a
    fleet and its mission, written as a single-vehicle file is."""

    name: Ref
    mission: Mission
    span: Span = field(default=_NOWHERE, compare=False)


@dataclass(frozen=True)
class Fleet:
    """``FLEET name { CHANNEL ...; VEHICLE ... }``: several vehicles coordinated by messages on
    channels (never by shared transitions)."""

    name: str
    channels: tuple[ChannelDecl, ...]
    vehicles: tuple[Vehicle, ...]
    span: Span = field(default=_NOWHERE, compare=False)
