"""The tokens and trees of either parser (mcl/syntax.py): lark's and the standalone one's are
recognised alike by isinstance, and a plain string is neither."""

from __future__ import annotations

from pathlib import Path

import lark

from mcl import grammars, syntax

OPTIONS = {"parser": "lalr", "propagate_positions": True, "maybe_placeholders": True,
           "start": ["start", "value"]}


def test_tokens_and_trees_of_either_parser_are_recognised(folder: Path) -> None:
    fresh = lark.Lark.open_from_package("mcl", "mcl.lark", ("grammar",), **OPTIONS)
    standalone = grammars.standalone("mcl.lark", **OPTIONS)
    for parser in (fresh, standalone.parser):
        tree = parser.parse("MISSION { A() }", start="start")
        tokens = list(parser.lex("MISSION { A() }"))
        assert tokens and all(isinstance(t, syntax.Token) for t in tokens)
        assert isinstance(tree, syntax.Tree) and not isinstance(tree, syntax.Token)
    assert not isinstance("NAME", syntax.Token) and not isinstance("NAME", syntax.Tree)
    made: syntax.Tree[syntax.Token] = syntax.Tree("start", [])
    assert isinstance(made, syntax.Tree) and made.meta.empty and made.children == []
