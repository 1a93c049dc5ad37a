"""Graphviz views of a net.

``full``: every place (circle, a dot when marked) and transition (box, with its event, timer
and actions). ``tasks``: like the paper's Figure 5, each task collapsed into one grey node and
only the normal flow of the control structures kept (the abort machinery — stopping children,
absorbing late aborts, switching latches off — is left out), so the mission's shape shows at a
glance.
"""

from __future__ import annotations

import re

from petri.net import Net

# Transitions that belong to the abort machinery, left out of the task view.
_ABORT = re.compile(r"\.(abort|stop|late_|stopped|cleanup|off\.|keep\.)|abort_|\.from\.")


def _q(text: str) -> str:
    return '"' + text.replace("\\", "\\\\").replace('"', '\\"').replace("\n", "\\n") + '"'


def _task_key(net: Net, origin: object) -> str | None:
    o = origin
    if o is None or getattr(o, "kind", "") != "task":
        return None
    return f"task:{o.line}:{o.col}"  # type: ignore[attr-defined]


def to_dot(net: Net, view: str = "full") -> str:
    if view not in ("full", "tasks"):
        raise ValueError("view is 'full' or 'tasks'")
    collapse = view == "tasks"
    lines = [f"digraph {_q(net.name)} {{", "  rankdir=TB;", '  node [fontname="Helvetica"];',
             '  edge [arrowsize=0.6];']
    node_of_place: dict[int, str] = {}
    node_of_transition: dict[int, str] = {}
    tasks: dict[str, str] = {}
    for p, place in enumerate(net.places):
        key = _task_key(net, place.origin) if collapse else None
        if key is not None:
            node_of_place[p] = key
            assert place.origin is not None
            text = place.origin.text if len(place.origin.text) <= 32 else \
                place.origin.text[:29] + "..."
            tasks.setdefault(key, f"{text}\\nline {place.origin.line}")
            continue
        node_of_place[p] = f"p{p}"
        marked = net.initial.get(p, 0)
        label = place.name + (f"\\n● ×{marked}" if marked > 1 else "\\n●" if marked else "")
        extra = ', style=filled, fillcolor="#d7ecff"' if place.behaviours else ""
        lines.append(f"  p{p} [shape=circle, label={_q(label)}, fontsize=9{extra}];")
    for key, label in tasks.items():
        lines.append(f'  {_q(key)} [shape=circle, style=filled, fillcolor="#bbbbbb", '
                     f"label={_q(label)}, fontsize=10];")
    shown = [not (collapse and _ABORT.search(tr.name) and _task_key(net, tr.origin) is None)
             for tr in net.transitions]
    used = {p for t, tr in enumerate(net.transitions) if shown[t]
            for p, _ in tr.inputs + tr.outputs}
    if collapse:  # drop the places only the abort machinery touches
        keep = [f"  {n} " for p, n in node_of_place.items() if p in used]
        lines = [ln for ln in lines if not ln.startswith("  p") or any(
            ln.startswith(k) for k in keep)]
    for t, tr in enumerate(net.transitions):
        if not shown[t]:
            continue
        key = _task_key(net, tr.origin) if collapse else None
        if key is not None:
            node_of_transition[t] = key
            continue
        node_of_transition[t] = f"t{t}"
        details = [tr.label or tr.name]
        if tr.event:
            details.append(f"on {tr.event}")
        if tr.timer is not None:
            details.append(f"after {tr.timer}")
        details += [str(a) for a in tr.actions]
        lines.append(f"  t{t} [shape=box, height=0.2, fontsize=8, label={_q(chr(10).join(details))}];")
    edges: set[tuple[str, str, int]] = set()
    for t, tr in enumerate(net.transitions):
        if not shown[t]:
            continue
        tn = node_of_transition[t]
        for p, w in tr.inputs:
            if not (collapse and _ABORT.search(net.places[p].name)):
                edges.add((node_of_place[p], tn, w))
        for p, w in tr.outputs:
            if not (collapse and _ABORT.search(net.places[p].name)):
                edges.add((tn, node_of_place[p], w))
    for a, b, w in sorted(edges):
        if a == b:
            continue
        label = f" [label={w}]" if w > 1 else ""
        lines.append(f"  {_q(a)} -> {_q(b)}{label};")
    lines.append("}")
    return "\n".join(lines) + "\n"
