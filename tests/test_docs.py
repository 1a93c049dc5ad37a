"""The documents the code cites exist, and the documents' own references hold (issue 20).

Four checks over the repository, each reporting every offence as ``file:line: what``:

1. *Citations of a document.* A citation of a document in code, grammar, task library, TOML or
   Markdown (``docs/SEMANTICS.md``, ``AAL.md``, ``MCL.md §5``) names a file of ``docs/``. Outside
   ``docs/`` a design document (SEMANTICS, AAL, MCL, DESIGN, ARCHITECTURE) is cited by its path
   from the root (``docs/SEMANTICS.md``): a bare ``SEMANTICS.md`` in a module's docstring does
   not say where to look. A section cited
   (``docs/SEMANTICS.md §3``) is a numbered heading of that document (``## 3. ...``).
2. *Paths.* Every path of the tree that ``docs/*.md`` and ``README.md`` mention
   (``petri/execution/player.py``, ``mcl/analysis/``) exists. A path a worked example tells the
   reader to create is named in the info string of its code block (```` ```python
   behaviours/depth.py ````) and may be mentioned in that document.
3. *Links.* Every Markdown link in ``docs/`` and ``README.md`` to a file of the repository
   resolves, and an anchor (``LANGUAGE.md#what-mclc-proves``) names a heading of the file it
   points to (GitHub's rule for heading anchors).
4. *Module names.* A module named without its folder in the prose of those documents
   (``stack.py``, ``mavlink_guided.py``) is the name of some module of the tree.

The scanners are plain functions over text, tested on their own below so that each check can be
seen to fail.
"""

from __future__ import annotations

import os
import re
from collections.abc import Iterator
from pathlib import Path

import pytest

from tests.support import REPO
from tests.test_layers import LAYERS

DOCS = REPO / "docs"
SCANNED = (".py", ".md", ".lark", ".tasks", ".toml")  # .toml: pyproject.toml's comments
SKIPPED_DIRS = {"out", "build", "dist", "node_modules", "__pycache__"}
# The design documents the code cites by name (the others are cited as docs/NAME.md already).
DESIGN_NAMES = ("SEMANTICS", "AAL", "MCL", "DESIGN", "ARCHITECTURE")
# The top folders whose paths docs mention; a path must end in a file suffix, or in "/".
TOP = ("app", "mission", "mcl", "mosaic", "vehicle_adapters", "vehicle", "petri", "behaviours",
       "aal", "diagnostics", "tests", "bench", "missions", "examples", "docs")
FILE_SUFFIXES = (".py", ".md", ".lark", ".tasks", ".mcl", ".toml", ".json", ".jsonl", ".pnml",
                 ".png", ".svg", ".csv", ".txt", ".yml", ".yaml", ".cfg", ".sh", ".tgz")

# docs/NAME.md, or a bare NAME.md (not part of a longer path), with an optional "§N[.M]"
CITATION = re.compile(r"(?<![\w/.-])(?P<path>(?:docs/)?(?P<name>[A-Z][A-Z0-9_]*)\.md)"
                      r"(?:'s)?(?:\s+§\s?(?P<section>\d+(?:\.\d+)*))?")
# a path built in code: REPO / "docs" / "EXTENDING.md"
DOCS_FOLDER = re.compile(r"[\"']docs[\"']\s*/\s*[\"']$")
# a design document cited without its file name: "SEMANTICS §5"
BARE_SECTION = re.compile(r"\b(?P<name>%s)\s+§\s?\d" % "|".join(DESIGN_NAMES))
MODULE = re.compile(r"(?<![\w/.-])(?P<name>[A-Za-z_]\w*\.py)\b")
PATH = re.compile(r"(?<![\w/.<>~-])(?P<path>(?:%s)/[^\s`'\")\]|,;:!?]*)" % "|".join(TOP))
LINK = re.compile(r"!?\[(?:[^\]\[]|\[[^\]]*\])*\]\((?P<target><[^>]*>|[^)\s]+)(?:\s+\"[^\"]*\")?\)")
FENCE = re.compile(r"^\s*(```|~~~)(?P<info>.*)$")
HEADING = re.compile(r"^(?P<hashes>#{1,6})\s+(?P<text>.+?)\s*#*\s*$")


# -- the files -------------------------------------------------------------------------------------

