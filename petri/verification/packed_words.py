"""Markings packed into one 64-bit word, and the firing rule on whole arrays of them: the
representation of :mod:`petri.verification.explore_packed`'s search.

A marking is one ``uint64``: place p's token count is the field of ``bits[p]`` bits from bit
``shift[p]`` (:class:`Packing`). A place no transition changes keeps its initial count for
ever and takes no bits.

On packed words the firing rule is integer arithmetic on whole arrays (:class:`Rules`): place
p's field masked in place (``word & mask[p]``) holds at least w tokens when it is at least
``w << shift[p]``; firing t adds the constant ``sum(effect(t, p) << shift[p])`` (modulo
2**64, which is exact because every field stays in its range); a firing overflows a field when
the field, masked in place, is at least ``(limit - gain + 1) << shift[p]``.
:func:`expand_slice` fires every transition from some sorted words at once: the successors by
one transition, in the words' order, are sorted too, so they are a few sorted runs that a
stable sort merges (:func:`distinct`) before they are looked up among the visited words.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
import numpy.typing as npt

WORD_BITS = 64

Words = npt.NDArray[np.uint64]
Ints = npt.NDArray[np.integer[Any]]
Array = npt.NDArray[Any]


@dataclass(frozen=True)
class Packing:
    """Where each place's token count lies in a marking's word: ``bits[p]`` bits from bit
    ``shift[p]`` (no bits: the place keeps its initial count, ``constant[p]``)."""

    bits: tuple[int, ...]
    constant: tuple[int, ...]
    shift: tuple[int, ...] = field(init=False)

    def __post_init__(self) -> None:
        shifts, at = [], 0
        for b in self.bits:
            shifts.append(at)
            at += b
        object.__setattr__(self, "shift", tuple(shifts))

    @property
    def width(self) -> int:
        return sum(self.bits)

    def cap(self, p: int) -> int:
        """The most tokens place p's field holds."""
        return (1 << self.bits[p]) - 1

    def mask(self, p: int) -> int:
        return self.cap(p) << self.shift[p]

    def pack(self, row: Array) -> int:
        return sum(int(row[p]) << self.shift[p] for p in range(len(self.bits)) if self.bits[p])

    def field(self, words: Words, p: int) -> Words:
        return (words >> np.uint64(self.shift[p])) & np.uint64(self.cap(p))

    def repack(self, words: Words, wider: Packing) -> Words:
        """``words`` (packed by this packing) packed by ``wider``."""
        out = np.zeros_like(words)
        for p, b in enumerate(self.bits):
            if b:
                out |= self.field(words, p) << np.uint64(wider.shift[p])
        return out

    def unpack(self, words: Words, dtype: Any) -> Array:
        """The token counts of each word, a row of ``len(bits)`` cells each."""
        cells = np.empty((len(words), len(self.bits)), dtype=dtype)
        for p, b in enumerate(self.bits):
            cells[:, p] = self.field(words, p) if b else self.constant[p]
        return cells


def first_packing(net: Any, top: int) -> Packing:
    """The packing the search starts with: each place that some transition changes gets the
    bits of the largest initial count of the net (tokens move: in a net that keeps its
    tokens, as Kanban-PT-00005, that is every place's bound, and no field is ever widened), or
    if that does not fit a word, those of its own initial count; at least one, at most
    ``top``. A place no transition changes gets none."""
    m0 = [int(x) for x in net.row]
    changed = set(int(p) for p in net.eff_place)
    most = max(m0, default=0).bit_length()
    for least in (most, 0):
        bits = tuple(min(top, max(1, least, m0[p].bit_length())) if p in changed else 0
                     for p in range(len(m0)))
        if sum(bits) <= WORD_BITS:
            break
    return Packing(bits, tuple(m0))


def widened(packing: Packing, need: dict[int, int], top: int, hint: int) -> Packing:
    """``packing`` with the field of each place p of ``need`` wide enough for ``need[p]``
    tokens: at least a bit more, and the ``hint``'s bits if they fit a word (fewer widenings,
    each of which repacks every marking found), at most ``top``."""
    for least in (hint, 0):
        bits = list(packing.bits)
        for p, tokens in need.items():
            bits[p] = min(top, max(bits[p] + 1, tokens.bit_length(), least))
        if sum(bits) <= WORD_BITS:
            break
    return Packing(tuple(bits), packing.constant)


