"""The parallel frontier expansion (petri/verification/explore_parallel.py) gives the graph of
the sequential numba kernel: the same numbering, arcs, parents, counts and stopping point, on
random nets and on a net whose frontier is wide, with and without the arcs, under the marking
and token limits, and when the threads' buffers fill at every marking."""

from __future__ import annotations

import numpy as np
import pytest

from petri.net import Net
from petri.verification import reachability as rg
from tests.petri.verification.test_explore_packed import assert_same
from tests.petri.verification.test_reachability import random_net

explore_numba = pytest.importorskip("petri.verification.explore_numba")


def rings(components: int, tokens: int) -> Net:
    """``components`` independent two-place rings, ``tokens`` tokens each: (tokens + 1) **
    components markings, most of them in a few wide BFS levels."""
    net = Net(f"rings{components}x{tokens}")
    for c in range(components):
        a, b = net.add_place(f"a{c}"), net.add_place(f"b{c}")
        net.add_transition(f"go{c}", [a], [b])
        net.add_transition(f"back{c}", [b], [a])
        net.initial[a] = tokens
    return net


def explored(monkeypatch: pytest.MonkeyPatch, net: Net, parallel: bool, arcs: bool,
             **limits: int) -> rg.StateSpace:
    with monkeypatch.context() as m:
        m.setattr(explore_numba, "PARALLEL", parallel)
        return rg.explore(net, engine="numba", arcs=arcs, **limits)


@pytest.mark.parametrize("arcs", [True, False])
def test_random_nets_in_parallel_chunks_of_any_size(monkeypatch: pytest.MonkeyPatch,
                                                    arcs: bool) -> None:
    # Every frontier goes to the parallel phase (WIDE = 1), and each thread's buffer holds
    # one marking's successors at most (BUFFER_SUCCESSORS = 1): the threads stop early.
    rng = np.random.default_rng(27)
    parallel_runs = 0
    for i in range(40):
        net = random_net(rng, i)
        for limits in ({"max_tokens": 6}, {"max_markings": 40, "max_tokens": 200}):
            sequential = explored(monkeypatch, net, False, arcs, **limits)
            for buffer in (1, 65536):
                with monkeypatch.context() as m:
                    m.setattr(explore_numba, "WIDE", 1)
                    m.setattr(explore_numba, "BUFFER_SUCCESSORS", buffer)
                    parallel = explored(monkeypatch, net, True, arcs, **limits)
                assert_same(parallel, sequential, f"{net.name} {limits} buffer {buffer}")
            parallel_runs += sequential.n_markings > 10
    assert parallel_runs >= 10


@pytest.mark.parametrize("arcs", [True, False])
def test_a_wide_frontier_in_parallel(monkeypatch: pytest.MonkeyPatch, arcs: bool) -> None:
    net = rings(5, 6)  # 16,807 markings, levels up to a few thousand wide
    sequential = explored(monkeypatch, net, False, arcs)
    parallel = explored(monkeypatch, net, True, arcs)
    assert sequential.complete and sequential.n_markings == 7 ** 5
    assert_same(parallel, sequential, net.name)
    numpy = rg.explore(net, engine="numpy", arcs=arcs)
    assert np.array_equal(parallel.markings, numpy.markings)


@pytest.mark.parametrize("limits", [{"max_markings": 5000}, {"max_tokens": 20}])
def test_limits_stop_the_parallel_search_where_the_sequential_one_stops(
        monkeypatch: pytest.MonkeyPatch, limits: dict[str, int]) -> None:
    net = rings(4, 5)  # and a transition without inputs that piles tokens up: unbounded
    net.add_transition("make", [], [net.add_place("pile")])
    sequential = explored(monkeypatch, net, False, True, **limits)
    parallel = explored(monkeypatch, net, True, True, **limits)
    assert not sequential.complete
    assert_same(parallel, sequential, f"{net.name} {limits}")


def test_parallel_only_with_an_idle_core(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(explore_numba, "PARALLEL", None)
    monkeypatch.setattr(explore_numba.os, "getloadavg", lambda: (64.0, 64.0, 64.0))
    assert explore_numba.parallel_threads() == 0
    monkeypatch.setattr(explore_numba, "PARALLEL", False)
    monkeypatch.setattr(explore_numba.os, "getloadavg", lambda: (0.0, 0.0, 0.0))
    assert explore_numba.parallel_threads() == 0
    monkeypatch.setattr(explore_numba, "PARALLEL", True)
    assert explore_numba.parallel_threads() >= 1