def repository_files(root: Path = REPO, suffixes: tuple[str, ...] = SCANNED) -> list[Path]:
    """The repository's own files with these suffixes (no virtual environment, no caches, no
    generated output, not this test: it spells the patterns it looks for)."""
    found: list[Path] = []
    for folder, dirs, files in os.walk(root):
        dirs[:] = sorted(d for d in dirs if not (d.startswith(".") or d in SKIPPED_DIRS
                                                 or d.endswith(".egg-info")))
        for name in sorted(files):
            path = Path(folder) / name
            if path.suffix in suffixes and path != Path(__file__).resolve():
                found.append(path)
    return found


def documents(root: Path = REPO) -> list[Path]:
    """docs/*.md and README.md."""
    return sorted((root / "docs").glob("*.md")) + [root / "README.md"]


def where(path: Path, line: int, root: Path = REPO) -> str:
    return f"{path.relative_to(root)}:{line}"


# -- Markdown structure ----------------------------------------------------------------------------

def prose_lines(text: str) -> Iterator[tuple[int, str]]:
    """The lines of a Markdown text outside fenced code blocks, numbered from 1."""
    fenced: str | None = None
    for number, line in enumerate(text.splitlines(), start=1):
        m = FENCE.match(line)
        if m:
            if fenced is None:
                fenced = m.group(1)
            elif m.group(1) == fenced:
                fenced = None
            continue
        if fenced is None:
            yield number, line


def made_by_examples(text: str) -> set[str]:
    """The files a document's worked examples make: the path in a code block's info string
    (```` ```python behaviours/depth.py ````)."""
    made: set[str] = set()
    fenced: str | None = None
    for line in text.splitlines():
        m = FENCE.match(line)
        if not m:
            continue
        if fenced is None:
            fenced = m.group(1)
            words = m.group("info").split()
            made.update(w for w in words[1:] if "/" in w or "." in w)
        elif m.group(1) == fenced:
            fenced = None
    return made


def anchor(heading: str) -> str:
    """GitHub's anchor of a heading: the text without Markdown, lower case, punctuation
    dropped, each space a hyphen."""
    text = re.sub(r"\[([^\]]*)\]\([^)]*\)", r"\1", heading)  # a link: its text
    text = re.sub(r"[^\w\- ]", "", text.lower())
    return text.replace(" ", "-")


def anchors(text: str) -> set[str]:
    """The anchors of a Markdown text's headings (a repeated one gets -1, -2, ...)."""
    seen: dict[str, int] = {}
    out: set[str] = set()
    for _, line in prose_lines(text):
        m = HEADING.match(line)
        if not m:
            continue
        slug = anchor(m.group("text"))
        n = seen.get(slug, 0)
        seen[slug] = n + 1
        out.add(slug if n == 0 else f"{slug}-{n}")
    return out


def sections(text: str) -> set[str]:
    """The numbers of a document's numbered headings: "## 3. The external stop" -> "3"."""
    out: set[str] = set()
    for _, line in prose_lines(text):
        m = HEADING.match(line)
        if m:
            number = re.match(r"(\d+(?:\.\d+)*)\.?\s", m.group("text"))
            if number:
                out.add(number.group(1))
    return out


# -- the four checks, on one file's text ------------------------------------------------------------

def citation_errors(text: str, in_docs: bool, docs: Path) -> list[tuple[int, str]]:
    """Citations of documents that name no file of ``docs`` (or a section it lacks)."""
    errors: list[tuple[int, str]] = []
    for number, line in enumerate(text.splitlines(), start=1):
        for m in CITATION.finditer(line):
            path, name, section = m.group("path"), m.group("name"), m.group("section")
            bare = not path.startswith("docs/") and not DOCS_FOLDER.search(line[:m.start()])
            if bare and name == "README":
                continue  # the repository's front page, cited by its name
            if bare and not in_docs and name not in DESIGN_NAMES and \
                    not (docs / f"{name}.md").exists():
                continue  # not a design document's name (a file of some other project)
            target = docs / f"{name}.md"
            if not target.exists():
                errors.append((number, f"cites {path}: there is no docs/{name}.md"))
            elif bare and not in_docs and name in DESIGN_NAMES:
                errors.append((number, f"cites {path}: write docs/{name}.md"))
            elif section and section not in sections(target.read_text(encoding="utf-8")):
                errors.append((number, f"cites {path} §{section}: docs/{name}.md has no "
                                       f"section {section}"))
        for m in BARE_SECTION.finditer(line):
            if not re.match(r"\w+\.md", line[m.start():]):
                errors.append((number, f"cites {m.group(0)!r}: write docs/{m.group('name')}.md"
                                       f" §..."))
    return errors