@dataclass(frozen=True)
class Rules:
    """The firing rule on words of one packing, as arrays for whole-frontier operations.

    Enabled: the masked field of row ``in_row[a]`` of ``masks`` is at least ``in_low[a]`` for
    every input arc a of the transitions ``in_t`` (each a run of arcs from ``in_start``); the
    transitions in ``always`` have no input that can fail; the others never are (an input
    place whose count never changes holds too few tokens). Over the limit: the masked field of
    ``over_place[a]`` is at least ``over_low[a]`` for some arc of ``over_t``; ``widen[a]`` says
    whether the limit is the field's width (then the packing must grow) or ``max_tokens``.
    """

    masks: Words  # of the places with bits, in order (the rows of a slice's masked fields)
    in_row: Ints  # the row of each input arc's place among them
    in_low: Words
    in_start: Ints
    in_more: list[tuple[Ints, Ints]]  # for the k-th inputs (k >= 1): (which of in_t, arc)
    in_t: Ints
    always: Ints
    over_place: Ints
    over_row: Ints
    over_low: Words
    over_t: Ints
    over_gain: Ints  # the tokens the transition puts in the place
    widen: npt.NDArray[np.bool_]
    delta: Words  # (transitions,) what firing adds to a word, modulo 2**64
    n_trans: int


def rules(net: Any, packing: Packing, max_tokens: int, top: int) -> Rules:
    n_trans = len(net.in_ptr) - 1
    read = [p for p, b in enumerate(packing.bits) if b]
    row_of = {p: k for k, p in enumerate(read)}
    masks = np.array([packing.mask(p) for p in read], dtype=np.uint64)
    in_place: list[int] = []
    in_low: list[int] = []
    in_start: list[int] = []
    in_t: list[int] = []
    always: list[int] = []
    over_place, over_low, over_t, over_gain, widen = [], [], [], [], []
    delta = []
    never = (1 << WORD_BITS) - 1  # no field reaches it (fields have at most 32 bits)
    for t in range(n_trans):
        arcs = []
        dead = False
        for a in range(int(net.in_ptr[t]), int(net.in_ptr[t + 1])):
            p, w = int(net.in_place[a]), int(net.in_w[a])
            if not packing.bits[p]:
                dead |= packing.constant[p] < w
            else:
                arcs.append((p, never if w > packing.cap(p) else w << packing.shift[p]))
        if dead:  # an input whose count never changes is short: never enabled
            pass
        elif arcs:
            in_start.append(len(in_place))
            in_t.append(t)
            for p, low in arcs:
                in_place.append(p)
                in_low.append(low)
        else:
            always.append(t)
        total = 0
        for a in range(int(net.eff_ptr[t]), int(net.eff_ptr[t + 1])):
            p, d = int(net.eff_place[a]), int(net.eff_delta[a])
            total += d << packing.shift[p]
            if d > 0:
                grows = packing.bits[p] < top
                limit = packing.cap(p) if grows else max_tokens
                over_place.append(p)
                over_low.append(max(0, limit - d + 1) << packing.shift[p])
                over_t.append(t)
                over_gain.append(d)
                widen.append(grows)
        delta.append(total % (1 << WORD_BITS))

    def ints(values: list[int]) -> Ints:
        return np.asarray(values, dtype=np.int64)

    def words(values: list[int]) -> Words:
        return np.asarray(values, dtype=np.uint64)

    ends = in_start[1:] + [len(in_place)]
    more = [(ints([i for i, (a, b) in enumerate(zip(in_start, ends)) if b - a > k]),
             ints([a + k for a, b in zip(in_start, ends) if b - a > k]))
            for k in range(1, max((b - a for a, b in zip(in_start, ends)), default=1))]
    return Rules(masks, ints([row_of[p] for p in in_place]), words(in_low), ints(in_start),
                 more,
                 ints(in_t),
                 ints(always), ints(over_place),
                 ints([row_of[p] for p in over_place]), words(over_low), ints(over_t),
                 ints(over_gain), np.asarray(widen, dtype=bool), words(delta), n_trans)


# -- a slice of a level -----------------------------------------------------------------------

