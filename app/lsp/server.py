"""``mcl lsp``: the MCL language server, over standard input and output (pygls 2).

On every change the mission goes through the parser, its libraries and the checker at once
(app/lsp/document.py) and their errors are published; the proofs follow in a process of their
own once typing pauses (app/lsp/proofs.py), and their failures join the diagnostics. Hover,
definition, rename, completion, symbols, code actions, inlay hints and formatting (``mcl
fmt``'s layout) read the document as
the pipeline left it (the last version that parsed, for completion while a line is half
typed). Editors' setup: docs/EDITORS.md; exit statuses: docs/EXIT.md.
"""

from __future__ import annotations

import argparse
from typing import Any

from lsprotocol import types
from pygls import uris
from pygls.lsp.server import LanguageServer

from app import arguments
from app.lsp import diagnostics, hover, navigation, outline, proofs
from app.lsp.document import Document, analyse
from app.lsp.locate import Found, at
from app.version import version_text
from diagnostics import MclError
from mcl.analysis import duration
from mcl.formatter import format_source
from mcl.tasks_formatter import format_library_source
from mcl.quantities import seconds_text
from mission.exits import Exit

PROVED = "mcl/proved"  # sent after a proof's diagnostics: {uri, version, outcome}


class MclLanguageServer(LanguageServer):
    """The server and what it keeps per open document: the latest analysis, the latest
    that parsed, and the diagnostics of the latest proof of the current version."""

    def __init__(self, delay: float = proofs.PROOF_DELAY, vehicle: str | None = None) -> None:
        super().__init__("mcl-lsp", version_text("mcl lsp"))
        self.documents: dict[str, Document] = {}
        self.parsed: dict[str, Document] = {}
        self.proved: dict[str, list[types.Diagnostic]] = {}
        self.prover = proofs.Prover(self.proof_done, delay, vehicle=vehicle)

    def update(self, uri: str) -> None:
        """Analyse the document's current text, publish what the checker says, and ask for
        its proof."""
        text_document = self.workspace.get_text_document(uri)
        path = uris.to_fs_path(uri) or uri
        doc = analyse(path, text_document.source, text_document.version)
        self.documents[uri] = doc
        if doc.mission is not None:
            self.parsed[uri] = doc
        self.proved.pop(uri, None)
        self.publish(uri)
        if doc.ok:
            self.prover.request(uri, path, text_document.source, doc.version)
        else:
            self.prover.cancel(uri)

    def publish(self, uri: str) -> None:
        doc = self.documents[uri]
        found = [diagnostics.from_mcl(doc.source, d) for d in doc.diagnostics]
        self.text_document_publish_diagnostics(types.PublishDiagnosticsParams(
            uri, found + self.proved.get(uri, []), version=doc.version))

    def proof_done(self, uri: str, version: int | None, outcome: proofs.Outcome) -> None:
        doc = self.documents.get(uri)
        if doc is None or doc.version != version:
            return  # a proof of a text that is no longer there
        if outcome.kind == "verified" and outcome.verification is not None:
            self.proved[uri] = ([diagnostics.from_mcl(doc.source, d) for d in outcome.lacks]
                                + diagnostics.from_verification(doc.source,
                                                                outcome.verification))
        elif outcome.kind == "stopped":
            self.proved[uri] = [diagnostics.stopped(doc.source, outcome.why)]
        self.publish(uri)
        self.protocol.notify(PROVED, {"uri": uri, "version": version, "outcome": outcome.kind})

    def found(self, uri: str, position: types.Position) -> tuple[Document, Found] | None:
        """The document and what stands at an LSP position (0-based) of it."""
        doc = self.documents.get(uri)
        if doc is None or doc.mission is None:
            doc = self.parsed.get(uri)
        if doc is None or doc.mission is None:
            return None
        thing = at(doc.mission, position.line + 1, position.character + 1)
        return None if thing is None else (doc, thing)


