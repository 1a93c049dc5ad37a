"""petri/verification/graph.py and the verifier's graph answers, cross-checked against networkx.

The verifier searches its reachability graph with its own vectorised code (CSR arrays, a
breadth-first level at a time, Kahn's peeling for cycles). networkx is the independent
reference, on the same graph (:func:`petri.verification.reachability.as_digraph`):

* random small P/T nets (Hypothesis) and, when ../shared/mcc is there, small contest nets:
  BFS distances from the initial marking (``shortest_path``, ``Adjacency.path``) against
  ``networkx.shortest_path_length``; forward and backward reach against ``descendants`` and
  ``ancestors``; the markings on a cycle and the lasso against
  ``strongly_connected_components``;
* random small missions, verified: each counterexample is as short as networkx's shortest path
  to the marking it names, ``can-end`` fails exactly when networkx finds a marking of the
  main model that reaches no end, and its loop lies in a strongly connected component;
  ``terminates`` (the graph rule of a plain net) fails exactly when the main model has a
  cycle, with a lasso as short as networkx's.
"""

from __future__ import annotations

import tarfile
from pathlib import Path

import networkx as nx
import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from diagnostics import Source
from mcl import ast, printer, tasklib
from mcl.api import compile_source
from petri.net import Net
from petri.semantics import Semantics
from petri.formats.pnml import read_pnml
from petri.verification import graph as graph_module
from petri.verification import reachability as rg
from petri.verification.graph import Adjacency, Marked, lasso, on_cycles
from petri.verification.properties import Verdict, verify
from tests.strategies import LAMP_OFF, LAMP_ON, bodies, generic_calls, generic_missions

GENERIC = tasklib.load(["generic"])
MCC = Path(__file__).resolve().parents[4] / "shared" / "mcc" / "models"
SMALL_MCC = ["Angiogenesis-PT-01", "ResAllocation-PT-R005C002", "DatabaseWithMutex-PT-02",
             "TokenRing-PT-005", "CircularTrains-PT-012", "Philosophers-PT-000005"]
SETTINGS = settings(max_examples=60, deadline=None, derandomize=True,
                    suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])


@st.composite
def small_nets(draw: st.DrawFn) -> Net:
    """A random P/T net of 2-5 places and 1-6 transitions (arc weights 1 or 2), any initial
    marking of up to 2 tokens a place: cycles, deadlocks, unbounded places all come up."""
    net = Net("random")
    places = [net.add_place(f"p{i}") for i in range(draw(st.integers(2, 5)))]
    some = st.lists(st.sampled_from(places), max_size=3, unique=True)
    for t in range(draw(st.integers(1, 6))):
        inputs = {p: draw(st.integers(1, 2)) for p in draw(some)}
        outputs = {p: draw(st.integers(1, 2)) for p in draw(some)}
        net.add_transition(f"t{t}", inputs, outputs)
    net.initial = {p: n for p in places if (n := draw(st.integers(0, 2)))}
    return net


def cyclic_nodes(graph: nx.MultiDiGraph) -> set[int]:
    """The markings on a cycle: in a strongly connected component of two or more, or with a
    firing back to themselves."""
    out: set[int] = set()
    for component in nx.strongly_connected_components(graph):
        if len(component) > 1 or any(graph.has_edge(m, m) for m in component):
            out |= component
    return out


def shortest_cycle(graph: nx.MultiDiGraph, m: int) -> int:
    """The length of a shortest cycle through ``m`` (networkx)."""
    back = [p for p in graph.predecessors(m) if nx.has_path(graph, m, p)]
    return min(int(nx.shortest_path_length(graph, m, p)) + 1 for p in back)


