"""What the language server knows of one open mission: its text run through the one pipeline
(mcl/parser.py, the task libraries, mcl/checker.py) as far as it goes. The compiler and the
verifier run later, apart (app/lsp/proofs.py): on a 1,000-task mission the compiler alone
would double the time a keystroke waits for its diagnostics.

Each stage keeps what it made, so that hover, definition and completion still work on a
mission the checker rejects (its syntax tree and libraries are there), and the errors that
stopped it are the document's diagnostics.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from importlib import resources

from diagnostics import Diagnostic, MclError, Source, Span
from mcl import ast, checker, parser, tasklib
from mcl.api import library_of
from mcl.fleet import check_fleet, is_fleet


@dataclass
class Document:
    """One version of a mission's text and what the pipeline made of it."""

    path: str
    version: int | None
    source: Source
    mission: ast.Mission | None = None
    library: tasklib.Library | None = None
    checked: checker.Checked | None = None
    diagnostics: list[Diagnostic] = field(default_factory=list)
    fleet: ast.Fleet | None = None  # a fleet file (FLEET ...): checked, never proved here

    @property
    def ok(self) -> bool:
        """Checked without an error: the proofs may run."""
        return self.checked is not None


def analyse(path: str, text: str, version: int | None = None) -> Document:
    """Parse, load the libraries and check ``text`` (the mission at ``path``, whose
    folder its ``USES`` are relative to), stopping at the first stage that fails; a task
    library (``.tasks``) is loaded as :func:`analyse_library` says."""
    doc = Document(path, version, Source(path, text))
    if path.endswith(".tasks"):
        return analyse_library(doc)
    try:
        if is_fleet(doc.source):  # a fleet: every vehicle checked, no proofs here
            return analyse_fleet(doc)
        doc.mission = parser.parse(doc.source)
        doc.library = library_of(doc.mission, doc.source)
        doc.checked = checker.check_mission(doc.mission, doc.library, doc.source)
        doc.diagnostics = list(doc.checked.diagnostics)
    except MclError as exc:
        doc.diagnostics = list(exc.diagnostics)
    except RecursionError:  # a pathological text: say so at the top, never crash the server
        doc.diagnostics = [Diagnostic("error", "too deeply nested to analyse",
                                      Span(path, 1, 1), code="too-deep")]
    except Exception as exc:  # a bug of ours: said plainly in the editor, the server lives on
        doc.diagnostics = [Diagnostic(
            "error", f"internal error: {type(exc).__name__}: {exc}", Span(path, 1, 1),
            hint="this is a bug in mcl; mclc --debug on the file shows where",
            code="internal-error")]
    return doc


def analyse_fleet(doc: Document) -> Document:
    """A fleet file: parsed, then every vehicle checked (mcl/fleet.py); its errors, or every
    vehicle's warnings, are the document's diagnostics (the caller catches the errors)."""
    unit = parser.parse_unit(doc.source)
    assert isinstance(unit, ast.Fleet)
    doc.fleet = unit
    checked = check_fleet(unit, doc.source)
    doc.diagnostics = [d for c in checked.values() for d in c.diagnostics]
    return doc


def analyse_library(doc: Document) -> Document:
    """A task library: loaded after the core library, as every mission loads it; if that
    fails, after the Ictineu library too (a library may use the behaviours of another that
    missions load beside it), and its errors are those of the first try when both fail."""
    core = tasklib.shipped_source("core.tasks")
    tries = [[core, doc.source], [core, tasklib.shipped_source("ictineu.tasks"), doc.source]]
    first: list[Diagnostic] = []
    for sources in tries:
        try:
            doc.library = tasklib.load_sources(sources)
            return doc
        except MclError as exc:
            first = first or list(exc.diagnostics)
        except RecursionError:
            break
    doc.diagnostics = first or [Diagnostic("error", "too deeply nested to analyse",
                                           Span(doc.path, 1, 1), code="too-deep")]
    return doc


def shipped_path(file: str) -> str | None:
    """The file on disk of a span's file: a shipped library's ``<mcl>/tasks/NAME`` is the
    package's own copy (None if the package is not on disk, e.g. in a zip)."""
    prefix = "<mcl>/tasks/"
    if not file.startswith(prefix):
        return file
    target = resources.files("mcl").joinpath("tasks", file.removeprefix(prefix))
    return str(target) if hasattr(target, "is_file") and target.is_file() else None
