"""Explicit reachability: hand-made nets with known answers, limits, shortest firing sequences,
the numpy fallback against the numba kernel, and pm4py's reachability graph as an independent
reference on small nets."""

from __future__ import annotations

import numpy as np
import pytest

from petri.verification import reachability as rg
from petri.net import END_FAIL, END_OK, Net

ENGINES = ["numpy"] + (["numba"] if rg.default_engine() == "numba" else [])


def marking_set(ss: rg.StateSpace) -> set[tuple[int, ...]]:
    return {tuple(int(x) for x in row) for row in ss.markings}


def fire(net: Net, marking: np.ndarray, t: int) -> np.ndarray:
    tr = net.transitions[t]
    assert all(marking[p] >= w for p, w in tr.inputs), f"transition {t} is not enabled"
    marking = marking.copy()
    for p, d in net.effect(t).items():
        marking[p] += d
    return marking


# -- hand-made nets -----------------------------------------------------------------------

@pytest.mark.slow
@pytest.mark.parametrize("engine", ENGINES)
def test_a_deadlock(engine: str) -> None:
    # start --t0--> middle --t1--> end, one token: three markings in a line, the last dead.
    net = Net("line")
    start, middle, end = (net.add_place(n) for n in ("start", "middle", "end"))
    net.add_transition("t0", [start], [middle])
    net.add_transition("t1", [middle], [end])
    net.initial = {start: 1}
    ss = rg.explore(net, engine=engine)
    assert ss.complete and ss.engine == engine
    assert ss.markings.tolist() == [[1, 0, 0], [0, 1, 0], [0, 0, 1]]
    assert list(zip(ss.src.tolist(), ss.dst.tolist(), ss.transition.tolist())) == [
        (0, 1, 0), (1, 2, 1)]
    assert rg.deadlocks(ss).tolist() == [2]
    assert rg.dead_transitions(net, ss) == []
    assert rg.shortest_path(ss, rg.deadlocks(ss)) == [0, 1]
    assert rg.is_one_safe(ss)


@pytest.mark.parametrize("engine", ENGINES)
def test_an_unsafe_place(engine: str) -> None:
    # t0 puts two tokens (a weight-2 arc) into 'pile'; t1 takes them one by one.
    net = Net("unsafe")
    src, pile, done = (net.add_place(n) for n in ("src", "pile", "done"))
    net.add_transition("t0", {src: 1}, {pile: 2})
    net.add_transition("t1", {pile: 1}, {done: 1})
    net.initial = {src: 1}
    ss = rg.explore(net, engine=engine)
    # {src} -> {pile x2} -> {pile, done} -> {done x2}
    assert ss.markings.tolist() == [[1, 0, 0], [0, 2, 0], [0, 1, 1], [0, 0, 2]]
    assert rg.max_tokens(ss) == 2
    assert not rg.is_one_safe(ss)
    assert rg.place_bounds(ss).tolist() == [1, 2, 2]
    assert rg.deadlocks(ss).tolist() == [3]


@pytest.mark.parametrize("engine", ENGINES)
def test_a_livelock_cycle_and_a_dead_transition(engine: str) -> None:
    # a <-> b forever; 'never' needs a token in 'c', which no transition produces.
    net = Net("cycle")
    a, b, c = (net.add_place(n) for n in ("a", "b", "c"))
    net.add_transition("ab", [a], [b])
    net.add_transition("ba", [b], [a])
    net.add_transition("never", [c], [a])
    net.initial = {a: 1}
    ss = rg.explore(net, engine=engine)
    assert ss.n_markings == 2 and ss.n_arcs == 2
    assert rg.deadlocks(ss).size == 0
    assert rg.dead_transitions(net, ss) == [2]


