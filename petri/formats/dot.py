"""Graphviz views of a net.

``full``: every place (circle, a dot when marked) and transition (box, with its event, timer
and actions). ``tasks``: like the paper's Figure 5, each task collapsed into one grey node and
only the normal flow of the control structures kept — what can happen from the mission's start
without an abort from outside: the abort machinery (stopping children on an abort, absorbing
late aborts, switching latches off) is left out, while the wait for a child stopped because its
sibling won (a TRY's CATCH, an OR's other branches) stays, since the normal flow goes on from
it. Places in the task view are small unlabelled circles (their names as tooltips), so the
mission's shape shows at a glance.
"""

from __future__ import annotations

import re
from collections.abc import Iterable

from petri.net import Net, Transition

# Transitions that belong to the abort machinery, left out of the task view...
ABORT_MACHINERY = re.compile(r"\.(abort|stop|late_|stopped|cleanup|off\.|keep\.)|abort_|\.from\.")
# ...except the wait for a child that a control structure stopped on its normal path.
STOPPED_CHILD = re.compile(r"\.stop\w*\.stopped$")
# Places of the abort machinery: the abort asked of a child, its answer, the cleanups.
ABORT_PLACE = re.compile(r"\.(abort|late_|cleanup)|abort_")


def quoted(text: str) -> str:
    """``text`` as a DOT string: quotes and backslashes escaped, line breaks as DOT's ``\\n``."""
    return '"' + text.replace("\\", "\\\\").replace('"', '\\"').replace("\n", "\\n") + '"'


def task_key(origin: object) -> str | None:
    """The task view's node for an element a task call made (``task:LINE:COL``), else None."""
    if origin is None or getattr(origin, "kind", "") != "task":
        return None
    return f"task:{origin.line}:{origin.col}"  # type: ignore[attr-defined]


def to_dot(net: Net, view: str = "full") -> str:
    """The Graphviz text of ``net`` in the ``full`` view or the ``tasks`` view."""
    if view not in ("full", "tasks"):
        raise ValueError("view is 'full' or 'tasks'")
    if view == "tasks":
        return _task_view(net)
    lines = _header(net)
    for p, place in enumerate(net.places):
        marked = net.initial.get(p, 0)
        label = place.name + (f"\n● ×{marked}" if marked > 1 else "\n●" if marked else "")
        extra = ', style=filled, fillcolor="#d7ecff"' if place.behaviours else ""
        lines.append(f"  p{p} [shape=circle, label={quoted(label)}, fontsize=9{extra}];")
    for t, tr in enumerate(net.transitions):
        lines.append(_transition_line(t, tr))
    edges = {(f"p{p}", f"t{t}", w) for t, tr in enumerate(net.transitions) for p, w in tr.inputs}
    edges |= {(f"t{t}", f"p{p}", w) for t, tr in enumerate(net.transitions)
              for p, w in tr.outputs}
    return "\n".join(lines + _edge_lines(edges) + ["}"]) + "\n"


def _header(net: Net) -> list[str]:
    return [f"digraph {quoted(net.name)} {{", "  rankdir=TB;", '  node [fontname="Helvetica"];',
            '  edge [arrowsize=0.6];']


def _transition_line(t: int, tr: Transition, label: str = "") -> str:
    details = [label or tr.label or tr.name]
    if tr.event:
        details.append(f"on {tr.event}")
    if tr.timer is not None:
        details.append(f"after {tr.timer}")
    details += [str(a) for a in tr.actions]
    return f"  t{t} [shape=box, height=0.2, fontsize=8, label={quoted(chr(10).join(details))}];"


def _edge_lines(edges: Iterable[tuple[str, str, int]]) -> list[str]:
    return [f"  {quoted(a)} -> {quoted(b)}" + (f" [label={w}]" if w > 1 else "") + ";"
            for a, b, w in sorted(set(edges)) if a != b]


def normal_flow(net: Net) -> tuple[set[int], set[int]]:
    """The places and transitions of the task view: what the normal flow reaches from the
    initial marking (a transition once every input outside the abort machinery is reached)."""
    def normal(tr: Transition) -> bool:
        return (task_key(tr.origin) is not None or not ABORT_MACHINERY.search(tr.name)
                or bool(STOPPED_CHILD.search(tr.name)))

    shown = {p for p, n in net.initial.items() if n > 0}
    fired: set[int] = set()
    candidates = [t for t, tr in enumerate(net.transitions) if normal(tr)]
    grew = True
    while grew:
        grew = False
        for t in candidates:
            tr = net.transitions[t]
            if t in fired or not all(p in shown for p, _ in tr.inputs
                                     if not ABORT_PLACE.search(net.places[p].name)):
                continue
            fired.add(t)
            grew = True
            shown |= {p for p, _ in tr.outputs if not ABORT_PLACE.search(net.places[p].name)}
    return shown, fired


def _task_view(net: Net) -> str:
    places, transitions = normal_flow(net)
    node: dict[tuple[str, int], str] = {}
    tasks: dict[str, str] = {}
    for kind, index, origin in ([("p", p, net.places[p].origin) for p in places]
                                + [("t", t, net.transitions[t].origin) for t in transitions]):
        key = task_key(origin)
        node[(kind, index)] = key or f"{kind}{index}"
        if key is not None and origin is not None:
            text = origin.text if len(origin.text) <= 32 else origin.text[:29] + "..."
            tasks.setdefault(key, f"{text}\nline {origin.line}")
    edges = {(node[("p", p)], node[("t", t)], w) for t in transitions
             for p, w in net.transitions[t].inputs if p in places}
    edges |= {(node[("t", t)], node[("p", p)], w) for t in transitions
              for p, w in net.transitions[t].outputs if p in places}
    edges = {e for e in edges if e[0] != e[1]}
    linked = {a for a, _, _ in edges} | {b for _, b, _ in edges}
    lines = _header(net)
    for key, label in sorted(tasks.items()):
        lines.append(f'  {quoted(key)} [shape=ellipse, style=filled, fillcolor="#bbbbbb", '
                     f"label={quoted(label)}, fontsize=10];")
    for p in sorted(places):
        if node[("p", p)] == f"p{p}" and f"p{p}" in linked:
            place = net.places[p]
            fill = ', style=filled, fillcolor="#d7ecff"' if place.behaviours else ""
            label = "●" if net.initial.get(p, 0) else ""
            lines.append(f"  p{p} [shape=circle, width=0.25, fixedsize=true, fontsize=9, "
                         f"label={quoted(label)}, tooltip={quoted(place.name)}{fill}];")
    for t in sorted(transitions):
        if node[("t", t)] == f"t{t}" and f"t{t}" in linked:
            tr = net.transitions[t]  # a child stopped on the normal path: not an abort
            lines.append(_transition_line(t, tr, "stopped" if STOPPED_CHILD.search(tr.name)
                                          else ""))
    return "\n".join(lines + _edge_lines(edges) + ["}"]) + "\n"
