"""Each block of a mission and its state at every instant of a run: waiting, running, ok,
fail or aborted, read off the firings.

Every block compiles to a subnet with the interface places ``begin``, ``ok``, ``fail`` and
``aborted`` (mcl/templates/common.py), each made with its role and its block's origin. So a
firing says by itself what it does to blocks: one that takes the token of a block's ``begin``
starts it (running); one that puts a token in its ``ok``, ``fail`` or ``aborted`` ends it so.
A block no firing has started is waiting; a block in a loop runs again, and its state is that
of its last round. The mission itself ends in its ``end-ok`` or ``end-fail`` place.

The same model serves a run as it happens (:class:`BlockStates` is a player observer, as
petri/execution/status.py's :class:`MissionStatus` and mission/handled.py's
:class:`CatchWatch` are) and a finished run's log (:meth:`BlockStates.read`), whose ``fire``
records name each transition by its index.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass
from typing import Any

from mcl import ast
from petri.execution.player import Record
from petri.net import ABORTED, BEGIN, END_FAIL, END_OK, FAIL, OK, Net

WAITING, RUNNING = "waiting", "running"
STATES = (WAITING, RUNNING, "ok", "fail", "aborted")
# what a token in a place of each role means for its block
ENDED = {OK: "ok", FAIL: "fail", ABORTED: "aborted", END_OK: "ok", END_FAIL: "fail"}

Key = tuple[str, int, int]  # a block: its kind ("task", "SEQ", "TRY", ...), line, column
KINDS: dict[type, str] = {ast.Call: "task", ast.Sequence: "SEQ", ast.TryCatchDo: "TRY",
                          ast.ParallelAnd: "AND", ast.ParallelOr: "OR",
                          ast.IfThenElse: "IF", ast.WhileDo: "WHILE"}


def key_of(block: ast.Block) -> Key:
    """The key of an AST block, as its places' origins give it."""
    return KINDS[type(block)], block.span.line, block.span.col


MISSION_KEY: Key = ("MISSION", 0, 0)  # the mission as a whole (whatever its line)


def block_id(key: Key) -> str:
    """A block's name for people and pages: ``task@34:9``, ``TRY@33:5``, ``MISSION``."""
    return "MISSION" if key == MISSION_KEY else f"{key[0]}@{key[1]}:{key[2]}"


@dataclass(frozen=True)
class Change:
    """A block's state from mission time ``t`` on (until its next change)."""

    t: float
    block: Key
    state: str


def effects(net: Net) -> list[list[tuple[Key, str]]]:
    """For each transition of ``net``, what firing it does to blocks, in order: the blocks
    it starts, then those it ends and how."""
    def key(index: int) -> Key | None:
        place = net.places[index]
        if place.origin is None:
            return None
        if place.origin.kind == "MISSION":
            return MISSION_KEY
        return place.origin.kind, place.origin.line, place.origin.col

    out: list[list[tuple[Key, str]]] = []
    for tr in net.transitions:
        changes: list[tuple[Key, str]] = []
        for index, _ in tr.inputs:
            k = key(index)
            if k is not None and net.places[index].role == BEGIN:
                changes.append((k, RUNNING))
        for index, _ in tr.outputs:
            k = key(index)
            if k is not None and net.places[index].role in ENDED:
                changes.append((k, ENDED[net.places[index].role]))
        out.append(changes)
    return out


class BlockStates:
    """A player observer (append it to ``player.observers``) that keeps every change of a
    block's state, in the order of the firings; :meth:`at` answers for any instant."""

    def __init__(self, net: Net):
        self.effects = effects(net)
        self.changes: list[Change] = []
        self.current: dict[Key, str] = {}  # each started block's state now
        self.start: float | None = None  # the player's time at the first record (live)

    def __call__(self, record: Record) -> None:
        if self.start is None:
            self.start = record.t
        if record.kind == "fire":
            self.fired(int(record.data["index"]), record.t - self.start)

    def fired(self, index: int, t: float) -> None:
        """Transition ``index`` fired at mission time ``t``."""
        if 0 <= index < len(self.effects):
            for k, state in self.effects[index]:
                self.changes.append(Change(t, k, state))
                self.current[k] = state

    def now(self) -> dict[str, str]:
        """Each started block's state now, by its :func:`block_id` (JSON-ready: the
        mission status a player publishes carries it as ``blocks``)."""
        return {block_id(k): state for k, state in self.current.items()}

    def read(self, records: Iterable[dict[str, Any]]) -> BlockStates:
        """Take a run log's records (mission time already): its ``fire`` records."""
        for r in records:
            if r.get("kind") == "fire" and isinstance(r.get("index"), int):
                self.fired(r["index"], float(r.get("t", 0.0)))
        return self

    def at(self, t: float) -> dict[Key, str]:
        """Each block's state at mission time ``t``: its last change at or before ``t``;
        a block absent has not started (waiting)."""
        states: dict[Key, str] = {}
        for change in self.changes:
            if change.t > t:
                break
            states[change.block] = change.state
        return states