def path_errors(text: str, root: Path) -> list[tuple[int, str]]:
    """Paths of the tree a document mentions that do not exist."""
    made = made_by_examples(text)
    errors: list[tuple[int, str]] = []
    for number, line in enumerate(text.splitlines(), start=1):
        for m in PATH.finditer(line):
            path = m.group("path").rstrip(".")
            if any(c in path for c in "<>{}*$…") or "..." in path or path in made:
                continue
            if not (path.endswith("/") or path.endswith(FILE_SUFFIXES)):
                continue  # not a file or folder (a Zenoh key: mcl/auv/aal/action)
            if not (root / path).exists():
                errors.append((number, f"mentions {path}, which does not exist"))
    return errors


def link_errors(text: str, here: Path, root: Path) -> list[tuple[int, str]]:
    """Markdown links to files of the repository that do not resolve (or to an anchor that is
    no heading of their file)."""
    errors: list[tuple[int, str]] = []
    for number, line in prose_lines(text):
        for m in LINK.finditer(line):
            target = m.group("target").strip("<>")
            if re.match(r"[a-z][a-z0-9+.-]*:", target):
                continue  # https:, mailto:
            file, _, fragment = target.partition("#")
            dest = (here.parent / file).resolve() if file else here
            if not dest.exists():
                errors.append((number, f"links to {target}: no such file"))
                continue
            if root.resolve() not in dest.parents and dest != root.resolve():
                errors.append((number, f"links to {target}: outside the repository"))
                continue
            if fragment and dest.suffix == ".md" and \
                    fragment not in anchors(dest.read_text(encoding="utf-8")):
                errors.append((number, f"links to {target}: {dest.name} has no heading "
                                       f"#{fragment}"))
    return errors


def module_errors(text: str, modules: set[str]) -> list[tuple[int, str]]:
    """Module file names, without their folder, in the prose of a document (not in its code
    blocks: commands of other tools) that no module of the tree has."""
    made = {Path(m).name for m in made_by_examples(text)}
    errors: list[tuple[int, str]] = []
    for number, line in prose_lines(text):
        for m in MODULE.finditer(line):
            name = m.group("name")
            if name not in modules and name not in made:
                errors.append((number, f"names the module {name}, which no folder has"))
    return errors


# -- the repository ---------------------------------------------------------------------------------

def report(errors: list[str]) -> str:
    return f"{len(errors)} stale reference(s):\n  " + "\n  ".join(errors)


def test_every_cited_document_exists() -> None:
    errors: list[str] = []
    for path in repository_files():
        text = path.read_text(encoding="utf-8", errors="replace")
        in_docs = path.parent == DOCS
        errors += [f"{where(path, n)}: {why}" for n, why in citation_errors(text, in_docs, DOCS)]
    assert not errors, report(errors)


def test_every_path_the_documents_mention_exists() -> None:
    errors: list[str] = []
    for path in documents():
        text = path.read_text(encoding="utf-8")
        errors += [f"{where(path, n)}: {why}" for n, why in path_errors(text, REPO)]
    assert not errors, report(errors)


def test_every_link_in_the_documents_resolves() -> None:
    errors: list[str] = []
    for path in documents():
        text = path.read_text(encoding="utf-8")
        errors += [f"{where(path, n)}: {why}" for n, why in link_errors(text, path, REPO)]
    assert not errors, report(errors)


def test_every_module_the_documents_name_exists() -> None:
    modules = {p.name for p in repository_files(REPO, (".py",))} | {Path(__file__).name}
    errors = []
    for path in documents():
        text = path.read_text(encoding="utf-8")
        errors += [f"{where(path, n)}: {why}" for n, why in module_errors(text, modules)]
    assert not errors, report(errors)


@pytest.mark.parametrize("name", ["SEMANTICS", "AAL", "DESIGN", "ARCHITECTURE"])
def test_the_design_documents_exist(name: str) -> None:
    text = (DOCS / f"{name}.md").read_text(encoding="utf-8")
    assert text.startswith("# "), f"docs/{name}.md starts with its title"


def test_the_architecture_states_the_layer_order_of_the_layer_test() -> None:
    """docs/ARCHITECTURE.md states the packages in tests/test_layers.py's order."""
    text = (DOCS / "ARCHITECTURE.md").read_text(encoding="utf-8")
    order = re.search(r"`(app > [a-z_ >]+)`", text)
    assert order is not None, "docs/ARCHITECTURE.md states the order as `app > ... > diagnostics`"
    stated = tuple(order.group(1).split(" > "))
    assert set(stated) >= set(LAYERS), f"the order omits {set(LAYERS) - set(stated)}"
    assert tuple(p for p in stated if p in LAYERS) == LAYERS


