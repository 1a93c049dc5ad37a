"""The packed-word search (issue 27): the same graph as the numpy engine, numbered alike, on
one thread or two, with fields widened as places fill, another engine where markings do not
fit a word, and the memory budget kept."""

from __future__ import annotations

import sys

import numpy as np
import pytest

import petri.verification
from petri.net import Net
from petri.verification import explore_packed, packed_words
from petri.verification import reachability as rg
from petri.verification.packed_words import Packing
from tests.petri.verification.test_memory_budget import cycles
from tests.petri.verification.test_reachability import random_net

FIELDS = ("markings", "src", "dst", "transition", "parent", "parent_transition", "degree",
          "fired")


def assert_same(a: rg.StateSpace, b: rg.StateSpace, what: str) -> None:
    assert (a.complete, a.stop_reason, a.unbounded_place, a.expanded) == \
        (b.complete, b.stop_reason, b.unbounded_place, b.expanded), what
    for key in FIELDS:
        x, y = getattr(a, key), getattr(b, key)
        assert (x is None) == (y is None), (what, key)
        if x is not None:
            assert np.array_equal(x, y), (what, key)


def compare_on_random_nets(count: int, seed: int) -> int:
    """Explore random nets with both engines, with and without arcs, under limits; the
    number of graphs of more than five markings compared."""
    rng = np.random.default_rng(seed)
    compared = 0
    for i in range(count):
        net = random_net(rng, i)
        for limits in ({"max_tokens": 6}, {"max_markings": 40, "max_tokens": 200},
                       {"max_tokens": 3}):
            for arcs in (True, False):
                numpy = rg.explore(net, engine="numpy", arcs=arcs, **limits)
                packed = rg.explore(net, engine="packed", arcs=arcs, **limits)
                assert packed.engine == "packed"
                assert_same(numpy, packed, f"{net.name} {limits} arcs={arcs}")
                compared += numpy.n_markings > 5
    return compared


@pytest.mark.slow
def test_the_packed_search_numbers_markings_as_the_numpy_engine() -> None:
    # random nets: weights 1-2, token limits that stop some searches (with a Karp-Miller
    # witness), marking limits, places filled past their first fields
    assert compare_on_random_nets(60, seed=11) >= 60