def check_against_networkx(net: Net, ss: rg.StateSpace) -> None:
    """Every graph answer of the verifier's code on ``ss`` equals networkx's."""
    graph = rg.as_digraph(net, ss)
    n = ss.n_markings
    assert graph.number_of_nodes() == n and graph.number_of_edges() == len(ss.src)
    # BFS distances: the numbering, shortest_path and Adjacency.path
    distance = nx.single_source_shortest_path_length(graph, 0)
    assert set(distance) == set(range(n))  # every marking was reached from the initial one
    assert [distance[m] for m in range(n)] == sorted(distance[m] for m in range(n))
    adjacency = Adjacency(n, ss.src, ss.dst)
    for m in range(1, n):
        assert len(rg.shortest_path(ss, [m])) == distance[m]
        goal = np.zeros(n, bool)
        goal[m] = True
        path, end = adjacency.path(0, goal)
        assert (len(path), end) == (distance[m], m)
    # reach, forward and backward, inside a part of the graph
    inside = np.arange(n) % 3 != 1
    inside[0] = True
    part = graph.subgraph(np.flatnonzero(inside).tolist())
    part_distance = nx.single_source_shortest_path_length(part, 0)
    for m in np.flatnonzero(inside)[1:].tolist():
        goal = np.zeros(n, bool)
        goal[m] = True
        path, end = adjacency.path(0, goal, within=inside)
        assert (len(path), end) == ((part_distance[m], m) if m in part_distance else (0, -1))
    for m in np.flatnonzero(inside)[:8].tolist():
        forward = adjacency.reach(np.array([m]), within=inside)
        assert set(np.flatnonzero(forward).tolist()) == nx.descendants(part, m) | {m}
        backward = adjacency.reach(np.array([m]), backward=True, within=inside)
        assert set(np.flatnonzero(backward).tolist()) == nx.ancestors(part, m) | {m}
    # the markings on a cycle inside `inside`, and the lasso to one of them
    cycles = cyclic_nodes(part)
    peeled = set(np.flatnonzero(on_cycles(n, inside, ss.src, ss.dst)).tolist())
    around = set().union(*(nx.descendants(part, c) for c in cycles)) | cycles
    assert peeled == around & (set().union(*(nx.ancestors(part, c) for c in cycles)) | cycles)
    found = lasso(ss, adjacency, inside, ss.src, ss.dst, adjacency)
    if not cycles:
        assert found is None
        return
    assert found is not None
    at, prefix, cycle = found
    assert at in cycles and at == min(peeled & cycles)
    assert len(prefix) == distance[at]
    assert len(cycle) == shortest_cycle(part, at)


@SETTINGS
@given(small_nets())
def test_random_nets_agree_with_networkx(net: Net) -> None:
    ss = rg.explore(net, max_markings=200, max_tokens=4)
    check_against_networkx(net, ss)


@SETTINGS
@given(small_nets())
def test_random_nets_nearest_violations_are_networkx_nearest(net: Net) -> None:
    # a net of no mission: no end place, so every marking without successors is a deadlock
    verdict = verify(net, max_markings=200, keep_graph=True)
    assert verdict.space is not None
    graph = rg.as_digraph(net, verdict.space)
    distance = nx.single_source_shortest_path_length(graph, 0)
    expanded = (verdict.space.n_markings if verdict.space.complete
                else verdict.space.expanded)
    bad = {"no-deadlock": {m for m in graph if graph.out_degree(m) == 0 and m < expanded},
           "one-safe": {m for m in graph if verdict.space.markings[m].max() > 1}}
    for r in verdict.results:
        if r.name in bad and bad[r.name]:
            assert r.status == "fails" and r.counterexample is not None
            assert len(r.counterexample) == min(distance[m] for m in bad[r.name])
        elif r.name in bad:
            assert r.status == ("holds" if verdict.space.complete else "undecided")


@pytest.mark.parametrize("model", SMALL_MCC)
def test_contest_nets_agree_with_networkx(model: str, tmp_path: Path) -> None:
    archive = MCC / f"{model}.tgz"
    if not archive.is_file():
        pytest.skip(f"{archive} is absent: the contest models are not available")
    with tarfile.open(archive) as tar:
        tar.extractall(tmp_path, filter="data")
    net = read_pnml(tmp_path / model / "model.pnml")
    ss = rg.explore(net)
    assert ss.complete
    check_against_networkx(net, ss)


# -- the verifier's counterexamples on random missions -------------------------------------

