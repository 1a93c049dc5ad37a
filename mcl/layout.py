"""The token writer both layouts of ``mcl fmt`` share: missions (mcl/formatter.py) and task
libraries (mcl/tasks_formatter.py).

A layout reads lark's parse of its grammar with every token kept and the comments collected by
the lexer (lark's ``lexer_callbacks``), and writes the tokens back in source order through a
:class:`TokenWriter`: only the blanks between tokens change, so the text parses to what it did.
The writer owns what both layouts do alike (docs/FMT.md):

- one space between tokens except after ``(`` ``[`` and before ``,`` ``;`` ``)`` ``]`` and a
  call's ``(`` (a layout may refine :meth:`TokenWriter.spaced`);
- a line break the author put after ``,`` ``(`` ``[`` or before ``)`` ``]`` is kept
  (:meth:`TokenWriter.kept_break`), the next line at :meth:`TokenWriter.indentation`;
- at most one blank line where the author left one or more, none after ``{`` or before ``}``;
- comments where they were: on their own line at the level of what follows, or at the end of
  the line, the ``//`` comments ending a run of lines aligned two spaces past the longest code;
  a one-line ``/* */`` comment stays inline, one space from its neighbours.
"""

from __future__ import annotations

import threading
from bisect import bisect_left
from collections.abc import Iterator
from functools import lru_cache

from lark import Lark, Token, Tree

WIDTH = 100  # the columns a construct kept on one line may take
INDENT = "    "
OPENING = ("(", "[")
CLOSING = (")", "]")


class _Collected:
    """The comments the lexer met in the parse under way (the parsers are shared: a lock)."""

    lock = threading.Lock()
    comments: list[Token] = []


@lru_cache(maxsize=2)
def _lark(grammar: str, start: str) -> Lark:
    def keep(tok: Token) -> Token:
        _Collected.comments.append(tok)
        return tok

    return Lark.open_from_package("mcl", grammar, ("grammar",), parser="lalr",
                                  propagate_positions=True, maybe_placeholders=True,
                                  keep_all_tokens=True, start=start,
                                  lexer_callbacks={"COMMENT": keep, "BLOCK_COMMENT": keep})


def parse_with_comments(grammar: str, start: str, text: str) -> tuple[Tree[Token], list[Token]]:
    """The parse of ``text`` by the shipped grammar (``mcl.lark``, ``tasks.lark``) with every
    token kept, and its comments in source order. The text must parse: check it first with
    the parser that words the errors."""
    with _Collected.lock:
        _Collected.comments = []
        tree = _lark(grammar, start).parse(text)
        comments = sorted(_Collected.comments, key=start_of)
    return tree, comments


def start_of(t: Token) -> int:
    return t.start_pos if t.start_pos is not None else 0


def end_of(t: Token) -> int:
    return t.end_pos if t.end_pos is not None else 0


def tokens_of(tree: Tree[Token] | Token) -> Iterator[Token]:
    """The tokens of a subtree in source order (placeholders of absent parts skipped)."""
    if isinstance(tree, Token):
        yield tree
        return
    for child in tree.children:
        if child is not None:
            yield from tokens_of(child)


def spaced(prev: Token | None, cur: Token) -> bool:
    """Whether one space goes between two tokens on a line."""
    if prev is None or cur.value in (",", ";", *CLOSING) or prev.value in OPENING:
        return False
    return not (cur.value == "(" and prev.type == "NAME")


