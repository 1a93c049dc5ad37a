"""petri/formats/dot.py on its own: Graphviz text of a net, in full or as the paper's task view.

The text is read back with a small parser of the lines ``to_dot`` writes (nodes and edges), so
the tests check the graph, not the spelling: every place and transition in the full view, the
marking and weights shown; in the task view one grey node per task call and none of the abort
machinery, with the mission's normal flow from its start to each task.
"""

from __future__ import annotations

import re

import pytest

from diagnostics import Source
from mcl import tasklib
from mcl.api import compile_source
from petri.formats.dot import to_dot
from petri.net import Action, Net
from tests.support import shipped_nets

GENERIC = tasklib.load(["generic"])
NODE = re.compile(r'^  ("(?:[^"\\]|\\.)*"|\w+) \[(.*)\];$')
EDGE = re.compile(r'^  "((?:[^"\\]|\\.)*)" -> "((?:[^"\\]|\\.)*)"( \[label=(\d+)\])?;$')


def _graph(text: str) -> tuple[dict[str, str], dict[tuple[str, str], int]]:
    """The nodes (name -> attributes) and edges ((from, to) -> weight) of ``to_dot``'s text."""
    nodes: dict[str, str] = {}
    edges: dict[tuple[str, str], int] = {}
    for line in text.splitlines()[1:-1]:
        if m := EDGE.match(line):
            edges[(m[1], m[2])] = int(m[4] or 1)
        elif (m := NODE.match(line)) and m[1] not in ("node", "edge"):
            nodes[m[1].strip('"')] = m[2]
    return nodes, edges


def _mission(body: str) -> Net:
    return compile_source(Source("m.mcl", f"MISSION {{\n  {body}\n}}\n"), library=GENERIC).net


def _weighted() -> Net:
    net = Net('say "hi"')
    a = net.add_place("a")
    b = net.add_place("b", ("Lamp",))
    net.add_transition("t", {a: 2}, [b], event="Probe.ok",
                       actions=(Action("enable", "Lamp"),), label="go")
    net.add_transition("u", [b], [a, a], timer=1.5)
    net.initial = {a: 2}
    return net


def test_the_full_view_has_every_place_and_transition_and_arc() -> None:
    net = _mission("TRY { A() } CATCH { B() } DO { Wait(1 s) }")
    text = to_dot(net)
    assert text.startswith('digraph "mission" {\n') and text.endswith("}\n")
    nodes, edges = _graph(text)
    places = {n for n, attrs in nodes.items() if "shape=circle" in attrs}
    transitions = {n for n, attrs in nodes.items() if "shape=box" in attrs}
    assert places == {f"p{i}" for i in range(len(net.places))}
    assert transitions == {f"t{i}" for i in range(len(net.transitions))}
    arcs = {(f"p{p}", f"t{t}") for t, tr in enumerate(net.transitions) for p, _ in tr.inputs}
    arcs |= {(f"t{t}", f"p{p}") for t, tr in enumerate(net.transitions) for p, _ in tr.outputs}
    assert set(edges) == arcs


def test_the_full_view_shows_marking_weights_events_timers_and_actions() -> None:
    nodes, edges = _graph(to_dot(_weighted()))
    assert 'label="a\\n● ×2"' in nodes["p0"]  # two tokens, under the name (a DOT line break)
    assert 'fillcolor="#d7ecff"' in nodes["p1"] and "fillcolor" not in nodes["p0"]
    assert nodes["t0"].endswith('label="go\\non Probe.ok\\nenable Lamp"')
    assert nodes["t1"].endswith('label="u\\nafter 1.5"')
    assert edges == {("p0", "t0"): 2, ("t0", "p1"): 1, ("p1", "t1"): 1, ("t1", "p0"): 2}


def test_quotes_in_names_are_escaped() -> None:
    assert to_dot(_weighted()).startswith('digraph "say \\"hi\\"" {')


def test_an_unknown_view_is_refused() -> None:
    with pytest.raises(ValueError, match="'full' or 'tasks'"):
        to_dot(_weighted(), "tree")


def test_the_task_view_collapses_each_task_and_leaves_out_the_abort_machinery() -> None:
    net = _mission("A(); PARALLEL { B() } OR { Wait(1 s) }")
    nodes, edges = _graph(to_dot(net, "tasks"))
    tasks = {n: attrs for n, attrs in nodes.items() if n.startswith("task:")}
    assert set(tasks) == {"task:2:3", "task:2:19", "task:2:30"}
    assert all('fillcolor="#bbbbbb"' in attrs for attrs in tasks.values())
    assert 'label="Wait(1 s)\\nline 2"' in tasks["task:2:30"]
    boxes = [attrs for attrs in nodes.values() if "shape=box" in attrs]
    assert not [b for b in boxes if "aborted" in b or "had already ended" in b]
    labels = " ".join(boxes)
    assert "start every branch" in labels and "mission starts" in labels
    assert "the others stopped → ok" in labels  # the OR's normal end stays
    assert len(nodes) < len(net.places) + len(net.transitions) // 2


def _reachable(edges: dict[tuple[str, str], int], start: str) -> set[str]:
    seen, todo = {start}, [start]
    while todo:
        node = todo.pop()
        for a, b in edges:
            if a == node and b not in seen:
                seen.add(b)
                todo.append(b)
    return seen


@pytest.mark.parametrize("body", [
    "A(); B()",
    "PARALLEL { A() } AND { B() }",
    "IF { A() } THEN { B() } ELSE { C() }",
    "WHILE { A() } DO { B() }",
])
def test_in_the_task_view_every_task_follows_from_the_start(body: str) -> None:
    nodes, edges = _graph(to_dot(_mission(body), "tasks"))
    reached = _reachable(edges, "p0")  # MISSION.begin
    assert {n for n in nodes if n.startswith("task:")} <= reached


def test_in_the_task_view_do_follows_from_catch() -> None:
    nodes, edges = _graph(to_dot(_mission("TRY { A() } CATCH { B() } DO { C() }"), "tasks"))
    assert "task:2:34" in nodes and "task:2:34" in _reachable(edges, "p0")


SHIPPED = shipped_nets()  # each vehicle of a shipped fleet too


@pytest.mark.parametrize("name, net", SHIPPED, ids=[name for name, _ in SHIPPED])
def test_the_task_view_of_a_shipped_mission_is_one_connected_flow(name: str, net: Net) -> None:
    """Issue 21: the task view of the dam mission had places floating on top, unconnected."""
    nodes, edges = _graph(to_dot(net, "tasks"))
    start = next(n for n, attrs in nodes.items() if 'tooltip="MISSION.begin"' in attrs)
    tasks = {n for n in nodes if n.startswith("task:")}
    assert len(tasks) >= 4 and tasks <= _reachable(edges, start)
    linked = {a for a, _ in edges} | {b for _, b in edges}
    assert set(nodes) <= linked


def test_labels_break_lines_as_graphviz_does_not_with_a_written_backslash() -> None:
    text = to_dot(_mission("A(); B()"), "tasks") + to_dot(_weighted())
    assert "\\n" in text and "\\\\n" not in text