NEVER_FAIL = st.sampled_from([ast.Call("Now", ()), LAMP_ON, LAMP_OFF])


@st.composite
def looping_missions(draw: st.DrawFn) -> ast.Mission:
    """A block, then a WHILE whose condition and body are mostly tasks that never fail: a
    loop that cannot end (a lasso for ``terminates``), often in zero time (``no-zeno``)."""
    leaf = st.one_of(NEVER_FAIL, generic_calls(lone_lamp_on=True))
    first = draw(bodies(generic_calls(lone_lamp_on=True), 2, 3))
    loop = ast.WhileDo(draw(bodies(leaf, 1, 2)), draw(bodies(leaf, 1, 2)))
    items = first.items if isinstance(first, ast.Sequence) else (first,)
    return ast.Mission(None, ast.Sequence((*items, loop)))


def main_model(net: Net, verdict: Verdict) -> tuple[nx.MultiDiGraph, set[int], set[int]]:
    """networkx's view of the verification model: the graph without the external stop's
    firings (from the initial marking), the final markings (the mission's ok or fail place
    marked, nothing else but latch states), and the main model's markings that reach none."""
    assert verdict.space is not None
    rules = Semantics(net)
    graph = rg.as_digraph(net, verdict.space)
    main = nx.MultiDiGraph()
    main.add_node(0)
    main.add_edges_from((s, d, k) for s, d, k in graph.edges(keys=True)
                        if k not in rules.stops)
    main = main.subgraph(nx.descendants(main, 0) | {0}).copy()
    rows = verdict.space.markings
    latch = set(rules.latch_states)
    final = {m for m in graph if any(rows[m][p] for p in rules.ends)
             and sum(int(x) for p, x in enumerate(rows[m]) if p not in latch) == 1}
    can_end = set().union(*(nx.ancestors(main, f) | {f} for f in final & set(main)))
    return main, final, set(main) - can_end


@pytest.mark.slow
@settings(max_examples=80, deadline=None, derandomize=True,
          suppress_health_check=[HealthCheck.too_slow])
@given(st.one_of(generic_missions(max_depth=2, max_calls=5, lamps="free"), looping_missions()))
def test_counterexamples_are_networkx_shortest_paths(mission: ast.Mission) -> None:
    net = compile_source(Source("g.mcl", printer.mission(mission)), library=GENERIC).net
    verdict = verify(net, max_markings=50_000, keep_graph=True)
    assert verdict.space is not None and verdict.space.complete
    graph = rg.as_digraph(net, verdict.space)
    distance = nx.single_source_shortest_path_length(graph, 0)
    results = {r.name: r for r in verdict.results}
    for r in verdict.results:  # a shortest firing sequence from the start, in the whole graph
        # (can-end, terminates: in the main model, below; a firing's own property and a
        # timed re-check's sequence are not searched in this graph)
        if r.counterexample is None or "timed model" in r.method or r.name in (
                "can-end", "terminates", "no-disable-while-held"):
            continue
        assert r.witness is not None
        assert len(r.counterexample) == distance[r.witness], r.name
    main, final, stuck = main_model(net, verdict)
    looping = cyclic_nodes(main)  # the graph rule: a reachable cycle is a run for ever
    every_run_ends = results["terminates"]
    assert every_run_ends.holds == (not looping)
    if looping:
        assert every_run_ends.witness in looping and every_run_ends.cycle is not None
        assert every_run_ends.counterexample is not None
        assert len(every_run_ends.counterexample) == nx.shortest_path_length(
            main, 0, every_run_ends.witness)
        assert len(every_run_ends.cycle) == shortest_cycle(main.subgraph(looping),
                                                           every_run_ends.witness)
    terminates = results["can-end"]
    assert terminates.holds == (not stuck)
    if stuck:
        loops = cyclic_nodes(main.subgraph(stuck))
        assert (terminates.cycle is not None) == bool(loops)
        if loops:
            assert terminates.witness in loops
            assert terminates.counterexample is not None and terminates.cycle is not None
            main_distance = nx.shortest_path_length(main, 0, terminates.witness)
            assert len(terminates.counterexample) == main_distance
            assert len(terminates.cycle) == shortest_cycle(main.subgraph(stuck),
                                                           terminates.witness)
    deadlocks = {m for m in graph if graph.out_degree(m) == 0} - final
    no_deadlock = results["no-deadlock"]
    assert no_deadlock.holds == (not deadlocks)
    if deadlocks:
        assert no_deadlock.counterexample is not None
        assert len(no_deadlock.counterexample) == min(distance[m] for m in deadlocks)


