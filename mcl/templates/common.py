"""What every template shares: the block interface, absorbing an abort, switching latches off.

Every block compiles to a subnet with the input places ``begin`` and ``abort`` and the output
places ``ok``, ``fail`` and ``aborted`` (docs/DESIGN.md §5). One token in ``begin`` leads to
exactly one token in ``ok``, ``fail`` or ``aborted``, and the subnet is then empty again.

Why ``aborted`` is a place of its own: a parent that aborts a child must know whether the
child took the abort token. If the child had already ended, the token is still in the child's
``abort`` place and the parent must absorb it; if the child took it, the child ends in
``aborted``. With only ``fail`` the two cases look alike (a child that failed by itself while
the abort was on its way), and a P/T net cannot test a place for emptiness. The parent reads
``aborted`` as fail; the mission as a whole ends fail when aborted.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING

from diagnostics import Span
from petri.net import ABORT, ABORTED, BEGIN, FAIL, INNER, OK, Action, Net, Origin

from mcl import ast

if TYPE_CHECKING:
    from mcl.checker import Checked
    from mcl.analysis.latches import Flow


@dataclass(frozen=True)
class Interface:
    """A block's subnet as its parent sees it: its begin and abort places and its ends."""

    name: str
    begin: int
    abort: int
    ok: int
    fail: int
    aborted: int


@dataclass
class Latch:
    """A latched behaviour's state machine: off, or on from one call site."""

    behaviour: str
    off: int
    sites: dict[int, int] = field(default_factory=dict)  # id(Call) -> its "on" place
    by_site: dict[str, int] = field(default_factory=dict)  # "line:col" -> its "on" place

    def states(self) -> list[int]:
        return [self.off, *self.sites.values()]

    def among(self, values: frozenset[tuple[str, str]] | None) -> list[int]:
        """The state places of this latch that ``values`` (pairs (behaviour, "off" | site)
        from mcl/analysis/latches.py) allow, in the order of :meth:`states` (that of the places'
        numbers: "off" is made before the sites, mcl/compiler.py); all of them when
        ``values`` is None or names a state this latch does not know."""
        if values is None:
            return self.states()
        wanted: set[int] = set()
        for behaviour, value in values:
            if behaviour != self.behaviour:
                continue
            place = self.off if value == "off" else self.by_site.get(value)
            if place is None:
                return self.states()
            wanted.add(place)
        return sorted(wanted)  # the order of states(): off, then the sites as made


@dataclass
class Context:
    """What the templates share while compiling one mission: the net being built and the
    latches."""

    net: Net
    checked: Checked
    latches: dict[str, Latch] = field(default_factory=dict)
    names: set[str] = field(default_factory=set)
    # Latch states that may hold at each call and in each block (None: assume any).
    flow: Flow | None = None

    def states_at_call(self, latch: Latch, call: ast.Call) -> list[int]:
        """The states ``latch`` may be in when ``call`` runs."""
        at = None if self.flow is None else self.flow.at_call.get(id(call))
        return latch.among(at)

    def states_in_block(self, latch: Latch, block: ast.Block) -> list[int]:
        """The states ``latch`` may be in while ``block`` runs or is being stopped."""
        at = None if self.flow is None else self.flow.at_block.get(id(block))
        return latch.among(at)

    # -- naming and building ----------------------------------------------------------------
    def prefix(self, kind: str, span: Span) -> str:
        base = f"{kind}@{span.line}:{span.col}"
        name, n = base, 1
        while name in self.names:
            n += 1
            name = f"{base}#{n}"
        self.names.add(name)
        return name

    def origin(self, span: Span, text: str, kind: str) -> Origin:
        return Origin(span.file, span.line, span.col, text, kind)

    def place(self, name: str, behaviours: tuple[str, ...] = (),
              origin: Origin | None = None, role: str = INNER) -> int:
        return self.net.add_place(name, behaviours, origin, role)

    def interface(self, name: str, origin: Origin) -> Interface:
        return Interface(name, *(self.place(f"{name}.{role}", origin=origin, role=role)
                                 for role in (BEGIN, ABORT, OK, FAIL, ABORTED)))

    def transition(self, name: str, inputs: list[int], outputs: list[int], label: str,
                   origin: Origin, actions: tuple[Action, ...] = (), event: str | None = None,
                   timer: float | str | None = None) -> int:
        return self.net.add_transition(name, inputs, outputs, actions=actions, event=event,
                                       timer=timer, origin=origin, label=label)

    # -- the two mechanisms every composite template uses -----------------------------------
    def absorb(self, child: Interface, waiting: int, done: list[int], name: str,
               origin: Origin) -> None:
        """The parent has put a token in ``child.abort`` and marked ``waiting``: the child
        either takes the abort (and ends in ``aborted``) or had already ended, in which case
        the abort token is absorbed here together with the child's result."""
        self.transition(f"{name}.stopped", [waiting, child.aborted], done,
                        f"{child.name} stopped", origin)
        self.transition(f"{name}.late_ok", [waiting, child.ok, child.abort], done,
                        f"{child.name} had already ended ok", origin)
        self.transition(f"{name}.late_fail", [waiting, child.fail, child.abort], done,
                        f"{child.name} had already ended fail", origin)

    def abort_entry(self, block: ast.Block, name: str, aborted: int, origin: Origin) -> int:
        """The place an aborted block goes to once its children have stopped. From there the
        latched behaviours switched on inside the block and still on are switched off, one
        behaviour after the other, before the block reports ``aborted``."""
        owned: dict[str, set[int]] = {}  # behaviour -> its "on" places from inside
        for call in ast.calls(block):  # linear in the block, whatever the number of latches
            for behaviour, latch in self.latches.items():
                if id(call) in latch.sites:
                    owned.setdefault(behaviour, set()).add(latch.sites[id(call)])
        latched = [latch for b, latch in sorted(self.latches.items()) if b in owned]
        if not latched:
            return aborted
        entry = current = self.place(f"{name}.cleanup", origin=origin)
        for i, latch in enumerate(latched):
            after = aborted if i == len(latched) - 1 else self.place(
                f"{name}.cleanup{i + 1}", origin=origin)
            for state in self.states_in_block(latch, block):
                if state in owned[latch.behaviour]:
                    self.transition(f"{name}.off.{self.net.places[state].name}",
                                    [current, state], [after, latch.off],
                                    f"switch {latch.behaviour} off (aborted)", origin,
                                    actions=(Action("disable", latch.behaviour),))
                else:
                    self.transition(f"{name}.keep.{self.net.places[state].name}",
                                    [current, state], [after, state],
                                    f"{latch.behaviour} not on from inside", origin)
            current = after
        return entry
