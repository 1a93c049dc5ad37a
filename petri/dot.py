"""Graphviz views of a net.

``full``: every place (circle, a dot when marked) and transition (box, with its event, timer
and actions). ``tasks``: like the paper's Figure 5, each task collapsed into one grey node,
the control structures' places and transitions kept, so the mission's shape shows at a glance.
"""

from __future__ import annotations

from .net import Net


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
            tasks.setdefault(key, f"{place.origin.text}\\nline {place.origin.line}")
            continue
        node_of_place[p] = f"p{p}"
        marked = net.initial.get(p, 0)
        label = place.name + (f"\\n● ×{marked}" if marked > 1 else "\\n●" if marked else "")
        extra = ', style=filled, fillcolor="#d7ecff"' if place.behaviours else ""
        lines.append(f"  p{p} [shape=circle, label={_q(label)}, fontsize=9{extra}];")
    for key, label in tasks.items():
        lines.append(f'  {_q(key)} [shape=circle, style=filled, fillcolor="#bbbbbb", '
                     f"label={_q(label)}, fontsize=10];")
    for t, tr in enumerate(net.transitions):
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
        tn = node_of_transition[t]
        for p, w in tr.inputs:
            edges.add((node_of_place[p], tn, w))
        for p, w in tr.outputs:
            edges.add((tn, node_of_place[p], w))
    for a, b, w in sorted(edges):
        if a == b:
            continue
        label = f" [label={w}]" if w > 1 else ""
        lines.append(f"  {_q(a)} -> {_q(b)}{label};")
    lines.append("}")
    return "\n".join(lines) + "\n"
