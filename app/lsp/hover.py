"""Hover: a task's declaration at its call, a parameter's value with its unit, a block's
proved [best, worst] duration (mcl/analysis/duration.py), as Markdown."""

from __future__ import annotations

from mcl import ast
from mcl.analysis import duration
from mcl.declarations import Expr, Field, Library, TaskForm
from mcl.fleet_tasks import FLEET_TASKS, SHAPES
from mcl.quantities import seconds_text
from mcl.values import to_text

from app.lsp.document import Document
from app.lsp.locate import Found, declaration


def expr_text(e: Expr) -> str:
    """A library expression as written: a value, or a point's field (``target.x``)."""
    return f"{e.formal}.{e.field}" if isinstance(e, Field) else to_text(e)


def form_text(form: TaskForm, library: Library) -> list[str]:
    """A task's call form: its signature, the behaviours it drives (their degrees of freedom,
    events and power), how it ends, its timeout, latch and where it is declared."""
    lines = [f"```mcl\n{form.signature}\n```"]
    for b in dict.fromkeys(a.behaviour for a in form.start + form.stop):
        kinds = ", ".join(a.kind for a in form.start + form.stop if a.behaviour == b)
        decl = library.behaviours.get(b)
        facts = [kinds]
        if decl is not None:
            facts.append("drives " + (", ".join(decl.dofs) or "no degree of freedom"))
            if decl.events:
                facts.append("events " + ", ".join(decl.events))
            if decl.power is not None:
                facts.append(f"{decl.power:g} W")
        lines.append(f"- behaviour **{b}**: {'; '.join(facts)}")
    if form.ok:
        lines.append(f"- ok on {', '.join(form.ok)}")
    if form.fail:
        lines.append(f"- fail on {', '.join(form.fail)}")
    if form.timeout is not None:
        lines.append(f"- timeout {expr_text(form.timeout[0])} → {form.timeout[1]}")
    if form.latch:
        lines.append(f"- latches {form.latch} on")
    if form.unlatch:
        lines.append(f"- unlatches {form.unlatch}")
    if form.immediate:
        lines.append("- ends at once (ok) once its actions are sent")
    lines.append(f"- declared at {form.span}")
    return lines


def fleet_text(form: TaskForm) -> list[str]:
    """Send or Receive in a fleet's vehicle (mcl/fleet_tasks.py): what it does."""
    if form.name == "Send":
        action = form.start[0]
        message = next((v for k, v in action.bindings if k == "message"), None)
        what = to_text(message) if isinstance(message, ast.Ref) else "?"
        return [f"```mcl\n{SHAPES['Send']}\n```",
                f"- puts **{what}** on channel **{action.behaviour}** and ends at once (ok)",
                "- the player gives it to the fleet's channel, never to the vehicle"]
    return [f"```mcl\n{SHAPES['Receive']}\n```",
            f"- ok when **{form.ok[0]}** comes; fail on its timeout",
            "- a message that comes while nothing waits for it is ignored"]


def bound_text(doc: Document, block: ast.Block) -> str | None:
    """The proved [best, worst] duration of a block of the checked mission."""
    if doc.checked is None:
        return None
    found = [duration.analyse(doc.checked)]
    stop = duration.stop_handler(doc.checked)
    if stop is not None:
        found.append(stop)
    for bounds in found:
        for b in bounds.blocks:
            if (b.construct, b.line, b.col) == (type(block).__name__, block.span.line,
                                                 block.span.col):
                return (f"proved duration: [{seconds_text(b.best)}, {seconds_text(b.worst)}]"
                        + "".join(f"; ends {k} in [{seconds_text(lo)}, {seconds_text(hi)}]"
                                  for k, (lo, hi) in b.ends.items()))
    return None


def hover(doc: Document, found: Found) -> str | None:
    """The Markdown shown for what stands under the pointer."""
    if found.kind == "call" and doc.library is not None:
        assert isinstance(found.node, ast.Call)
        forms = doc.library.tasks.get(found.name, [])
        if doc.checked is not None and id(found.node) in doc.checked.calls:
            forms = [doc.checked.resolved(found.node).form]
        lines = [line for form in forms for line in (
            fleet_text(form) if doc.checked is not None and doc.checked.fleet is not None
            and form.name in FLEET_TASKS else form_text(form, doc.library))]
        bound = bound_text(doc, found.node)
        return "\n".join(lines + ([f"\n{bound}"] if bound else [])) or None
    if found.kind == "param" and doc.mission is not None:
        return param_text(doc, found.name)
    if found.kind == "block":
        assert isinstance(found.node, (ast.TryCatchDo, ast.ParallelAnd, ast.ParallelOr,
                                       ast.IfThenElse, ast.WhileDo))
        return bound_text(doc, found.node)
    if found.kind == "uses":
        return f"task library `{found.name}`"
    return None


def param_text(doc: Document, name: str) -> str | None:
    """A parameter: its value (with its unit) and the kind of value its uses need."""
    assert doc.mission is not None
    decl = declaration(doc.mission, name)
    value = doc.checked.params.get(name) if doc.checked is not None else None
    if value is None and decl is not None:
        value = decl.value
    if decl is None and value is None:
        return None
    kind = doc.checked.param_kinds.get(name) if doc.checked is not None else None
    text = to_text(value) if value is not None else "no value: give one with --param"
    return (f"```mcl\nPARAM {name} = {text}\n```"
            + (f"\n{kind}" if kind else ""))