def test_two_threads_tiny_slices_and_merged_slices_give_the_same_graph(
        monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(explore_packed, "PARALLEL", True)
    monkeypatch.setattr(explore_packed, "SLICE_ROWS", 2)  # many slices per level
    monkeypatch.setattr(explore_packed, "MERGE_ROWS", 3)  # many blocks per merge
    monkeypatch.setattr(explore_packed, "MERGE_CANDIDATES", 2)  # a level's slices merged
    assert explore_packed.threads() == 2
    assert compare_on_random_nets(25, seed=5) >= 25


def test_fields_widen_as_places_fill(monkeypatch: pytest.MonkeyPatch) -> None:
    # 'pile' starts with the bit of the largest initial count (1) and ends with 200 tokens
    # (eight bits): widened on the way, the level expanded again
    net = Net("fill")
    source, pile = net.add_place("source"), net.add_place("pile")
    net.add_transition("pour", {source: 1}, {pile: 200})
    net.add_transition("take", {pile: 1}, {})
    net.initial = {source: 1}
    widths = []

    def widened(packing: Packing, need: dict[int, int], top: int, hint: int) -> Packing:
        wider = packed_words.widened(packing, need, top, hint)
        widths.append(wider.bits[:2])
        return wider

    monkeypatch.setattr(explore_packed, "widened", widened)
    ss = rg.explore(net, arcs=False)
    assert widths == [(1, 8)]
    assert ss.engine == "packed" and ss.complete and ss.n_markings == 202
    assert ss.markings[1].tolist() == [0, 200] and rg.deadlocks(ss).tolist() == [201]
    assert_same(rg.explore(net, engine="numpy", arcs=False), ss, "fill")


def test_an_unbounded_place_stops_at_the_token_limit_with_its_witness() -> None:
    net = Net("grow")
    run, pile = net.add_place("run"), net.add_place("pile")
    net.add_transition("add", {run: 1}, {run: 1, pile: 1})
    net.initial = {run: 1}
    ss = rg.explore(net, arcs=False)
    assert ss.engine == "packed" and not ss.complete
    assert ss.stop_reason == "more than 255 tokens in a place" and ss.unbounded_place == pile
    assert ss.n_markings == 256 and ss.expanded == 255


def test_markings_wider_than_a_word_take_another_engine_and_without_numba_the_arcs_not(
        monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setitem(sys.modules, "petri.verification.explore_numba", None)  # numpy's,
    monkeypatch.delattr(petri.verification, "explore_numba", raising=False)  # not numba's
    wide = Net("wide")  # nine places of 200 tokens: 72 bits from the start
    places = [wide.add_place(f"p{i}") for i in range(9)]
    for a, b in zip(places, places[1:] + places[:1]):
        wide.add_transition(f"{a}-{b}", {a: 1}, {b: 1})
    wide.initial = {p: 200 for p in places}
    with pytest.raises(ValueError, match="do not fit one 64-bit word"):
        rg.explore(wide, engine="packed", arcs=False, max_markings=1000)
    assert rg.explore(wide, arcs=False, max_markings=1000).engine == "numpy"
    # fields that outgrow the word during the search: nine places given 64 tokens a firing
    # need 7 bits each after one firing (63 in all), 8 after two (72)
    grown = Net("grown")
    run = grown.add_place("run")  # never changed: no bits
    for i in range(9):
        grown.add_transition(f"fill {i}", {run: 1}, {run: 1, grown.add_place(f"q{i}"): 64})
    grown.initial = {run: 1}
    ss = rg.explore(grown, arcs=False)
    assert ss.engine == "numpy" and ss.stop_reason == "more than 255 tokens in a place"
    assert_same(rg.explore(grown, engine="numpy", arcs=False), ss, "grown")
    # without numba, the arcs too are searched on packed words where they fit
    assert rg.explore(cycles(3), arcs=True, engine="auto").engine == "bits"
    ring = Net("ring")  # not 1-safe: no bits engine
    p, q = ring.add_place("p"), ring.add_place("q")
    ring.add_transition("there", {p: 1}, {q: 1})
    ring.add_transition("back", {q: 1}, {p: 1})
    ring.initial = {p: 3}
    ss = rg.explore(ring, arcs=True)
    assert ss.engine == "packed" and ss.n_arcs == 6
    assert_same(rg.explore(ring, engine="numpy", arcs=True), ss, "ring")


@pytest.mark.slow
def test_auto_takes_the_packed_search_without_arcs_only() -> None:
    big = cycles(17)  # 131,072 markings: past the bits engine's first try
    assert rg.explore(big, arcs=False).engine == "packed"
    net = Net("two")  # not 1-safe: no bits engine
    p, q = net.add_place("p"), net.add_place("q")
    net.add_transition("move", {p: 1}, {q: 1})
    net.initial = {p: 2}
    assert rg.explore(net, arcs=False).engine == "packed"
    assert rg.explore(net, arcs=True).engine in ("numba", "numpy")  # the arcs: not packed


@pytest.mark.slow
def test_the_packed_search_stops_at_its_byte_budget() -> None:
    net = cycles(20)  # 1,048,576 markings of 40 one-bit fields, 20 successors each
    ss = rg.explore(net, 2_000_000, engine="packed", arcs=False, max_bytes=32 << 20)
    assert not ss.complete and ss.stop_reason == "the memory budget of 32 MiB"
    assert ss.degree is not None and 0 < ss.expanded <= ss.n_markings < 1 << 20
    assert (ss.degree[: ss.expanded] == 20).all() and not ss.degree[ss.expanded:].any()


def test_merge_sorted_puts_new_words_in_their_places(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(explore_packed, "MERGE_ROWS", 4)
    rng = np.random.default_rng(3)
    for size, extra in ((0, 5), (10, 0), (37, 11), (200, 150)):
        both = rng.choice(10_000, size + extra, replace=False).astype(np.uint64)
        old, new = np.sort(both[:size]), np.sort(both[size:])
        keys = np.zeros(size + extra + 7, dtype=np.uint64)
        keys[:size] = old
        tags = np.zeros(len(keys), dtype=np.int32)
        tags[:size] = old.astype(np.int32)
        explore_packed.merge_sorted(keys, size, new, [(tags, new.astype(np.int32))])
        assert keys[: size + extra].tolist() == sorted(both.tolist())
        assert tags[: size + extra].tolist() == sorted(both.tolist())
