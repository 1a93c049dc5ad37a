"""The tokens and trees of a parse, whichever parser made them: missions are parsed by lark's
standalone parser (mcl/grammars.py), task libraries and the formatters by lark itself, and each
has classes of its own, alike in all but name.

``isinstance(x, Token)`` holds for a token of either (a ``str`` with a ``type``), and
``isinstance(x, Tree)`` for a tree of either (``data`` and ``children``); a type checker sees
lark's classes.
"""

from __future__ import annotations

from types import SimpleNamespace
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from lark import Token as Token
    from lark import Tree as Tree
else:
    class TokenKind(type):
        """The class of :class:`Token`: what isinstance asks of a token."""

        def __instancecheck__(cls, value: object) -> bool:
            return isinstance(value, str) and hasattr(value, "type")

    class TreeKind(type):
        """The class of :class:`Tree`: what isinstance asks of a tree."""

        def __instancecheck__(cls, value: object) -> bool:
            return (not isinstance(value, str) and hasattr(value, "data")
                    and hasattr(value, "children"))

    class Token(metaclass=TokenKind):
        """A token of lark's parser or of the standalone one (for isinstance only)."""

    class Tree(metaclass=TreeKind):
        """A tree of lark's parser or of the standalone one; one made here (``Tree(data,
        children)``, as the syntax tree's builder regroups a parse) has no place of its own
        (its ``meta`` is empty)."""

        def __init__(self, data: str, children: list[Any], meta: Any = None) -> None:
            self.data, self.children = data, children
            self.meta = meta if meta is not None else SimpleNamespace(empty=True)

        def __repr__(self) -> str:
            return f"Tree({self.data!r}, {self.children!r})"
