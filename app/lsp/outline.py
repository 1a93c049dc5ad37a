"""Completion (tasks of the libraries in use with their parameters, parameters, keywords,
units) and document symbols (the construct tree)."""

from __future__ import annotations

from lsprotocol import types

from diagnostics import Span
from mcl import ast, printer
from mcl.parser import FLEET_KEYWORDS, KEYWORDS
from mcl.values import UNITS, to_text

from app.lsp.document import Document

KIND = types.SymbolKind
FLEET_TASKS = (("Send", "Send(CHANNEL, MESSAGE): put a message on a channel from this vehicle"),
               ("Receive", "Receive(CHANNEL, MESSAGE[, timeout = DURATION]): wait for it"))
CONSTRUCTS = {  # the construct tree's nodes: (name shown, symbol kind)
    ast.TryCatchDo: ("TRY … CATCH … DO", KIND.Namespace),
    ast.ParallelAnd: ("PARALLEL … AND", KIND.Struct),
    ast.ParallelOr: ("PARALLEL … OR", KIND.Struct),
    ast.IfThenElse: ("IF … THEN … ELSE", KIND.Namespace),
    ast.WhileDo: ("WHILE … DO", KIND.Enum),
}


def completion(doc: Document) -> list[types.CompletionItem]:
    """Everything that may be written at a place of a mission: each call form of each task
    of the libraries in use (with its formals), each parameter, each keyword and unit."""
    items: list[types.CompletionItem] = []
    if doc.library is not None:
        for name, forms in sorted(doc.library.tasks.items()):
            for form in forms:
                items.append(types.CompletionItem(
                    name, kind=types.CompletionItemKind.Function, detail=form.signature,
                    documentation=f"declared at {form.span}",
                    label_details=types.CompletionItemLabelDetails(
                        detail="(" + ", ".join(f.text for f in form.formals) + ")")))
    if doc.mission is not None:
        for p in doc.mission.params:
            items.append(types.CompletionItem(
                p.name, kind=types.CompletionItemKind.Variable,
                detail=f"PARAM {p.name} = {to_text(p.value)}" if p.value is not None
                else f"PARAM {p.name}"))
    if doc.fleet is not None:
        items += fleet_completion(doc.fleet)
    items += [types.CompletionItem(k, kind=types.CompletionItemKind.Keyword) for k in KEYWORDS]
    items += [types.CompletionItem(u, kind=types.CompletionItemKind.Unit, detail=what)
              for u, (what, _) in UNITS.items()]
    return items


def fleet_completion(fleet: ast.Fleet) -> list[types.CompletionItem]:
    """In a fleet: its words, Send and Receive, its channels and their messages."""
    items = [types.CompletionItem(k, kind=types.CompletionItemKind.Keyword)
             for k in FLEET_KEYWORDS]
    items += [types.CompletionItem(name, kind=types.CompletionItemKind.Function,
                                   detail=detail) for name, detail in FLEET_TASKS]
    for c in fleet.channels:
        items.append(types.CompletionItem(
            c.name.name, kind=types.CompletionItemKind.Interface,
            detail=f"CHANNEL {c.name.name} FROM {c.sender.name} TO "
                   f"{', '.join(r.name for r in c.receivers)}"))
        items += [types.CompletionItem(m.name, kind=types.CompletionItemKind.EnumMember,
                                       detail=f"a message of {c.name.name}")
                  for m in c.messages]
    return items


def symbols(doc: Document) -> list[types.DocumentSymbol]:
    """The mission's outline: its ``USES``, its ``PARAM``s, and ``MISSION`` (and ``ON STOP``)
    with their constructs and task calls (sequences are not nodes of their own); a fleet's:
    ``FLEET`` with its channels and each vehicle's outline."""
    if doc.fleet is not None:
        return [fleet_symbol(doc.fleet)]
    m = doc.mission
    if m is None:
        return []
    return mission_symbols(m)


def fleet_symbol(fleet: ast.Fleet) -> types.DocumentSymbol:
    """``FLEET name``: its channels, then its vehicles, each with its mission's outline."""
    kids = [symbol(f"CHANNEL {c.name.name}", KIND.Interface, c.span,
                   f"{c.sender.name} → {', '.join(r.name for r in c.receivers)}: "
                   f"{', '.join(m.name for m in c.messages)}") for c in fleet.channels]
    kids += [symbol(f"VEHICLE {v.name.name}", KIND.Class, v.span,
                    children=mission_symbols(v.mission)) for v in fleet.vehicles]
    return symbol(f"FLEET {fleet.name}", KIND.Module, fleet.span, children=kids)


def mission_symbols(m: ast.Mission) -> list[types.DocumentSymbol]:
    """A mission's USES, PARAMs, MISSION and ON STOP."""
    out = [symbol(f"USES {u.library}", KIND.Module, u.span) for u in m.uses]
    out += [symbol(p.name, KIND.Variable, p.span,
                   to_text(p.value) if p.value is not None else None) for p in m.params]
    out.append(symbol(f"MISSION {m.name or ''}".strip(), KIND.Module,
                      through(m.span, m.body.span), children=tree(m.body)))
    if m.on_stop is not None:
        out.append(symbol("ON STOP", KIND.Event, through(m.stop_span, m.on_stop.span),
                          children=tree(m.on_stop)))
    return out


def tree(block: ast.Block) -> list[types.DocumentSymbol]:
    """The symbols of a block: a call, a construct with its children, or a sequence's
    items."""
    if isinstance(block, ast.Sequence):
        return [s for item in block.items for s in tree(item)]
    if isinstance(block, ast.Call):
        return [symbol(printer.call(block), KIND.Function, block.span)]
    name, kind = CONSTRUCTS[type(block)]
    kids = [s for child in ast.children(block) for s in tree(child)]
    return [symbol(name, kind, block.span, children=kids)]


def through(head: Span, body: Span) -> Span:
    """From a keyword to the end of the block it opens."""
    return Span(head.file, head.line, head.col, body.end_line, body.end_col)


def symbol(name: str, kind: types.SymbolKind, span: Span, detail: str | None = None,
           children: list[types.DocumentSymbol] | None = None) -> types.DocumentSymbol:
    start = types.Position(max(span.line - 1, 0), max(span.col - 1, 0))
    end = (types.Position(span.end_line - 1, max(span.end_col - 1, 0))
           if span.end_line >= span.line > 0 else start)
    rng = types.Range(start, end)
    return types.DocumentSymbol(name, kind, rng, types.Range(start, start), detail=detail,
                                children=children or None)
