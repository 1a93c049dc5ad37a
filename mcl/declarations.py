"""What a task library declares: behaviours and the call forms of tasks.

The values the loader (mcl/tasklib.py) builds from ``*.tasks`` files (mcl/library_builder.py)
and the checker, the compiler and the analyses read: a :class:`Library` of :class:`Behaviour`
and :class:`TaskForm` declarations, each form with its :class:`Formal` parameters, the
:class:`ActionSpec` actions it sends, its events, timeout, latch and :class:`Estimate`.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from diagnostics import Span

from mcl import ast
from mcl.values import FIELDS, Range, to_text

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
    """A parameter of a task's call form: ``name: kind [range] [= default]``, or a literal
    word (``enable`` / ``disable``) that picks the form."""

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
    """An action a task sends: enable, disable or configure a behaviour, with parameters
    bound to the task's formals or to literal values."""

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
    """A behaviour of the vehicle's stack: the degrees of freedom it drives and its events."""

    name: str
    dofs: tuple[str, ...]
    events: tuple[str, ...]
    span: Span
    dof_spans: tuple[Span, ...] = field(default=(), compare=False)  # one per dof
    power: float | None = None  # watts drawn while on ('power N W'), None: not declared


@dataclass
class Library:
    """Every behaviour and task the loaded ``*.tasks`` files declare (a task may have several
    call forms)."""

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
