"""The formatter of ``mcl fmt``: MCL text in one canonical layout, its comments kept.

It reads the lark parse of the one grammar (``mcl/grammar/mcl.lark``) with every token kept
and the comments collected by the lexer, and writes the tokens back in source order through
the writer task libraries share (mcl/layout.py): only the blanks between them change, so
``parse(fmt(x)) == parse(x)``. The layout (docs/FMT.md):

- one ``USES`` or ``PARAM`` per line; the ``=`` of consecutive one-line ``PARAM`` lines aligned;
- blocks broken over lines, one item per line, four spaces a level; a construct stays on one
  line when every block of it holds one item that fits on a line, and the whole fits in
  :data:`WIDTH` columns; otherwise the condition block of ``IF`` and ``WHILE`` may stay on the
  keyword's line (``IF { A() } THEN {``) and every other block is broken;
- one space between tokens except after ``(`` ``[`` and before ``,`` ``;`` ``)`` ``]`` and a
  call's ``(``; a line break the author put after ``,`` ``(`` ``[`` or before ``)`` ``]``
  inside a value or a call is kept (long lists), at one more level per open bracket;
- a fleet: ``FLEET name {``, then each CHANNEL and VEHICLE one level in, a vehicle laid out as
  a file is (its USES, PARAM and MISSION one level further); a CHANNEL on one line when it
  fits, else its MESSAGES on the next line, one level in;
- at most one blank line where the author left one or more, none after ``{`` or before ``}``;
- comments where they were: on their own line at the level of what follows, or at the end of
  the line, the ``//`` comments ending a run of lines aligned two spaces past the longest code;
  a one-line ``/* */`` comment stays inline, one space from its neighbours.
"""

from __future__ import annotations

from collections.abc import Callable

from lark import Token, Tree

from diagnostics import Source

from mcl.layout import (
    CLOSING,
    INDENT,
    OPENING,
    WIDTH,
    TokenWriter,
    parse_with_comments,
    spaced,
    start_of,
    tokens_of,
)
from mcl.parser import parse_unit

# The shared writer's names, importable from here too (mcl.formatter.WIDTH, ...).
__all__ = ["CLOSING", "INDENT", "OPENING", "WIDTH", "Layout", "format_source", "format_text",
           "lexed", "spaced", "tokens_of"]

CONDITION_OF = {"if_then_else", "while_do"}  # constructs whose first block is a condition
MISSIONS = {"mission", "vehicle_mission"}  # a file's mission, a fleet vehicle's


def format_source(source: Source) -> str:
    """The canonical layout of a mission or a fleet; an :class:`MclError` if it does not
    parse."""
    parse_unit(source)  # the parser's friendly errors for text that is not MCL
    text = source.text.replace("\r\n", "\n")  # the layout's lines end in '\n' alone
    tree, comments = parse_with_comments("mcl.lark", "start", text)
    return Layout(text, tree, comments).text()


def lexed(source: Source) -> list[Token]:
    """The tokens of a mission (or a fleet) and its comments (``COMMENT``,
    ``BLOCK_COMMENT``), in source order; an :class:`MclError` if it does not parse."""
    parse_unit(source)
    tree, comments = parse_with_comments("mcl.lark", "start", source.text)
    return sorted([*tokens_of(tree), *comments], key=start_of)


def format_text(text: str, origin: str = "<text>") -> str:
    return format_source(Source(origin, text))


class Layout(TokenWriter):
    """Writes one parsed mission back, line by line (see the module's docstring)."""

    # -- the constructs ----------------------------------------------------------------
    def lay_out(self) -> None:
        self.start(self.tree)

    def start(self, tree: Tree[Token]) -> None:
        last = tree.children[-1]
        if isinstance(last, Tree) and last.data == "fleet":  # the parser refuses headers here
            self.fleet(last)
            return
        self.unit([c for c in tree.children if isinstance(c, Tree)])

    def unit(self, parts: list[Tree[Token]]) -> None:
        """USES and PARAM lines, then the mission: a file's, or a fleet vehicle's."""
        headers = [c for c in parts if c.data not in MISSIONS]
        pads = self._param_pads(headers)
        for child in parts:
            self.newline()
            if child.data in MISSIONS:
                self.mission(child)
            else:
                self.header(child, pads.get(id(child), 0))

    # -- fleets ------------------------------------------------------------------------
    def fleet(self, tree: Tree[Token]) -> None:
        """``FLEET name {``, each channel and vehicle on its own lines one level in, ``}``."""
        self.braced(tree, self._fleet_items)

    def _fleet_items(self, parts: list[Tree[Token]]) -> None:
        for tree in parts:
            self.newline()
            if tree.data == "channel":
                self.channel(tree)
            else:
                self.braced(tree, self.unit)

    def braced(self, tree: Tree[Token], inner: Callable[[list[Tree[Token]]], None]) -> None:
        """A construct whose head and '{' come first, its parts one level in, '}' last."""
        close = tree.children[-1]
        assert isinstance(close, Token)
        parts = [c for c in tree.children if isinstance(c, Tree)]
        for t in tree.children:
            if isinstance(t, Token) and t is not close:
                self.tok(t)
        self.depth += 1
        inner(parts)
        self.leading(start_of(close), INDENT * self.depth)
        self.depth -= 1
        self.newline()
        self.tok(close)

    def channel(self, tree: Tree[Token]) -> None:
        """A CHANNEL on one line when it fits, else its MESSAGES on the next, one level in."""
        flat = self.flat(tree)
        fits = flat is not None and self._fits(len(flat))
        for child in tree.children:
            if child is None:
                continue
            if isinstance(child, Tree) and child.data == "messages" and not fits:
                self.depth += 1
                self.newline()
                for t in tokens_of(child):
                    self.tok(t)
                self.depth -= 1
                continue
            for t in tokens_of(child):
                self.tok(t)

    def _param_pads(self, headers: list[Tree[Token]]) -> dict[int, int]:
        """The padding after each PARAM's name that aligns the '=' of a run of PARAM lines."""
        runs: list[list[Tree[Token]]] = [[]]
        for h in headers:
            one_line = h.data == "param" and self.flat(h) is not None
            if runs[-1] and (not one_line or self.separated(runs[-1][-1], h)):
                runs.append([])
            if one_line:
                runs[-1].append(h)
        pads: dict[int, int] = {}
        for run in runs:
            widest = max((len(_name(h)) for h in run), default=0)
            pads.update({id(h): widest - len(_name(h)) for h in run if h.children[2] is not None})
        return pads

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
        self.leading(start_of(close), INDENT * self.depth)
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
        if self.has_comment(tree):
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
                if prev is not None and self.kept_break(prev, t):
                    return None
                parts.append((" " if parts and spaced(prev, t) else "") + t.value)
                prev = t
        return "".join(parts).strip()


def _name(param: Tree[Token]) -> str:
    return str(param.children[1])