def test_the_verdict_keeps_the_graph_only_when_asked() -> None:
    net = compile_source(Source("w.mcl", "MISSION { A(); WHILE { Now() } DO { B() } }"),
                         library=GENERIC).net
    assert verify(net).space is None  # a run that verifies first does not hold it
    verdict = verify(net, keep_graph=True)
    assert verdict.space is not None
    assert (verdict.space.n_markings, len(verdict.space.src)) == (verdict.markings,
                                                                  verdict.arcs)


def test_kept_columns_answer_as_the_markings_do() -> None:
    """Marked.keep gathers columns once; every question it can answer from that copy gets
    the answer the markings give, and the others are still asked of the markings."""
    rng = np.random.default_rng(7)
    markings = (rng.random((200, 40)) < 0.2).astype(np.uint8) * rng.integers(1, 3, (200, 40),
                                                                            dtype=np.uint8)
    plain, kept = Marked(markings), Marked(markings)
    kept.keep([3, 9, 9, 17, 25, 31])
    assert kept.kept is not None and kept.kept.shape == (200, 5)
    rows = np.array([0, 5, 5, 199, 42])
    for key in [(slice(None), [9, 3]), (slice(None), [25]), (rows, [31, 17, 3, 9, 25]),
                np.ix_(rows, np.array([17, 3])), (slice(None), [3, 4]), (slice(2, 9), [5]),
                (slice(None), slice(3, 9)), (rows, 31)]:
        assert np.array_equal(kept[key], plain[key]), key
        assert np.array_equal(plain[key], markings[key] > 0)
    kept.kept[:, 0] = ~kept.kept[:, 0]  # the copy is what answers for kept columns
    assert not np.array_equal(kept[:, [3]], plain[:, [3]])
    assert np.array_equal(kept[:, [4]], plain[:, [4]])


@pytest.mark.parametrize("narrow", [0, 3, 10**9])  # numpy only, both, Python only
def test_reach_is_the_same_however_wide_a_level_is_expanded(
        narrow: int, monkeypatch: pytest.MonkeyPatch) -> None:
    rng = np.random.default_rng(11)
    n = 300
    src = rng.integers(0, n, 900).astype(np.int32)
    dst = rng.integers(0, n, 900).astype(np.int32)
    graph = nx.DiGraph()
    graph.add_nodes_from(range(n))
    graph.add_edges_from(zip(src.tolist(), dst.tolist()))
    within = rng.random(n) < 0.8
    monkeypatch.setattr(graph_module, "NARROW", narrow)
    adj = Adjacency(n, src, dst)
    for sources in ([0], [5, 17, 17, 230], list(range(0, n, 7))):
        forward = {s for s in sources} | {d for s in sources for d in nx.descendants(graph, s)}
        backward = {s for s in sources} | {a for s in sources for a in nx.ancestors(graph, s)}
        assert set(np.flatnonzero(adj.reach(np.array(sources)))) == forward
        assert set(np.flatnonzero(adj.reach(np.array(sources), backward=True))) == backward
        inside = graph.subgraph([m for m in range(n) if within[m]] + sources)
        kept = {s for s in sources} | {d for s in sources for d in nx.descendants(inside, s)}
        assert set(np.flatnonzero(adj.reach(np.array(sources), within=within))) == kept


def test_unique_is_numpys() -> None:
    rng = np.random.default_rng(3)
    for size in (0, 1, 2, 50, 1000):
        values = rng.integers(-5, 40, size)
        assert np.array_equal(graph_module.unique(values), np.unique(values))
        assert graph_module.unique(values).dtype == np.int64