@pytest.mark.parametrize("engine", ENGINES)
def test_a_two_bounded_net(engine: str) -> None:
    # two tokens move between 'left' and 'right': (2,0), (1,1), (0,2); four arcs.
    net = Net("two")
    left, right = net.add_place("left"), net.add_place("right")
    net.add_transition("go", [left], [right])
    net.add_transition("back", [right], [left])
    net.initial = {left: 2}
    ss = rg.explore(net, engine=engine)
    assert marking_set(ss) == {(2, 0), (1, 1), (0, 2)}
    assert ss.n_arcs == 4
    assert rg.max_tokens(ss) == 2
    assert rg.shortest_path(ss, [ss.markings.tolist().index([0, 2])]) == [0, 0]


@pytest.mark.parametrize("engine", ENGINES)
def test_weighted_input_arcs(engine: str) -> None:
    # 'pair' needs 2 tokens of 'p': from 5 tokens it fires twice; 1 token is left over.
    net = Net("weights")
    p, q = net.add_place("p"), net.add_place("q")
    net.add_transition("pair", {p: 2}, {q: 1})
    net.initial = {p: 5}
    ss = rg.explore(net, engine=engine)
    assert ss.markings.tolist() == [[5, 0], [3, 1], [1, 2]]


@pytest.mark.parametrize("engine", ENGINES)
def test_an_unbounded_place_is_found(engine: str) -> None:
    # 'gen' puts a token in 'heap' and keeps its own token: heap grows forever.
    net = Net("unbounded")
    gen, heap = net.add_place("gen"), net.add_place("heap")
    net.add_transition("more", [gen], [gen, heap])
    net.initial = {gen: 1}
    ss = rg.explore(net, max_tokens=10, engine=engine)
    assert not ss.complete
    assert ss.stop_reason == "more than 10 tokens in a place"
    assert ss.unbounded_place == heap
    assert ss.n_markings == 11  # heap = 0 .. 10


@pytest.mark.parametrize("engine", ENGINES)
def test_the_marking_limit_stops_the_search(engine: str) -> None:
    net = Net("counter")
    gen, heap = net.add_place("gen"), net.add_place("heap")
    net.add_transition("more", [gen], [gen, heap])
    net.initial = {gen: 1}
    ss = rg.explore(net, max_markings=5, engine=engine)
    assert not ss.complete and ss.n_markings == 5
    assert ss.stop_reason == "more than 5 markings"
    assert ss.unbounded_place == heap  # the path 0..4 already shows the covering


@pytest.mark.parametrize("engine", ENGINES)
def test_deadlocks_found_before_a_limit_are_real(engine: str) -> None:
    # 'more' grows 'heap' forever; 'stop' moves the generator's token to 'end': dead then.
    net = Net("grow then stop")
    gen, heap, end = (net.add_place(n) for n in ("gen", "heap", "end"))
    net.add_transition("more", [gen], [gen, heap])
    net.add_transition("stop", [gen], [end])
    net.initial = {gen: 1}
    ss = rg.explore(net, max_tokens=5, engine=engine)
    assert not ss.complete and ss.unbounded_place == heap
    dead = rg.deadlocks(ss)
    assert dead.size >= 4 and (dead < ss.expanded).all()
    for m in dead:  # {end, heap x k}: nothing is enabled
        assert ss.markings[m, gen] == 0 and ss.markings[m, end] == 1


def test_wider_rows_when_places_hold_more_than_255_tokens() -> None:
    net = Net("big")
    p, q = net.add_place("p"), net.add_place("q")
    net.add_transition("move", {p: 100}, {q: 100})
    net.initial = {p: 1000}
    ss = rg.explore(net, max_tokens=1000)
    assert ss.markings.dtype == np.uint16
    assert ss.markings[-1].tolist() == [0, 1000] and ss.n_markings == 11


def test_the_initial_marking_must_respect_max_tokens() -> None:
    net = Net("x")
    net.initial = {net.add_place("p"): 300}
    with pytest.raises(ValueError, match="max_tokens=255"):
        rg.explore(net)


# -- random nets: shortest paths, the two engines, pm4py ----------------------------------

