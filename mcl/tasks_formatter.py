"""The formatter of ``mcl fmt`` for task libraries (``.tasks`` files): one canonical layout,
its comments kept.

It reads the lark parse of ``mcl/grammar/tasks.lark`` with every token kept and the comments
collected by the lexer, and writes the tokens back in source order through the writer missions
share (mcl/layout.py): only the blanks between them change, so the library the text declares
(mcl/tasklib.py) is the same. The layout (docs/FMT.md):

- one declaration (``dofs``, ``behaviour``, ``task``) per line or block, at the left margin;
- a table of ``behaviour`` lines: in a run of consecutive one-line declarations (no blank line
  or comment line between, no comment inside) the name, ``drives``, ``events`` and ``power``
  parts each start in one column, two spaces past the widest part before it;
- a task's clauses one per line, four spaces in, the value of each in the column after
  ``timeout:`` (``start:   enable GoTo``; a longer label, ``estimate:``, one space); a task
  the author wrote on one line stays on one line when it fits in :data:`WIDTH` columns and
  holds no comment (``task A() { ok: Probe.ok; fail: Probe.fail; }``), an empty body is
  ``{ }``;
- a line break the author put inside brackets or a clause after ``,`` ``(`` ``[`` or before
  ``)`` ``]`` is kept, the next line aligned one past the open bracket, or with the clause's
  value outside brackets;
- spaces as in missions; none around ``.`` (``GoTo.reached``), none before ``:``, and ``m/s``
  written as one word.
"""

from __future__ import annotations

from lark import Token, Tree

from diagnostics import Source

from mcl.layout import INDENT, WIDTH, TokenWriter, parse_with_comments, spaced, tokens_of
from mcl.tasklib import parse_library

LABEL = len("timeout: ")  # the column of a clause's value after its label
BEHAVIOUR_PARTS = ("drives", "events", "power")
GAP = "  "  # between the columns of a table of behaviours


def format_library_source(source: Source) -> str:
    """The canonical layout of a task library; an :class:`MclError` if it does not parse."""
    parse_library(source)  # the loader's errors for text that is not a task library
    text = source.text.replace("\r\n", "\n")  # the layout's lines end in '\n' alone
    tree, comments = parse_with_comments("tasks.lark", "library", text)
    return LibraryLayout(text, tree, comments).text()


def format_library_text(text: str, origin: str = "<text>.tasks") -> str:
    return format_library_source(Source(origin, text))


def flat(tokens: list[Token]) -> str:
    """Tokens written on one line, spaced as in the layout."""
    parts: list[str] = []
    prev: Token | None = None
    for t in tokens:
        parts.append((" " if prev is not None and library_spaced(prev, t) else "") + t.value)
        prev = t
    return "".join(parts)


def library_spaced(prev: Token | None, cur: Token) -> bool:
    """Whether one space goes between two tokens of a library on a line."""
    if prev is None or cur.value in (":", ".") or prev.value == ".":
        return False
    if prev.type == "M" or cur.type == "S":  # 'm/s' of an estimate
        return False
    return spaced(prev, cur)


class LibraryLayout(TokenWriter):
    """Writes one parsed task library back, line by line (see the module's docstring)."""

    def __init__(self, text: str, tree: Tree[Token], comments: list[Token]) -> None:
        super().__init__(text, tree, comments)
        self.clause_column: int | None = None  # the column of the value of the clause under way

    def indentation(self) -> str:
        if self.columns:
            return " " * self.columns[-1]
        if self.clause_column is not None:
            return " " * self.clause_column
        return INDENT * self.depth

    def spaced(self, prev: Token | None, cur: Token) -> bool:
        return library_spaced(prev, cur)

    def kept_break(self, prev: Token, t: Token) -> bool:
        inside = bool(self.columns) or self.clause_column is not None
        return inside and super().kept_break(prev, t)

    # -- the declarations --------------------------------------------------------------
    def lay_out(self) -> None:
        columns = self.behaviour_columns()
        for child in self.tree.children:
            assert isinstance(child, Tree)
            self.newline()
            if child.data == "task":
                self.task(child)
            elif child.data == "behaviour":
                self.behaviour(child, columns.get(id(child)))
            else:
                self.declaration(list(tokens_of(child)))

    def declaration(self, tokens: list[Token]) -> None:
        """A one-line declaration; a line a comment ends goes on one level in."""
        self.tok(tokens[0])
        self.depth = 1
        for t in tokens[1:]:
            self.tok(t)
        self.depth = 0

    def behaviour(self, tree: Tree[Token], columns: dict[str, int] | None) -> None:
        """``behaviour NAME drives ... events ... power N W;``, its parts in the table's
        columns when it is in a table."""
        keyword, name, *parts, semicolon = tree.children
        assert isinstance(keyword, Token) and isinstance(name, Token)
        self.tok(keyword)
        self.depth = 1
        self.tok(name)
        for part in parts:
            if not isinstance(part, Tree):
                continue
            if columns is not None and self.code:
                self.code = self.code.ljust(columns[part.data] - 1)  # the token adds a space
            for t in tokens_of(part):
                self.tok(t)
        assert isinstance(semicolon, Token)
        self.tok(semicolon)
        self.depth = 0

    def behaviour_columns(self) -> dict[int, dict[str, int]]:
        """The columns of the parts of each behaviour in a table (see the module's docstring)."""
        runs: list[list[Tree[Token]]] = [[]]
        for child in self.tree.children:
            assert isinstance(child, Tree)
            in_table = child.data == "behaviour" and not self.has_comment(child)
            if runs[-1] and (not in_table or self.separated(runs[-1][-1], child)):
                runs.append([])
            if in_table:
                runs[-1].append(child)
        out: dict[int, dict[str, int]] = {}
        for run in runs:
            widest = max((len(str(b.children[1])) for b in run), default=0)
            column = len("behaviour ") + widest + len(GAP)
            columns: dict[str, int] = {}
            for part in BEHAVIOUR_PARTS:
                columns[part] = column
                widths = [len(flat(list(tokens_of(p)))) for b in run for p in b.children
                          if isinstance(p, Tree) and p.data == part]
                column += max(widths) + len(GAP) if widths else 0
            out.update({id(b): columns for b in run})
        return out

    def task(self, tree: Tree[Token]) -> None:
        """``task NAME(formals) {`` its clauses, one a line, ``}``; or all on one line."""
        tokens = list(tokens_of(tree))
        body = tokens.index(next(t for t in tokens if t.value == "{"))
        clauses = [c for c in tree.children if isinstance(c, Tree) and c.data != "formal"]
        start, end = tree.meta.start_pos, tree.meta.end_pos
        one_line = not self.has_comment(tree) and (not clauses or (
            "\n" not in self.src[start:end] and len(flat(tokens)) <= WIDTH))
        self.tok(tokens[0])
        self.depth = 1
        for t in tokens[1:body + 1]:
            self.tok(t)
        for clause in clauses:
            if not one_line:
                self.newline()
            self.clause(clause, one_line)
        self.leading(tokens[-1].start_pos or 0, self.indentation())
        self.depth = 0
        if not one_line:
            self.newline()
        self.tok(tokens[-1])

    def clause(self, tree: Tree[Token], one_line: bool) -> None:
        """``label: value;``, the value in the column after ``timeout:`` on a line of its own."""
        label, colon, *rest = list(tokens_of(tree))
        pad = 0 if one_line else max(0, LABEL - len(label) - 2)
        self.tok(label)
        self.tok(colon, pad=pad)
        self.clause_column = len(INDENT) * self.depth + len(label) + 2 + pad
        for t in rest:
            self.tok(t)
        self.clause_column = None
