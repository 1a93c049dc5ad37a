"""Which latched behaviours may be on, and from where, at each point of a mission.

A data-flow analysis on the syntax tree. Its states are pairs (behaviour, value), the value
"off" or the call site "line:col" that switched the behaviour on; a set of pairs says which
values each behaviour may have (per behaviour, not jointly). The analysis over-approximates:
every latch state that the compiled net can reach at a point is in the set for that point
(a state it lists may never occur).

Two users: :mod:`mcl.analysis.clashes` decides latch properties from it without building the
state space (overriding the hooks :meth:`Flow.can_end` and :meth:`Flow.race_won` to be finer),
and :mod:`mcl.compiler` generates, for each latching or unlatching call, only the
transitions for the states its latch may be in when the call runs, and for each block's abort
cleanup only the states that may hold while the block runs: the net then grows linearly with
the number of latching calls instead of with its square.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING

from mcl import ast

if TYPE_CHECKING:
    from mcl.checker import Checked

OFF = "off"
OK, FAIL = "ok", "fail"
ENDINGS = frozenset({OK, FAIL})

State = frozenset[tuple[str, str]]  # (behaviour, "off" | call site "line:col")


def site(call: ast.Call) -> str:
    return f"{call.span.line}:{call.span.col}"


@dataclass
class Flow:
    """The analysis. ``flow(body, initial)`` fills ``at_call`` (states while a call runs) and
    ``at_block`` (states at any moment while a block runs or is being stopped, including its
    abort cleanup)."""

    checked: Checked
    at_call: dict[int, State] = field(default_factory=dict)
    at_block: dict[int, State] = field(default_factory=dict)
    _sites: dict[int, frozenset[tuple[str, str]]] = field(default_factory=dict, repr=False)
    _created: dict[int, State] = field(default_factory=dict, repr=False)
    _writes: dict[int, frozenset[str]] = field(default_factory=dict, repr=False)
    # each WHILE's head states so far, per rely: a loop met again (an outer loop's next
    # round) starts from where it converged, so nested loops cost rounds added, not multiplied
    _heads: dict[tuple[int, State], State] = field(default_factory=dict, repr=False)
    steps: int = 0  # blocks flowed through: the work done

    def latch_of(self, call: ast.Call) -> tuple[str | None, bool]:
        form = self.checked.resolved(call).form
        if form.latch:
            return form.latch, True
        return form.unlatch, False

    def initial(self, body: ast.Block) -> State:
        """Every latched behaviour off (the mission's initial marking)."""
        return frozenset((b, OFF) for c in ast.calls(body)
                         for b, _ in [self.latch_of(c)] if b is not None)

    def sites(self, block: ast.Block) -> frozenset[tuple[str, str]]:
        key = id(block)
        if key not in self._sites:
            out = set()
            for c in ast.calls(block):
                b, on = self.latch_of(c)
                if b is not None and on:
                    out.add((b, site(c)))
            self._sites[key] = frozenset(out)
        return self._sites[key]

    def writes(self, block: ast.Block) -> frozenset[str]:
        key = id(block)
        if key not in self._writes:
            self._writes[key] = frozenset(b for c in ast.calls(block)
                                          for b, _ in [self.latch_of(c)] if b is not None)
        return self._writes[key]

    @staticmethod
    def cleanup(states: State, sites: frozenset[tuple[str, str]] | set[tuple[str, str]]
                ) -> State:
        return frozenset((b, OFF) if (b, s) in sites else (b, s) for b, s in states)

    @staticmethod
    def put(states: State, behaviour: str, value: str) -> State:
        return frozenset({(b, s) for b, s in states if b != behaviour} | {(behaviour, value)})

    def created(self, block: ast.Block) -> State:
        """The latch states a block may create at any moment: 'on from here' at each of its
        latching calls, 'off' at each unlatching call and at each abort that cleans up."""
        key = id(block)
        if key not in self._created:
            out = set()
            for c in ast.calls(block):
                b, on = self.latch_of(c)
                if b is not None:
                    out |= {(b, site(c)), (b, OFF)} if on else {(b, OFF)}
            self._created[key] = frozenset(out)
        return self._created[key]

    def switched_on(self, call: ast.Call, behaviour: str, after: State) -> None:
        """Called at each latching call with the states just after it (a hook for checks,
        e.g. two latched behaviours sharing a degree of freedom on together)."""

    # -- hooks a finer analysis overrides (mcl/analysis/clashes.py) ---------------------------
    def can_end(self, block: ast.Block) -> frozenset[str]:
        """The endings ("ok", "fail") ``block`` may reach from its start: here both, always
        (the compiler's pruning needs nothing finer)."""
        return ENDINGS

    def race_won(self, blocks: list[ast.Block], ends: list[State], winner: int) -> State:
        """The states just after ``blocks[winner]`` ended first in a race (PARALLEL OR, or
        TRY against CATCH) and the others were aborted: each other one is cleaned up if it
        was still running, or is as it ended if it had just ended (a late abort).
        ``ends``: each block's end states, seeing what the others create meanwhile."""
        others: set[tuple[str, str]] = set().union(
            *(self.sites(b) for j, b in enumerate(blocks) if j != winner))
        return ends[winner] | self.cleanup(ends[winner], others)

    def flow(self, block: ast.Block, s: State, rely: State = frozenset()
             ) -> tuple[State, State]:
        """(states at the block's normal end, states at any moment during it). ``rely``:
        states that blocks running concurrently may create at any moment."""
        self.steps += 1
        end, during = self._flow(block, s | rely, rely)
        if not isinstance(block, ast.Call):  # a task has no cleanup of its own
            key = id(block)
            # while the block is being stopped: what it may have been in, what its nested
            # cleanups leave (off), what concurrent blocks create meanwhile
            seen = during | end | self.created(block) | rely
            self.at_block[key] = self.at_block.get(key, frozenset()) | seen
        # a block that can never end has no end states
        return (end if self.can_end(block) else frozenset()), during

    def _flow(self, block: ast.Block, s: State, rely: State) -> tuple[State, State]:
        match block:
            case ast.Call():
                self.at_call[id(block)] = self.at_call.get(id(block), frozenset()) | s
                b, on = self.latch_of(block)
                if b is None:
                    return s, s
                end = self.put(s, b, site(block) if on else OFF) | rely
                if on:
                    self.switched_on(block, b, end)
                return end, s | end
            case ast.Sequence(items=items):
                during_ = set(s)  # in place: a long sequence stays linear
                for item in items:
                    s, d = self.flow(item, s, rely)
                    during_ |= d
                return s, frozenset(during_)
            case ast.IfThenElse(condition=c, then=a, else_=e):
                ec, dc = self.flow(c, s, rely)
                can = self.can_end(c)  # only the branches the condition's endings take
                ea, da = self.flow(a, ec, rely) if OK in can else (frozenset(), ec)
                if FAIL not in can:
                    eb, db = frozenset[tuple[str, str]](), ec
                else:
                    eb, db = self.flow(e, ec, rely) if e is not None else (ec, ec)
                return ea | eb, dc | da | db
            case ast.WhileDo(condition=c, body=body):
                return self._while(c, body, s, rely)
            case ast.ParallelAnd(branches=bs) | ast.ParallelOr(branches=bs):
                ends, during = self._concurrent(list(bs), s, rely)
                if isinstance(block, ast.ParallelOr):
                    first_ends: State = frozenset().union(
                        *(self.race_won(list(bs), ends, i) for i in range(len(bs))))
                    return first_ends, during
                return self._last_writers(list(bs), ends, s), during
            case ast.TryCatchDo(try_=t, catch=c, do=d):
                ends, during = self._concurrent([t, c], s, rely)
                # TRY ended first: CATCH aborted; CATCH ended first: TRY aborted, DO runs
                try_first = self.race_won([t, c], ends, 0)
                at_do = self.cleanup(during, self.sites(t)) | ends[0]
                ed, dd = self.flow(d, at_do, rely)
                return try_first | ed, during | dd
        raise TypeError(block)

    def _while(self, c: ast.Block, body: ast.Block, s: State, rely: State
               ) -> tuple[State, State]:
        """A WHILE: rounds until the states at the head no longer grow; it ends where its
        condition fails or its body fails (as far as :meth:`can_end` allows).

        Met again with states that include those of an earlier visit (an enclosing loop's
        next round: its states only grow), the rounds start from the head that visit
        converged to, which the least fixpoint from the new states includes: the result is
        the same (from other states, a superset: still sound). So each WHILE goes round at
        most once per visit plus once per state its head gains, however deeply loops nest
        (starting afresh, each level of nesting doubled the work)."""
        key = (id(c), rely)
        head = s | self._heads.get(key, frozenset())
        end, during = frozenset[tuple[str, str]](), s
        can_c, can_b = self.can_end(c), self.can_end(body)
        for _ in range(1000):  # a finite lattice: this converges in a few rounds
            ec, dc = self.flow(c, head, rely)
            eb, db = self.flow(body, ec, rely) if OK in can_c else (frozenset(), ec)
            end |= (ec if FAIL in can_c else frozenset()) | (
                eb if FAIL in can_b else frozenset())
            during = during | dc | db
            if eb <= head:
                break
            head = head | eb
        self._heads[key] = head
        return end, during

    def _concurrent(self, blocks: list[ast.Block], s: State, rely: State
                    ) -> tuple[list[State], State]:
        """Blocks running together: each may see, at any moment, what the others create."""
        created = [self.created(b) for b in blocks]
        ends, during = [], s
        for i, b in enumerate(blocks):
            others = frozenset().union(*(created[j] for j in range(len(blocks)) if j != i))
            e, d = self.flow(b, s, rely | others)
            ends.append(e)
            during |= d
        return ends, during

    def _last_writers(self, blocks: list[ast.Block], ends: list[State], s: State) -> State:
        """After concurrent blocks have all ended: a behaviour's state is what a block that
        writes it left, or unchanged when none writes it."""
        out: set[tuple[str, str]] = set()
        for beh in {b for st in [s, *ends] for b, _ in st}:
            writers = [i for i, blk in enumerate(blocks) if beh in self.writes(blk)]
            for st in ([ends[i] for i in writers] if writers else [s]):
                out |= {(b, v) for b, v in st if b == beh}
        return frozenset(out)


def analyse(checked: Checked) -> tuple[Flow, State]:
    """The analysis of a whole mission: (the filled-in Flow, the states at its end)."""
    flow = Flow(checked)
    body = checked.mission.body
    end, _during = flow.flow(body, flow.initial(body))
    return flow, end
