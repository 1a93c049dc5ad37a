"""The formatter of ``mcl fmt``: MCL text in one canonical layout, its comments kept.

It reads the lark parse of the one grammar (``mcl/grammar/mcl.lark``) with every token kept
and the comments collected by the lexer (lark's ``lexer_callbacks``), and writes the tokens
back in source order: only the blanks between them change, so ``parse(fmt(x)) == parse(x)``.
The layout (docs/FMT.md):

- one ``USES`` or ``PARAM`` per line; the ``=`` of consecutive one-line ``PARAM`` lines aligned;
- blocks broken over lines, one item per line, four spaces a level; a construct stays on one
  line when every block of it holds one item that fits on a line, and the whole fits in
  :data:`WIDTH` columns; otherwise the condition block of ``IF`` and ``WHILE`` may stay on the
  keyword's line (``IF { A() } THEN {``) and every other block is broken;
- one space between tokens except after ``(`` ``[`` and before ``,`` ``;`` ``)`` ``]`` and a
  call's ``(``; a line break the author put after ``,`` ``(`` ``[`` or before ``)`` ``]``
  inside a value or a call is kept (long lists), at one more level per open bracket;
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

from diagnostics import Source

from mcl.parser import parse

WIDTH = 100  # the columns a construct kept on one line may take
INDENT = "    "
OPENING = ("(", "[")
CLOSING = (")", "]")
CONDITION_OF = {"if_then_else", "while_do"}  # constructs whose first block is a condition


class _Collected:
    """The comments the lexer met in the parse under way (the parser is shared: a lock)."""

    lock = threading.Lock()
    comments: list[Token] = []


@lru_cache(maxsize=1)
def _lark() -> Lark:
    def keep(tok: Token) -> Token:
        _Collected.comments.append(tok)
        return tok

    return Lark.open_from_package("mcl", "mcl.lark", ("grammar",), parser="lalr",
                                  propagate_positions=True, maybe_placeholders=True,
                                  keep_all_tokens=True, start="start",
                                  lexer_callbacks={"COMMENT": keep, "BLOCK_COMMENT": keep})


def format_source(source: Source) -> str:
    """The canonical layout of a mission; an :class:`MclError` if it does not parse."""
    parse(source)  # the parser's friendly errors for text that is not MCL
    text = source.text.replace("\r\n", "\n")  # the layout's lines end in '\n' alone
    with _Collected.lock:
        _Collected.comments = []
        tree = _lark().parse(text)
        comments = sorted(_Collected.comments, key=_start)
    return Layout(text, tree, comments).text()


def lexed(source: Source) -> list[Token]:
    """The tokens of a mission and its comments (``COMMENT``, ``BLOCK_COMMENT``), in source
    order; an :class:`MclError` if it does not parse."""
    parse(source)
    with _Collected.lock:
        _Collected.comments = []
        tree = _lark().parse(source.text)
        comments = list(_Collected.comments)
    return sorted([*tokens_of(tree), *comments], key=_start)


def format_text(text: str, origin: str = "<text>") -> str:
    return format_source(Source(origin, text))


def _start(t: Token) -> int:
    return t.start_pos if t.start_pos is not None else 0


def _end(t: Token) -> int:
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


class Layout:
    """Writes one parsed mission back, line by line (see the module's docstring)."""

    def __init__(self, text: str, tree: Tree[Token], comments: list[Token]) -> None:
        self.src = text
        self.tokens = list(tokens_of(tree))
        self.comments = comments
        self.comment_starts = [_start(c) for c in comments]
        self.next_comment = 0
        self.lines: list[tuple[str, str]] = []  # (code, end-of-line comment)
        self.code = ""
        self.depth = 0
        self.open_brackets = 0
        self.prev: Token | None = None
        self.prev_end = 0
        self.position = {_start(t): i for i, t in enumerate(self.tokens)}
        self.tree = tree

    # -- the output ----------------------------------------------------------------------
    def text(self) -> str:
        self.start(self.tree)
        self.leading(len(self.src), self.depth)
        self.newline()
        while self.lines and not self.lines[-1][0]:
            self.lines.pop()
        return "\n".join(_aligned(self.lines)) + "\n"

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
            self.code = INDENT * (self.depth + self.open_brackets) + text
        else:
            self.code += (" " if space else "") + text

    # -- tokens and their comments -----------------------------------------------------
    def tok(self, t: Token, *, pad: int = 0) -> None:
        """Write a token: the comments before it, the token, the comments after it on its line."""
        self.leading(_start(t), self.depth + self.open_brackets)
        if self.prev is not None and self.code and self._kept_break(self.prev, t):
            self.newline()
        if t.value in CLOSING:
            self.open_brackets -= 1
        self.write(t.value, spaced(self.prev, t), _start(t))
        if t.value in OPENING:
            self.open_brackets += 1
        self.code += " " * pad
        self.prev, self.prev_end = t, _end(t)
        self.trailing(t)

    def _kept_break(self, prev: Token, t: Token) -> bool:
        if not (prev.value in (",", *OPENING) or t.value in CLOSING):
            return False
        return "\n" in self.src[_end(prev):_start(t)]

    def leading(self, pos: int, depth: int) -> None:
        """The comments before ``pos`` not yet written: each on its own line."""
        while self.next_comment < len(self.comments) and self.comment_starts[self.next_comment] < pos:
            c = self.comments[self.next_comment]
            self.next_comment += 1
            if self.code and "\n" not in self.src[self.prev_end:_start(c)]:
                self.code += " " + c.value  # a /* */ comment inside a line
            else:
                self.newline()
                self.blank_before(_start(c))
                self.code = INDENT * depth + c.value
                self.newline()
            self.prev_end = _end(c)

    def trailing(self, t: Token) -> None:
        """The comments after ``t`` on its line, before the next token."""
        i = self.position.get(_start(t), -1)
        following = _start(self.tokens[i + 1]) if 0 <= i < len(self.tokens) - 1 else len(self.src)
        while self.next_comment < len(self.comments):
            c = self.comments[self.next_comment]
            if _start(c) >= following or "\n" in self.src[self.prev_end:_start(c)]:
                return
            self.next_comment += 1
            self.prev_end = _end(c)
            if c.type == "BLOCK_COMMENT" and "\n" not in c.value and self.code:
                self.code += " " + c.value  # a one-line /* */ comment: inline, the line goes on
            elif self.code:
                self.lines.append((self.code, c.value))
                self.code = ""
            else:  # a second comment at the end of the same line
                code, comment = self.lines[-1]
                self.lines[-1] = (code, comment + " " + c.value)

    # -- the constructs ----------------------------------------------------------------
    def start(self, tree: Tree[Token]) -> None:
        headers = [c for c in tree.children if isinstance(c, Tree) and c.data != "mission"]
        pads = self._param_pads(headers)
        for child in tree.children:
            if not isinstance(child, Tree):
                continue
            self.newline()
            if child.data == "mission":
                self.mission(child)
            else:
                self.header(child, pads.get(id(child), 0))

    def _param_pads(self, headers: list[Tree[Token]]) -> dict[int, int]:
        """The padding after each PARAM's name that aligns the '=' of a run of PARAM lines."""
        runs: list[list[Tree[Token]]] = [[]]
        for h in headers:
            one_line = h.data == "param" and self.flat(h) is not None
            if runs[-1] and (not one_line or self._separated(runs[-1][-1], h)):
                runs.append([])
            if one_line:
                runs[-1].append(h)
        pads: dict[int, int] = {}
        for run in runs:
            widest = max((len(_name(h)) for h in run), default=0)
            pads.update({id(h): widest - len(_name(h)) for h in run if h.children[2] is not None})
        return pads

    def _separated(self, a: Tree[Token], b: Tree[Token]) -> bool:
        """Whether a blank line or a comment line stands between two headers."""
        gap = self.src[a.meta.end_pos:b.meta.start_pos]
        line_after_a = gap.split("\n", 1)[1] if "\n" in gap else ""
        return gap.count("\n") >= 2 or "//" in line_after_a or "/*" in line_after_a

    def header(self, tree: Tree[Token], pad: int) -> None:
        for i, t in enumerate(tokens_of(tree)):
            self.tok(t, pad=pad if i == 1 else 0)

    def mission(self, tree: Tree[Token]) -> None:
        for child in tree.children:
            if child is None:
                continue
            if isinstance(child, Token):
                self.tok(child)
            elif child.data == "block":
                self.block(child, inline=False)
            else:  # on_stop: ON STOP block
                for part in child.children:
                    if isinstance(part, Token):
                        self.tok(part)
                    else:
                        self.block(part, inline=False)

    def block(self, tree: Tree[Token], inline: bool) -> None:
        open_, *inner, close = tree.children
        assert isinstance(open_, Token) and isinstance(close, Token)
        self.tok(open_)
        if inline:
            for part in inner:
                self.item(part) if isinstance(part, Tree) else self.tok(part)
            self.tok(close)
            return
        self.depth += 1
        for part in inner:
            if isinstance(part, Token):  # ';'
                self.tok(part)
            else:
                self.newline()
                self.item(part)
        self.leading(_start(close), self.depth)
        self.depth -= 1
        self.newline()
        self.tok(close)

    def item(self, tree: Tree[Token] | Token) -> None:
        if isinstance(tree, Token) or tree.data == "call":
            for t in tokens_of(tree):
                self.tok(t)
            return
        flat = self.flat(tree)
        one_line = flat is not None and self._fits(len(flat) + 1)
        blocks = [c for c in tree.children if isinstance(c, Tree)]
        for child in tree.children:
            if child is None:
                continue
            if isinstance(child, Token):
                self.tok(child)
            elif one_line:
                self.block(child, inline=True)
            elif child is blocks[0] and tree.data in CONDITION_OF:
                self.block(child, inline=self._condition_inline(tree, child))
            else:
                self.block(child, inline=False)

    def _condition_inline(self, tree: Tree[Token], condition: Tree[Token]) -> bool:
        """Whether ``IF { A() } THEN {`` (or ``WHILE { A() } DO {``) fits on its line."""
        flat = self.flat(condition)
        then = "THEN" if tree.data == "if_then_else" else "DO"
        return flat is not None and len(self.code) + len(f" {flat} {then} {{") <= WIDTH

    def _fits(self, width: int) -> bool:
        return len(INDENT) * self.depth + width <= WIDTH

    def flat(self, tree: Tree[Token]) -> str | None:
        """The one-line text of a construct, a block or a value, or None if it cannot be one
        line: a block of two or more items, a comment inside, or a line break to keep."""
        start, end = tree.meta.start_pos, tree.meta.end_pos
        if bisect_left(self.comment_starts, end) > bisect_left(self.comment_starts, start):
            return None
        if tree.data == "block":
            items = [c for c in tree.children if isinstance(c, Tree)]
            if len(tree.children) != 3 or not items:
                return None
            inner = self.flat(items[0])
            return None if inner is None else "{ " + inner + " }"
        parts: list[str] = []
        prev: Token | None = None
        for child in tree.children:
            if child is None:
                continue
            if isinstance(child, Tree) and child.data == "block":
                inner = self.flat(child)
                if inner is None:
                    return None
                parts.append(" " + inner)
                prev = None
                continue
            for t in tokens_of(child):
                if prev is not None and self._kept_break(prev, t):
                    return None
                parts.append((" " if parts and spaced(prev, t) else "") + t.value)
                prev = t
        return "".join(parts).strip()


def _name(param: Tree[Token]) -> str:
    return str(param.children[1])


def _aligned(lines: list[tuple[str, str]]) -> list[str]:
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