def make_server(delay: float = proofs.PROOF_DELAY,
                vehicle: str | None = None) -> MclLanguageServer:
    """The server with every feature registered."""
    server = MclLanguageServer(delay, vehicle)

    @server.feature(types.TEXT_DOCUMENT_DID_OPEN)
    def did_open(ls: MclLanguageServer, params: types.DidOpenTextDocumentParams) -> None:
        ls.update(params.text_document.uri)

    @server.feature(types.TEXT_DOCUMENT_DID_CHANGE)
    def did_change(ls: MclLanguageServer, params: types.DidChangeTextDocumentParams) -> None:
        ls.update(params.text_document.uri)

    @server.feature(types.TEXT_DOCUMENT_DID_SAVE)
    def did_save(ls: MclLanguageServer, params: types.DidSaveTextDocumentParams) -> None:
        ls.update(params.text_document.uri)

    @server.feature(types.TEXT_DOCUMENT_DID_CLOSE)
    def did_close(ls: MclLanguageServer, params: types.DidCloseTextDocumentParams) -> None:
        uri = params.text_document.uri
        ls.prover.cancel(uri)
        for kept in (ls.documents, ls.parsed, ls.proved):
            kept.pop(uri, None)
        ls.text_document_publish_diagnostics(types.PublishDiagnosticsParams(uri, []))

    @server.feature(types.SHUTDOWN)
    def shutdown(ls: MclLanguageServer, params: Any) -> None:
        ls.prover.close()

    register_reading(server)
    return server


def register_reading(server: MclLanguageServer) -> None:
    """The features that read a document: hover, definition, rename, completion, symbols,
    code actions and inlay hints."""

    @server.feature(types.TEXT_DOCUMENT_HOVER)
    def on_hover(ls: MclLanguageServer, params: types.HoverParams) -> types.Hover | None:
        hit = ls.found(params.text_document.uri, params.position)
        text = hover.hover(*hit) if hit else None
        if hit is None or text is None:
            return None
        doc, found = hit
        s = found.span
        return types.Hover(types.MarkupContent(types.MarkupKind.Markdown, text),
                           diagnostics.word_range(doc.source, s.line, s.col, s.end_line,
                                                  s.end_col))

    @server.feature(types.TEXT_DOCUMENT_DEFINITION)
    def on_definition(ls: MclLanguageServer,
                      params: types.DefinitionParams) -> types.Location | None:
        hit = ls.found(params.text_document.uri, params.position)
        return navigation.definition(*hit) if hit else None

    @server.feature(types.TEXT_DOCUMENT_RENAME)
    def on_rename(ls: MclLanguageServer, params: types.RenameParams) -> types.WorkspaceEdit | None:
        hit = ls.found(params.text_document.uri, params.position)
        if hit is None:
            return None
        return navigation.rename(*hit, params.new_name, params.text_document.uri)

    @server.feature(types.TEXT_DOCUMENT_COMPLETION,
                    types.CompletionOptions(trigger_characters=["(", ","]))
    def on_completion(ls: MclLanguageServer,
                      params: types.CompletionParams) -> types.CompletionList:
        doc = ls.parsed.get(params.text_document.uri) or ls.documents.get(
            params.text_document.uri)
        items = outline.completion(doc) if doc is not None else []
        return types.CompletionList(is_incomplete=False, items=items)

    @server.feature(types.TEXT_DOCUMENT_DOCUMENT_SYMBOL)
    def on_symbols(ls: MclLanguageServer,
                   params: types.DocumentSymbolParams) -> list[types.DocumentSymbol]:
        doc = ls.documents.get(params.text_document.uri)
        if doc is None or doc.mission is None:
            doc = ls.parsed.get(params.text_document.uri)
        return outline.symbols(doc) if doc is not None else []

    @server.feature(types.TEXT_DOCUMENT_CODE_ACTION)
    def on_code_action(ls: MclLanguageServer,
                       params: types.CodeActionParams) -> list[types.CodeAction]:
        doc = ls.documents.get(params.text_document.uri)
        return code_actions(doc, params.text_document.uri) if doc is not None else []

    @server.feature(types.TEXT_DOCUMENT_INLAY_HINT)
    def on_inlay_hint(ls: MclLanguageServer,
                      params: types.InlayHintParams) -> list[types.InlayHint]:
        doc = ls.documents.get(params.text_document.uri)
        return inlay_hints(doc) if doc is not None else []

    @server.feature(types.TEXT_DOCUMENT_FORMATTING)
    def on_formatting(ls: MclLanguageServer,
                      params: types.DocumentFormattingParams) -> list[types.TextEdit]:
        doc = ls.documents.get(params.text_document.uri)
        return formatting(doc) if doc is not None else []


