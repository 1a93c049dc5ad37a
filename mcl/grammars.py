"""The parsers of the two grammars, ``mcl/grammar/mcl.lark`` (missions) and
``mcl/grammar/tasks.lark`` (task libraries): built by lark (its LALR tables, about 40 ms) the
first time, then loaded from the cache (mcl/cache.py, about 2 ms) under the key of the
grammar's text, the options, lark's version and Python's.
"""

from __future__ import annotations

from importlib import resources
from typing import IO, Any

import lark

from mcl import cache


def grammar_text(name: str) -> str:
    """The text of a grammar shipped in mcl/grammar/ (``mcl.lark``, ``tasks.lark``)."""
    return resources.files("mcl").joinpath("grammar", name).read_text("utf-8")


def parser(name: str, **options: Any) -> lark.Lark:
    """The lark parser of the shipped grammar ``name`` with lark's ``options``."""
    text = grammar_text(name)

    def parts() -> list[str]:
        return [name, text, repr(sorted(options.items())), lark.__version__]

    def build() -> lark.Lark:
        return lark.Lark.open_from_package("mcl", name, ("grammar",), **options)

    def save(built: lark.Lark, f: IO[bytes]) -> None:
        built.save(f)

    return cache.cached("grammar-" + name.removesuffix(".lark"), parts, build, save,
                        lark.Lark.load)