def random_net(rng: np.random.Generator, index: int) -> Net:
    net = Net(f"random{index}")
    n_places = int(rng.integers(2, 7))
    for p in range(n_places):
        net.add_place(f"p{p}")
    for t in range(int(rng.integers(1, 7))):
        ins = {int(p): int(rng.integers(1, 3)) for p in rng.choice(
            n_places, size=int(rng.integers(1, 3)), replace=False)}
        outs = {int(p): int(rng.integers(1, 3)) for p in rng.choice(
            n_places, size=int(rng.integers(0, 3)), replace=False)}
        net.add_transition(f"t{t}", ins, outs)
    net.initial = {p: int(rng.integers(0, 3)) for p in range(n_places)}
    return net


def bounded_random_nets(count: int, seed: int = 7) -> list[tuple[Net, rg.StateSpace]]:
    rng = np.random.default_rng(seed)
    nets = []
    for i in range(count):
        net = random_net(rng, i)
        ss = rg.explore(net, max_markings=3000, max_tokens=12)
        if ss.complete:
            nets.append((net, ss))
    assert len(nets) >= count // 3, "too few bounded random nets to compare"
    return nets


def test_shortest_paths_are_firable_and_shortest() -> None:
    for net, ss in bounded_random_nets(40):
        # BFS distances from the arcs, independently of the parent array
        dist = np.full(ss.n_markings, -1)
        dist[0] = 0
        frontier = [0]
        for depth in range(1, ss.n_markings + 1):
            nxt = sorted({int(d) for s, d in zip(ss.src, ss.dst) if s in frontier
                          and dist[d] < 0})
            dist[nxt] = depth
            frontier = nxt
            if not nxt:
                break
        for target in range(0, ss.n_markings, max(1, ss.n_markings // 7)):
            path = rg.shortest_path(ss, [target])
            assert len(path) == dist[target]
            marking = net.initial_vector()
            for t in path:
                marking = fire(net, marking, t)
            assert marking.tolist() == ss.markings[target].tolist()
            # the same answer from a state space without parents
            plain = rg.StateSpace(ss.markings, ss.src, ss.dst, ss.transition, True)
            assert len(rg.shortest_path(plain, [target])) == dist[target]


@pytest.mark.skipif("numba" not in ENGINES, reason="numba is not installed")
def test_numpy_fallback_numbers_markings_like_the_numba_kernel() -> None:
    rng = np.random.default_rng(11)
    for i in range(60):
        net = random_net(rng, i)
        for limits in ({"max_tokens": 6}, {"max_markings": 40, "max_tokens": 200}):
            a = rg.explore(net, engine="numba", **limits)
            b = rg.explore(net, engine="numpy", **limits)
            assert (a.complete, a.stop_reason, a.unbounded_place) == \
                (b.complete, b.stop_reason, b.unbounded_place), net.name
            for key in ("markings", "src", "dst", "transition", "parent",
                        "parent_transition"):
                assert np.array_equal(getattr(a, key), getattr(b, key)), (net.name, key)


def test_numpy_levels_in_slices_number_markings_as_whole_levels(
        monkeypatch: pytest.MonkeyPatch) -> None:
    """A level is expanded a slice at a time so that no level allocates more than
    CHUNK_BYTES (issue 21: 28 GiB at once on Philosophers-PT-000050): slices of one row give
    the same graph as whole levels."""
    from petri.verification import explore_numpy

    rng = np.random.default_rng(13)
    compared = 0
    for i in range(60):
        net = random_net(rng, i)
        for most, tokens in ((20_000_000, 6), (40, 200)):
            whole = rg.explore(net, most, tokens, engine="numpy")
            with monkeypatch.context() as m:
                m.setattr(explore_numpy, "CHUNK_BYTES", 1)  # one row per slice
                sliced = rg.explore(net, most, tokens, engine="numpy")
            assert (whole.complete, whole.stop_reason, whole.unbounded_place) == \
                (sliced.complete, sliced.stop_reason, sliced.unbounded_place), net.name
            for key in ("markings", "src", "dst", "transition", "parent",
                        "parent_transition"):
                assert np.array_equal(getattr(whole, key), getattr(sliced, key)), \
                    (net.name, key)
            compared += whole.n_markings > 5
    assert compared >= 20


def to_pm4py(net: Net) -> tuple[object, object]:
    from pm4py.objects.petri_net.obj import Marking, PetriNet
    from pm4py.objects.petri_net.utils.petri_utils import add_arc_from_to

    pn = PetriNet(net.name)
    places = [PetriNet.Place(p.name) for p in net.places]
    for place in places:
        pn.places.add(place)
    for t in net.transitions:
        transition = PetriNet.Transition(t.name, t.name)
        pn.transitions.add(transition)
        for p, w in t.inputs:
            add_arc_from_to(places[p], transition, pn, weight=w)
        for p, w in t.outputs:
            add_arc_from_to(transition, places[p], pn, weight=w)
    return pn, Marking({places[p]: n for p, n in net.initial.items() if n})


def test_same_markings_and_arcs_as_pm4py() -> None:
    pytest.importorskip("pm4py")
    from pm4py.objects.petri_net.utils.reachability_graph import (
        construct_reachability_graph,
        marking_flow_petri,
    )

    compared = 0
    for net, ss in bounded_random_nets(40, seed=3):
        if ss.n_markings > 400:  # pm4py's search is quadratic
            continue
        pn, initial = to_pm4py(net)
        graph = construct_reachability_graph(pn, initial)
        assert len(graph.states) == ss.n_markings, net.name
        assert len(graph.transitions) == ss.n_arcs, net.name
        incoming, _outgoing, _ = marking_flow_petri(pn, initial)
        index = {p.name: i for i, p in enumerate(net.places)}
        theirs = set()
        for marking in incoming:
            row = [0] * len(net.places)
            for place, n in marking.items():
                row[index[place.name]] = n
            theirs.add(tuple(row))
        assert theirs == marking_set(ss), net.name
        compared += 1
    assert compared >= 10


# -- the symbolic search on the same small nets ---------------------------------------------

def test_exact_counts_of_bdds() -> None:
    symbolic = pytest.importorskip("petri.verification.symbolic")
    if not symbolic.available():
        pytest.skip("dd is not installed")
    bdd, _backend = symbolic.new_bdd()
    names = [f"x{i}" for i in range(8)]
    bdd.declare(*names)
    counter = symbolic.ExactCounter(bdd, len(names))
    rng = np.random.default_rng(5)
    for _ in range(40):  # random DNFs, counted against brute force over 2**8 assignments
        cubes = [{names[int(v)]: bool(rng.integers(2)) for v in rng.choice(8, 3, replace=False)}
                 for _ in range(int(rng.integers(1, 5)))]
        u = bdd.false
        for cube in cubes:
            u = u | bdd.cube(cube)
        u = ~u if rng.integers(2) else u  # complemented edges too
        brute = sum(1 for bits in range(256)
                    if bdd.let({n: bool(bits >> i & 1) for i, n in enumerate(names)}, u)
                    == bdd.true)
        assert counter.count(u) == brute


def test_symbolic_agrees_with_explicit_on_random_safe_nets() -> None:
    symbolic = pytest.importorskip("petri.verification.symbolic")
    if not symbolic.available():
        pytest.skip("dd is not installed")
    rng = np.random.default_rng(19)
    compared = 0
    for i in range(80):
        net = random_net(rng, i)
        net.initial = {p: min(n, 1) for p, n in net.initial.items()}
        for t, tr in enumerate(net.transitions):  # weight 1 everywhere
            net.transitions[t] = type(tr)(tr.name, tuple((p, 1) for p, _ in tr.inputs),
                                          tuple((p, 1) for p, _ in tr.outputs))
        ss = rg.explore(net, max_tokens=20, max_markings=5000)
        if not ss.complete:
            continue
        if not rg.is_one_safe(ss):
            with pytest.raises(symbolic.NotOneSafe):
                symbolic.explore(net)
            continue
        result = symbolic.explore(net)
        assert (result.markings, result.arcs) == (ss.n_markings, ss.n_arcs), net.name
        assert result.deadlock_reachable == bool(rg.deadlocks(ss).size), net.name
        assert result.dead_transitions == rg.dead_transitions(net, ss), net.name
        assert result.max_tokens == rg.max_tokens(ss), net.name
        compared += 1
    assert compared >= 10


# -- sparse nets: indexing by input place, counts without arcs, wide safe nets ---------------

@pytest.mark.parametrize("engine", ENGINES)
def test_counts_without_arcs_match_the_arcs(engine: str) -> None:
    rng = np.random.default_rng(5)
    for i in range(40):
        net = random_net(rng, i)
        for limits in ({"max_tokens": 6}, {"max_markings": 40, "max_tokens": 200}):
            full = rg.explore(net, engine=engine, **limits)
            lean = rg.explore(net, engine=engine, arcs=False, **limits)
            assert lean.n_arcs == full.n_arcs and not lean.src.size
            assert np.array_equal(rg.out_degree(lean), rg.out_degree(full)), net.name
            assert np.array_equal(rg.deadlocks(lean), rg.deadlocks(full)), net.name
            assert rg.dead_transitions(net, lean) == rg.dead_transitions(net, full)
            assert np.array_equal(lean.markings, full.markings)


@pytest.mark.parametrize("engine", ENGINES)
def test_a_marking_with_more_successors_than_a_batch(engine: str) -> None:
    # one marked place enables 700 transitions (the kernel's batch holds 256 at first), and
    # a transition without inputs fires everywhere
    net = Net("wide")
    hub = net.add_place("hub")
    outs = [net.add_place(f"out{i}") for i in range(700)]
    for i, p in enumerate(outs):
        net.add_transition(f"t{i}", [hub], [p])
    sink = net.add_place("sink")
    net.add_transition("source", [], [sink])
    net.initial = {hub: 1}
    ss = rg.explore(net, engine=engine, max_tokens=3)
    assert not ss.complete and ss.stop_reason == "more than 3 tokens in a place"
    assert ss.unbounded_place == sink
    net.transitions.pop()
    ss = rg.explore(net, engine=engine)
    assert ss.complete and ss.n_markings == 701 and ss.n_arcs == 700
    assert sorted(int(t) for t in ss.transition) == list(range(700))


def test_wide_safe_nets_by_marked_place_sets_as_by_rows() -> None:
    # a chain of 5,000 places (wider than SMALL_SAFE_PLACES) with a side loop on each tenth
    net = Net("chain")
    places = [net.add_place(f"p{i}") for i in range(5000)]
    for i in range(4999):
        net.add_transition(f"step{i}", [places[i]], [places[i + 1]])
    for i in range(0, 4990, 10):
        net.add_transition(f"back{i}", [places[i + 5]], [places[i]])
    net.initial = {places[0]: 1}
    sets = rg.explore(net)
    assert sets.engine == "bits" and sets.complete
    rows = rg.explore(net, engine=ENGINES[-1])
    for key in ("markings", "src", "dst", "transition", "parent", "parent_transition"):
        assert np.array_equal(getattr(sets, key), getattr(rows, key)), key


def test_transitions_are_looked_up_by_their_rarest_input() -> None:
    from petri.net import triggers

    net = Net("latch")
    off = net.add_place("off")
    begins = [net.add_place(f"begin{i}") for i in range(4)]
    for i, b in enumerate(begins):
        net.add_transition(f"t{i}", [off, b], [off])
    assert triggers(net) == begins  # "off" is read by every transition, each begin by one


def test_integer_and_set_markings_give_the_same_graph(monkeypatch: pytest.MonkeyPatch) -> None:
    from mcl.api import compile_source
    from diagnostics import Source
    from petri.verification import explore_bits as _explore_bits

    texts = ["MISSION { PARALLEL { Wait(1 s); GoTo((0, 0, 1, 0 deg)) } AND { Alarms() } }",
             "MISSION { TRY { StartCamera(enable); Wait(2 s); StartCamera(disable) } "
             "CATCH { Alarms() } DO { Surface() } }",
             "MISSION { WHILE { Wait(1 s) } DO { PARALLEL { Wait(1 s) } OR { Alarms() } } }"]
    for text in texts:
        net = compile_source(Source("m.mcl", text)).net
        ints = _explore_bits.explore_bits(net, 10_000)
        monkeypatch.setattr(_explore_bits, "WIDE", 0)
        sets = _explore_bits.explore_bits(net, 10_000)
        lean = _explore_bits.explore_bits(net, 10_000, arcs=False)
        monkeypatch.setattr(_explore_bits, "WIDE", 4096)
        assert ints is not None and sets is not None and lean is not None
        assert len(ints[0]) > 10  # type: ignore[arg-type]
        for a, b in zip(ints, sets):
            assert np.array_equal(np.asarray(a), np.asarray(b)), text
        degree = np.bincount(np.asarray(ints[1]), minlength=len(ints[0]))  # type: ignore[arg-type]
        assert np.array_equal(np.asarray(lean[7]), degree)


# -- the graph as networkx's ----------------------------------------------------------------

def test_as_digraph_has_a_node_per_marking_and_an_edge_per_firing() -> None:
    from diagnostics import Source
    from mcl.api import compile_source

    net = compile_source(Source("m.mcl", "MISSION { TRY { Wait(1 s) } CATCH { Alarms() } "
                                          "DO { Surface() } }")).net
    ss = rg.explore(net)
    graph = ss.to_networkx(net)
    assert graph.is_directed() and graph.is_multigraph()
    assert graph.number_of_nodes() == ss.n_markings
    assert graph.number_of_edges() == ss.n_arcs
    assert graph.graph == {"net": net.name, "complete": True}
    for a in range(ss.n_arcs):  # each arc is there once, keyed by its transition
        s, d, t = int(ss.src[a]), int(ss.dst[a]), int(ss.transition[a])
        edge = graph.edges[s, d, t]
        tr = net.transitions[t]
        assert edge["transition"] == t and edge["name"] == tr.name
        assert edge["label"] == tr.label
        assert edge.get("line") == (tr.origin.line if tr.origin else None)
    assert [m for m, initial in graph.nodes(data="initial") if initial] == [0]
    for m, data in graph.nodes(data=True):
        assert data["marking"] == net.describe_marking(ss.markings[m])
        marked = {net.places[p].role for p in np.flatnonzero(ss.markings[m])}
        assert data["end"] == ("ok" if END_OK in marked else
                               "fail" if END_FAIL in marked else "")
    ends = {data["end"] for _, data in graph.nodes(data=True)}
    assert ends == {"", "ok", "fail"}


def test_as_digraph_of_a_cut_exploration_says_so() -> None:
    net = Net("grow")
    p = net.add_place("p")
    net.add_transition("more", [], [p])
    ss = rg.explore(net, max_markings=5)
    graph = rg.as_digraph(net, ss)
    assert graph.graph["complete"] is False and graph.graph["stop_reason"] == ss.stop_reason
    assert graph.number_of_nodes() == 5
    assert [graph.nodes[m]["marking"] for m in range(3)] == ["{}", "{p}", "{p×2}"]
    assert all("line" not in data for _, _, data in graph.edges(data=True))  # no source


def test_as_digraph_needs_the_arcs() -> None:
    net = Net("line")
    a, b = net.add_place("a"), net.add_place("b")
    net.add_transition("t", [a], [b])
    net.initial = {a: 1}
    with pytest.raises(ValueError, match="without its arcs"):
        rg.as_digraph(net, rg.explore(net, arcs=False))