class TokenWriter:
    """Writes one parse tree back, line by line; a layout says where lines break by
    :meth:`lay_out` (see the module's docstring)."""

    def __init__(self, text: str, tree: Tree[Token], comments: list[Token]) -> None:
        self.src = text
        self.tokens = list(tokens_of(tree))
        self.comments = comments
        self.comment_starts = [start_of(c) for c in comments]
        self.next_comment = 0
        self.lines: list[tuple[str, str]] = []  # (code, end-of-line comment)
        self.code = ""
        self.depth = 0
        self.columns: list[int] = []  # the column after each open bracket
        self.prev: Token | None = None
        self.prev_end = 0
        self.position = {start_of(t): i for i, t in enumerate(self.tokens)}
        self.tree = tree

    # -- what a layout says --------------------------------------------------------------
    def lay_out(self) -> None:
        """Write every construct of the tree (the layout's own)."""
        raise NotImplementedError

    def indentation(self) -> str:
        """The blanks a new line starts with: four spaces a level and an open bracket."""
        return INDENT * (self.depth + len(self.columns))

    def spaced(self, prev: Token | None, cur: Token) -> bool:
        return spaced(prev, cur)

    def kept_break(self, prev: Token, t: Token) -> bool:
        """Whether the author's line break between two tokens stays."""
        if not (prev.value in (",", *OPENING) or t.value in CLOSING):
            return False
        return "\n" in self.src[end_of(prev):start_of(t)]

    # -- the output ----------------------------------------------------------------------
    def text(self) -> str:
        self.lay_out()
        self.leading(len(self.src), self.indentation())
        self.newline()
        while self.lines and not self.lines[-1][0]:
            self.lines.pop()
        return "\n".join(aligned(self.lines)) + "\n"

    def newline(self) -> None:
        if self.code:
            self.lines.append((self.code, ""))
            self.code = ""

    def blank_before(self, pos: int, closing: bool = False) -> None:
        """One blank line if the author left one before ``pos`` (not after '{', before '}')."""
        if closing or not self.lines or not self.lines[-1][0]:
            return
        if self.lines[-1][0].endswith("{"):
            return
        if self.src.count("\n", self.prev_end, pos) >= 2:
            self.lines.append(("", ""))

    def write(self, text: str, space: bool, pos: int) -> None:
        if not self.code:
            self.blank_before(pos, text in ("}", *CLOSING))
            self.code = self.indentation() + text
        else:
            self.code += (" " if space else "") + text

    # -- tokens and their comments -----------------------------------------------------
    def tok(self, t: Token, *, pad: int = 0) -> None:
        """Write a token: the comments before it, the token, the comments after it on its line."""
        self.leading(start_of(t), self.indentation())
        if self.prev is not None and self.code and self.kept_break(self.prev, t):
            self.newline()
        if t.value in CLOSING and self.columns:
            self.columns.pop()
        self.write(t.value, self.spaced(self.prev, t), start_of(t))
        if t.value in OPENING:
            self.columns.append(len(self.code))
        self.code += " " * pad
        self.prev, self.prev_end = t, end_of(t)
        self.trailing(t)

    def leading(self, pos: int, indent: str) -> None:
        """The comments before ``pos`` not yet written: each on its own line."""
        while self.next_comment < len(self.comments) and self.comment_starts[self.next_comment] < pos:
            c = self.comments[self.next_comment]
            self.next_comment += 1
            if self.code and "\n" not in self.src[self.prev_end:start_of(c)]:
                self.code += " " + c.value  # a /* */ comment inside a line
            else:
                self.newline()
                self.blank_before(start_of(c))
                self.code = indent + c.value
                self.newline()
            self.prev_end = end_of(c)

    def trailing(self, t: Token) -> None:
        """The comments after ``t`` on its line, before the next token."""
        i = self.position.get(start_of(t), -1)
        following = start_of(self.tokens[i + 1]) if 0 <= i < len(self.tokens) - 1 else len(self.src)
        while self.next_comment < len(self.comments):
            c = self.comments[self.next_comment]
            if start_of(c) >= following or "\n" in self.src[self.prev_end:start_of(c)]:
                return
            self.next_comment += 1
            self.prev_end = end_of(c)
            if c.type == "BLOCK_COMMENT" and "\n" not in c.value and self.code:
                self.code += " " + c.value  # a one-line /* */ comment: inline, the line goes on
            elif self.code:
                self.lines.append((self.code, c.value))
                self.code = ""
            else:  # a second comment at the end of the same line
                code, comment = self.lines[-1]
                self.lines[-1] = (code, comment + " " + c.value)

    # -- what layouts ask of the source ------------------------------------------------
    def has_comment(self, tree: Tree[Token]) -> bool:
        """Whether a comment lies inside a construct."""
        start, end = tree.meta.start_pos, tree.meta.end_pos
        return bisect_left(self.comment_starts, end) > bisect_left(self.comment_starts, start)

    def separated(self, a: Tree[Token], b: Tree[Token]) -> bool:
        """Whether a blank line or a comment line stands between two declarations."""
        gap = self.src[a.meta.end_pos:b.meta.start_pos]
        line_after_a = gap.split("\n", 1)[1] if "\n" in gap else ""
        return gap.count("\n") >= 2 or "//" in line_after_a or "/*" in line_after_a


def aligned(lines: list[tuple[str, str]]) -> list[str]:
    """The lines, with the end-of-line comments of a run of lines aligned two spaces past the
    longest code that has one; a run is consecutive lines of code at one indentation."""
    out: list[str] = []
    i = 0
    while i < len(lines):
        indent = _indentation(lines[i][0])
        j = i + 1
        while j < len(lines) and lines[j][0] and _indentation(lines[j][0]) == indent:
            j += 1
        if not lines[i][0]:
            j = i + 1
        column = max((len(code.rstrip()) for code, comment in lines[i:j] if comment),
                     default=0) + 2
        for code, comment in lines[i:j]:
            code = code.rstrip()
            out.append(code.ljust(column) + comment if comment and code else
                       code + comment)
        i = j
    return out


def _indentation(code: str) -> int:
    return len(code) - len(code.lstrip(" "))