# -- the scanners, on text made to fail ---------------------------------------------------------------

def test_a_bare_citation_in_code_is_refused(tmp_path: Path) -> None:
    (tmp_path / "SEMANTICS.md").write_text("# S\n\n## 3. The stop\n", encoding="utf-8")
    code = '"""The rules (SEMANTICS.md).\n\nSee docs/SEMANTICS.md §3 and docs/SEMANTICS.md §4;\n' \
           'docs/NOPE.md; MCL.md §5; timers (SEMANTICS §5)."""\n'
    errors = citation_errors(code, in_docs=False, docs=tmp_path)
    assert errors == [
        (1, "cites SEMANTICS.md: write docs/SEMANTICS.md"),
        (3, "cites docs/SEMANTICS.md §4: docs/SEMANTICS.md has no section 4"),
        (4, "cites docs/NOPE.md: there is no docs/NOPE.md"),
        (4, "cites MCL.md: there is no docs/MCL.md"),
        (4, "cites 'SEMANTICS §5': write docs/SEMANTICS.md §..."),
    ]
    # inside docs/, a bare name is a relative reference
    assert citation_errors("see SEMANTICS.md §3", in_docs=True, docs=tmp_path) == []
    # a path built in code names the folder; a bare name that is no design document must exist
    (tmp_path / "EXTENDING.md").write_text("# E\n", encoding="utf-8")
    assert citation_errors('DOC = REPO / "docs" / "SEMANTICS.md"\nsee EXTENDING.md\n'
                           'see VEHICLES.md', in_docs=False, docs=tmp_path) == []
    assert citation_errors('REPO / "docs" / "AAL.md"', in_docs=False, docs=tmp_path) == [
        (1, "cites AAL.md: there is no docs/AAL.md")]
    # a file of another project is not a citation of ours
    assert citation_errors("pytest's CHANGELOG.md", in_docs=False, docs=tmp_path) == []


def test_a_missing_path_is_refused(tmp_path: Path) -> None:
    (tmp_path / "petri").mkdir()
    (tmp_path / "petri" / "net.py").write_text("", encoding="utf-8")
    text = ("`petri/net.py` and petri/verify.py, `petri/` and `petri/execution/`.\n"
            "Keys: mcl/<v>/aal/action, mcl/auv/aal/event, `mcl/templates/*.py`.\n"
            "```python behaviours/depth.py\n```\nwrite behaviours/depth.py\n")
    assert path_errors(text, tmp_path) == [
        (1, "mentions petri/verify.py, which does not exist"),
        (1, "mentions petri/execution/, which does not exist"),
    ]


def test_a_broken_link_or_anchor_is_refused(tmp_path: Path) -> None:
    docs = tmp_path / "docs"
    docs.mkdir()
    (docs / "A.md").write_text("# A\n\n## What `mclc` proves\n\n```sh\n# not a heading\n```\n",
                               encoding="utf-8")
    here = docs / "B.md"
    text = ("[a](A.md#what-mclc-proves) [b](A.md#not-a-heading) [c](C.md) "
            "[d](https://example.org/x.md) [e](#here)\n\n## Here\n"
            "```\n[f](nowhere.md)\n```\n")
    here.write_text(text, encoding="utf-8")
    assert link_errors(text, here, tmp_path) == [
        (1, "links to A.md#not-a-heading: A.md has no heading #not-a-heading"),
        (1, "links to C.md: no such file"),
    ]


def test_a_module_name_that_no_folder_has_is_refused() -> None:
    text = ("`stack.py` and `mavlink_guided.py`, each a module;\n"
            "```sh\nmavproxy.py --master=udpin:127.0.0.1:14550\n```\n"
            "```python behaviours/depth.py\n```\nand depth.py, made above.\n")
    assert module_errors(text, {"stack.py"}) == [
        (1, "names the module mavlink_guided.py, which no folder has")]


def test_anchors_follow_githubs_rule() -> None:
    assert anchor("Add a kind of vehicle (one file, one line)") == \
        "add-a-kind-of-vehicle-one-file-one-line"
    assert anchor("`mcl vehicle --zenoh ENDPOINT` and `mcl monitor` — the vehicle") == \
        "mcl-vehicle---zenoh-endpoint-and-mcl-monitor--the-vehicle"
    assert anchors("# T\n## Limits\n## Limits\n") == {"t", "limits", "limits-1"}
