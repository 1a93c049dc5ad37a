"""Go to definition (a task call to its ``.tasks`` line, a parameter to its ``PARAM``, a
``USES`` to its file) and rename of a parameter (its ``PARAM`` and every use)."""

from __future__ import annotations

import os

from lsprotocol import types
from pygls import uris

from diagnostics import Span
from mcl import ast, tasklib

from app.lsp.document import Document, shipped_path
from app.lsp.locate import Found, declaration, param_uses


def location(span: Span) -> types.Location | None:
    """A span as an LSP location (a shipped library's line in the package's own file)."""
    path = shipped_path(span.file)
    if path is None:
        return None
    line = max(span.line - 1, 0)
    start = types.Position(line, max(span.col - 1, 0))
    end = (types.Position(span.end_line - 1, max(span.end_col - 1, 0))
           if span.end_line >= span.line > 0 else start)
    return types.Location(uris.from_fs_path(os.path.abspath(path)) or path,
                          types.Range(start, end))


def definition(doc: Document, found: Found) -> types.Location | None:
    """Where what stands under the cursor is declared."""
    if found.kind == "call" and doc.library is not None:
        assert isinstance(found.node, ast.Call)
        forms = doc.library.tasks.get(found.name, [])
        if doc.checked is not None and id(found.node) in doc.checked.calls:
            forms = [doc.checked.resolved(found.node).form]
        return location(forms[0].span) if forms else None
    if found.kind == "param" and doc.mission is not None:
        decl = declaration(doc.mission, found.name)
        return location(decl.span) if decl is not None else None
    if found.kind == "uses":
        if tasklib.is_shipped(found.name):
            path = f"<mcl>/tasks/{found.name}.tasks"
        else:
            path = os.path.join(os.path.dirname(doc.path), found.name)
        return location(Span(path, 1, 1))
    return None


def rename(doc: Document, found: Found, new_name: str, uri: str) -> types.WorkspaceEdit | None:
    """Rename a parameter: its ``PARAM`` and every use (None: not a declared parameter)."""
    if found.kind != "param" or doc.mission is None:
        return None
    decl = declaration(doc.mission, found.name)
    if decl is None:
        return None
    if not new_name.isidentifier() or new_name.upper() in ("MISSION", "PARAM", "USES"):
        raise ValueError(f"not a parameter name: {new_name!r}")
    spans = [decl.span] + [r.span for r in param_uses(doc.mission) if r.name == found.name]
    edits = []
    for s in spans:
        start = types.Position(s.line - 1, s.col - 1)
        end = types.Position(s.line - 1, s.col - 1 + len(found.name))
        edits.append(types.TextEdit(types.Range(start, end), new_name))
    return types.WorkspaceEdit(changes={uri: edits})