def formatting(doc: Document) -> list[types.TextEdit]:
    """``mcl fmt``'s layout (mcl/formatter.py, mcl/tasks_formatter.py for a ``.tasks`` file)
    as one edit of the whole document; none for a text that does not parse (its errors are
    the diagnostics)."""
    library = doc.path.endswith(".tasks")
    if doc.mission is None and doc.fleet is None and not library:
        return []
    try:
        text = format_library_source(doc.source) if library else format_source(doc.source)
    except MclError:
        return []
    if text == doc.source.text:
        return []
    lines = doc.source.text.split("\n")
    end = types.Position(len(lines) - 1, len(lines[-1]))
    return [types.TextEdit(types.Range(types.Position(0, 0), end), text)]


def code_actions(doc: Document, uri: str) -> list[types.CodeAction]:
    """Quick fixes from the hints the parser and checker give: "delete this ';'" and
    "did you mean GoTo?"."""
    out = []
    for d in doc.diagnostics:
        if d.span is None or d.span.line <= 0 or d.span.file != doc.source.name:
            continue
        found = diagnostics.from_mcl(doc.source, d)
        if d.code == "trailing-semicolon":
            title, new = "delete this ';'", ""
            start = found.range.start
            line = doc.source.line(start.line + 1)
            semicolon = line.find(";", start.character)
            if semicolon < 0:
                continue
            rng = types.Range(types.Position(start.line, semicolon),
                              types.Position(start.line, semicolon + 1))
        elif "did you mean " in d.hint:
            new = d.hint.split("did you mean ", 1)[1].split("?", 1)[0]
            title, rng = f"replace with {new}", found.range
        else:
            continue
        out.append(types.CodeAction(
            title, kind=types.CodeActionKind.QuickFix, diagnostics=[found], is_preferred=True,
            edit=types.WorkspaceEdit(changes={uri: [types.TextEdit(rng, new)]})))
    return out


def inlay_hints(doc: Document) -> list[types.InlayHint]:
    """Each construct's proved [best, worst] duration at the end of its first line."""
    if doc.checked is None:
        return []
    found = [duration.analyse(doc.checked)]
    stop = duration.stop_handler(doc.checked)
    if stop is not None:
        found.append(stop)
    out = []
    for bounds in found:
        for b in bounds.blocks:
            if b.construct in ("Call", "Sequence"):
                continue
            end = len(doc.source.line(b.line))
            out.append(types.InlayHint(
                types.Position(b.line - 1, end),
                f"  [{seconds_text(b.best)}, {seconds_text(b.worst)}]",
                tooltip=f"{b.text}: proved duration (mcl/analysis/duration.py)",
                padding_left=True))
    return out


def seconds(text: str) -> float:
    """A number of seconds, 0 or more (argparse turns the error into one line, exit 2)."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not a number of seconds: {text!r}") from None
    if not 0 <= value <= 3600:
        raise argparse.ArgumentTypeError(f"must lie between 0 and 3600 s, got {text}")
    return value


def main(argv: list[str] | None = None) -> int:
    """``mcl lsp``: serve one editor over standard input and output until it exits."""
    p = arguments.Parser(prog="mcl lsp", description="The MCL language server, over "
                                "standard input and output (docs/EDITORS.md).")
    p.add_argument("--stdio", action="store_true", help="accepted for editors that pass it "
                   "(standard input and output are the only transport)")
    p.add_argument("--proof-delay", type=seconds, default=proofs.PROOF_DELAY, metavar="SECONDS",
                   help="quiet after a change before its proof starts (default "
                   f"{proofs.PROOF_DELAY:g} s)")
    p.add_argument("--vehicle", choices=sorted(proofs.VEHICLES), help="also check each "
                   "mission against what this vehicle declares, as mcl run does before the "
                   "first action (sim: every registered behaviour; ictineu: the paper's stack)")
    args = p.parse_args(argv)
    make_server(args.proof_delay, args.vehicle).start_io()
    return Exit.OK
