"""The second stage of parsing: a lark parse tree of MCL (a mission, a value, or a value in a
task library) turned into the AST of :mod:`mcl.ast`, every node with its span."""

from __future__ import annotations

import math
from dataclasses import replace


from diagnostics import Source, Span, error
from mcl import ast
from mcl.syntax import Token, Tree


def token_span(source: Source, tok: Token) -> Span:
    """Where a token stands in ``source``."""
    return source.span(tok.line or 1, tok.column or 1, tok.end_line or 0, tok.end_column or 0)


class AstBuilder:
    """Turns a lark parse tree of MCL (or of a value, or of a value in a task library) into
    the AST, every node with its span in ``source``."""

    def __init__(self, source: Source):
        self.source = source

    def span(self, node: Tree[Token] | Token) -> Span:
        if isinstance(node, Token):
            return token_span(self.source, node)
        m = node.meta
        return self.source.span(getattr(m, "line", 1), getattr(m, "column", 1),
                                getattr(m, "end_line", 0), getattr(m, "end_column", 0))

    def unit(self, tree: Tree[Token]) -> ast.Mission | ast.Fleet:
        """The whole file: a mission, or a fleet."""
        *headers, last = tree.children
        if isinstance(last, Tree) and last.data == "fleet":
            if headers:
                assert isinstance(headers[0], Tree)
                raise error(self.source, f"{headers[0].data.upper()} before FLEET: each "
                            "vehicle has its own", self.span(headers[0]),
                            "move it inside the VEHICLE it belongs to", code="fleet-header")
            return self.fleet(last)
        return self.mission(tree)

    def fleet(self, tree: Tree[Token]) -> ast.Fleet:
        name, *items = tree.children
        assert isinstance(name, Token)
        channels = tuple(self.channel(c) for c in items
                         if isinstance(c, Tree) and c.data == "channel")
        vehicles = tuple(self.vehicle(v) for v in items
                         if isinstance(v, Tree) and v.data == "vehicle")
        return ast.Fleet(str(name), channels, vehicles, self.span(tree))

    def name(self, tok: Tree[Token] | Token | None) -> ast.Ref:
        assert isinstance(tok, Token)
        return ast.Ref(str(tok), self.span(tok))

    def channel(self, tree: Tree[Token]) -> ast.ChannelDecl:
        kids = list(tree.children)
        link_at = next(i for i, k in enumerate(kids) if isinstance(k, Tree)
                       and k.data in ast.LINKS)
        name, sender, *receivers = (self.name(k) for k in kids[:link_at])
        link = kids[link_at]
        assert isinstance(link, Tree)
        delay, every, lossy, messages = kids[link_at + 1:]
        assert isinstance(delay, Tree) and isinstance(messages, Tree)
        lo, hi = delay.children
        every_value = None
        if isinstance(every, Tree):
            value = self.value(every.children[0])
            assert isinstance(value, ast.Number)
            every_value = value
        low, high = self.value(lo), self.value(hi)
        assert isinstance(low, ast.Number) and isinstance(high, ast.Number)
        return ast.ChannelDecl(name, sender, tuple(receivers), str(link.data), low, high,
                               every_value, lossy is not None,
                               tuple(self.name(m) for m in messages.children),
                               self.span(tree))

    def vehicle(self, tree: Tree[Token]) -> ast.Vehicle:
        name, *rest = tree.children
        return ast.Vehicle(self.name(name), self.mission(Tree("start", rest)), self.span(tree))

    def mission(self, tree: Tree[Token]) -> ast.Mission:
        *headers, mission_tree = tree.children
        params = tuple(self.param(p) for p in headers
                       if isinstance(p, Tree) and p.data == "param")
        uses = tuple(self.uses(u) for u in headers if isinstance(u, Tree) and u.data == "uses")
        assert isinstance(mission_tree, Tree)
        name_tok, block_tree, stop_tree = mission_tree.children
        assert isinstance(block_tree, Tree)
        name = str(name_tok) if name_tok is not None else None
        mission = ast.Mission(name, self.block(block_tree), params, self.span(mission_tree),
                              uses)
        if isinstance(stop_tree, Tree):  # ON STOP { ... }
            handler = stop_tree.children[0]
            assert isinstance(handler, Tree)
            mission = replace(mission, on_stop=self.block(handler),
                              stop_span=self.span(stop_tree))
        return mission

    def uses(self, tree: Tree[Token]) -> ast.Uses:
        tok = tree.children[0]
        assert isinstance(tok, Token)
        return ast.Uses(str(tok)[1:-1], self.span(tok))

    def param(self, tree: Tree[Token]) -> ast.Param:
        name, value = tree.children
        assert isinstance(name, Token)
        val = self.value(value) if value is not None else None
        return ast.Param(str(name), val, self.span(name))

    def block(self, tree: Tree[Token]) -> ast.Block:
        """A braced block; a single item stands for itself, several make a Sequence."""
        items = tuple(self.item(c) for c in tree.children if isinstance(c, Tree))
        if len(items) == 1:
            return items[0]
        return ast.Sequence(items, self.span(tree))

    def item(self, tree: Tree[Token]) -> ast.Block:
        kids = [c for c in tree.children if isinstance(c, Tree)]
        span = self.span(tree)
        match tree.data:
            case "call":
                name = tree.children[0]
                assert isinstance(name, Token)
                args = tuple(self.arg(a) for a in tree.children[1:] if a is not None)
                return ast.Call(str(name), args, span)
            case "try_catch_do":
                t, c, d = (self.block(k) for k in kids)
                return ast.TryCatchDo(t, c, d, span)
            case "parallel_and":
                return ast.ParallelAnd(tuple(self.block(k) for k in kids), span)
            case "parallel_or":
                return ast.ParallelOr(tuple(self.block(k) for k in kids), span)
            case "if_then_else":
                cond, then, other = tree.children
                assert isinstance(cond, Tree) and isinstance(then, Tree)
                return ast.IfThenElse(self.block(cond), self.block(then),
                                      self.block(other) if isinstance(other, Tree) else None,
                                      span)
            case "while_do":
                c, b = (self.block(k) for k in kids)
                return ast.WhileDo(c, b, span)
        raise AssertionError(f"unknown item {tree.data}")

    def arg(self, node: Tree[Token] | Token) -> ast.Arg:
        if isinstance(node, Tree) and node.data == "named_arg":
            name, value = node.children
            assert isinstance(name, Token)
            return ast.Arg(self.value(value), str(name), self.span(node))
        plain = self.value(node)
        return ast.Arg(plain, None, plain.span)

    def value(self, node: Tree[Token] | Token | None) -> ast.Value:
        if isinstance(node, Token):  # a bare NAME can arrive untransformed
            return ast.Ref(str(node), self.span(node))
        assert isinstance(node, Tree)
        span = self.span(node)
        match node.data:
            case "number":
                num, unit = node.children
                value = float(str(num))
                if not math.isfinite(value):
                    raise error(self.source, f"number {num} is out of range", span,
                                "numbers must be finite (below about 1.8e308)",
                                code="number-out-of-range")
                return ast.Number(value, str(unit) if unit else None, span)
            case "ref":
                return ast.Ref(str(node.children[0]), span)
            case "list":
                items = tuple(self.value(c) for c in node.children if c is not None)
                return ast.ListValue(items, span)
            case "point":
                return ast.Point(tuple(self.value(c) for c in node.children), span)
            case "value":
                return self.value(node.children[0])
        raise AssertionError(f"unknown value {node.data}")
