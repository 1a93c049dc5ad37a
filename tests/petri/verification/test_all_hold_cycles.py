"""The quick verdict's cycle test (petri/verification/all_hold.py, ``Graph.acyclic``), which
looks for cycles only among the markings reachable from the targets of back arcs, against a
plain depth-first search on random graphs."""

from __future__ import annotations

from array import array
from bisect import bisect_left

from hypothesis import given, settings
from hypothesis import strategies as st

from petri.verification.all_hold import Graph


def graph(n: int, arcs: list[tuple[int, int]]) -> Graph:
    """A Graph of ``n`` markings with these arcs (sorted by source, as the search gives
    them), and only what ``acyclic`` reads."""
    arcs = sorted(arcs)
    g = Graph.__new__(Graph)
    g.order = list(range(n))
    g.src = array("i", [s for s, _ in arcs])
    g.dst = array("i", [d for _, d in arcs])
    g.starts = [bisect_left(g.src, m) for m in range(n + 1)]
    return g


def has_cycle(n: int, arcs: list[tuple[int, int]]) -> bool:
    """A cycle among the arcs, by depth-first search (white, grey, black)."""
    out: list[list[int]] = [[] for _ in range(n)]
    for s, d in arcs:
        out[s].append(d)
    colour = [0] * n
    for root in range(n):
        if colour[root]:
            continue
        stack = [(root, iter(out[root]))]
        colour[root] = 1
        while stack:
            m, rest = stack[-1]
            after = next(rest, None)
            if after is None:
                colour[m] = 2
                stack.pop()
            elif colour[after] == 1:
                return True
            elif colour[after] == 0:
                colour[after] = 1
                stack.append((after, iter(out[after])))
    return False


@settings(max_examples=200, deadline=None)
@given(st.integers(1, 12).flatmap(lambda n: st.tuples(
    st.just(n), st.lists(st.tuples(st.integers(0, n - 1), st.integers(0, n - 1),
                                   st.booleans()), max_size=30))))
def test_acyclic_finds_a_cycle_exactly_where_there_is_one(
        case: tuple[int, list[tuple[int, int, bool]]]) -> None:
    n, drawn = case
    g = graph(n, [(s, d) for s, d, _ in drawn])
    marked = [m for _, _, m in sorted(drawn)]  # the arcs ``arcs`` marks, in the graph's order
    chosen = [(s, d) for s, d, m in sorted(drawn) if m]
    assert g.acyclic(marked) == (not has_cycle(n, chosen))


def test_a_cycle_reached_only_through_forward_arcs_is_found() -> None:
    # 0 -> 1 -> 2 -> 3 -> 1: the back arc 3 -> 1 closes it; 0 -> 4 is on no cycle
    arcs = [(0, 1), (0, 4), (1, 2), (2, 3), (3, 1)]
    g = graph(5, arcs)
    assert not g.acyclic([True] * 5)
    assert g.acyclic([True, True, True, True, False])  # the back arc unmarked
    assert not graph(1, [(0, 0)]).acyclic([True])  # a marking's arc to itself