@dataclass
class Slice:
    """What firing every transition from some frontier markings gave: the firings recorded
    (``fires[t, r]``: transition t from the slice's marking r, enabled and within the limits);
    the successors not numbered yet (``keys``, distinct and sorted; the search may merge
    several slices' into the first one's), each with the order of
    the first firing that found it in the sequential search (``order`` = rel * transitions +
    t, rel the source's number less the level's first); the first firing over
    ``max_tokens`` (``over``; -1: none); the tokens fields must hold (``need``, {place:
    tokens}: the packing must grow); and, with the arcs, each firing's order and target (its
    number, or -1 - k for ``keys[k]``)."""

    rel: Ints
    fires: npt.NDArray[np.bool_]
    keys: Words
    order: Ints
    over: int = -1
    need: dict[int, int] = field(default_factory=dict)
    arc_order: Ints | None = None
    arc_target: Ints | None = None


def distinct(keys: Words, order: Ints) -> tuple[Words, Ints, Ints, npt.NDArray[np.bool_]]:
    """The distinct ``keys``, sorted, each with its least ``order``; and how to map each key
    to its distinct one: ``by_key`` sorts the keys, ``first`` marks each new one in that
    order. ``keys`` are a few sorted runs: the stable sort merges them."""
    by_key = np.argsort(keys, kind="stable")
    ordered = keys[by_key]
    first = np.empty(len(keys), dtype=bool)
    first[:1] = True
    np.not_equal(ordered[1:], ordered[:-1], out=first[1:])
    starts = np.flatnonzero(first)
    least = np.minimum.reduceat(order[by_key], starts) if len(keys) else order[:0]
    return ordered[starts], least, by_key, first


def groups(by_key: Ints, first: npt.NDArray[np.bool_]) -> Ints:
    """Each key's distinct one (its index in :func:`distinct`'s keys)."""
    group = np.empty(len(by_key), dtype=np.int64)
    group[by_key] = np.cumsum(first) - 1
    return group


def expand_slice(words: Words, rel: Ints, rule: Rules, packing: Packing, visited: Words,
                 numbers: npt.NDArray[np.int32] | None) -> Slice:
    """Fire every transition from the frontier markings ``words`` (sorted; ``rel`` their
    numbers less the level's first) and look the successors up among the ``visited`` words
    (sorted; ``numbers`` the number of each, wanted for the arcs)."""
    n_trans = rule.n_trans
    fires = np.zeros((n_trans, len(words)), dtype=bool)
    masked = words[None, :] & rule.masks[:, None]  # (fields, rows): each field in place
    if len(rule.in_t):
        ok = masked[rule.in_row] >= rule.in_low[:, None]
        enabled = ok[rule.in_start]  # each transition's first input, then its others
        for which, arc in rule.in_more:
            enabled[which] &= ok[arc]
        fires[rule.in_t] = enabled
    fires[rule.always] = True
    found = Slice(rel, fires, words[:0], rel[:0])
    if len(rule.over_t):
        over = (masked[rule.over_row] >= rule.over_low[:, None]) & fires[rule.over_t]
        for a in np.flatnonzero(over.any(axis=1)):
            p, t, rows = int(rule.over_place[a]), int(rule.over_t[a]), over[a]
            if rule.widen[a]:
                most = int(packing.field(words[rows], p).max()) + int(rule.over_gain[a])
                found.need[p] = max(found.need.get(p, 0), most)
            else:
                earliest = int((rel[rows] * n_trans).min()) + t
                found.over = earliest if found.over < 0 else min(found.over, earliest)
                fires[t, rows] = False  # not recorded: the search stops before it
        if found.need:
            return found  # the level is expanded again once the fields are wider
    del masked
    t_of, r_of = np.nonzero(fires)  # by transition, then frontier row: sorted runs
    keys = words[r_of] + rule.delta[t_of]
    # half the bytes when the level's orders fit 32 bits (their type is the level's: rel's)
    order = rel[r_of] * n_trans + t_of.astype(rel.dtype)
    del t_of, r_of
    unique, least, by_key, first = distinct(keys, order)
    del keys
    pos = np.searchsorted(visited, unique)
    np.minimum(pos, len(visited) - 1, out=pos)
    known = visited[pos] == unique
    fresh = np.flatnonzero(~known)
    found.keys, found.order = unique[fresh], least[fresh]
    if numbers is not None:
        target = np.where(known, numbers[pos], -1).astype(np.int64)
        target[fresh] = -1 - np.arange(len(fresh))
        found.arc_order, found.arc_target = order, target[groups(by_key, first)]
    return found
