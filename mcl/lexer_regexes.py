"""The regular expressions of the standalone parser's lexer (mcl/grammars.py), kept compiled
between calls.

lark's contextual lexer matches, in each state of the parser, the terminals that state
accepts, with one regular expression of them all (a *scanner*), compiled the first time the
state is met: for the dam mission 22 patterns, 3 ms of CPU of every call, most of it Python's
own ``re`` parsing each pattern and writing the code of its matching engine. That code is a
function of the pattern, its flags and Python's version alone, so the parser's cache entry
keeps it: :func:`recording` gives the ``re`` the lexer compiles with when the entry is built
(every scanner built once, each pattern's compiled form kept), and :func:`kept` the one it
compiles with afterwards, which makes each kept pattern from its code at once (``_sre``'s
``compile``, which ``re.compile`` itself ends with, and which checks the code it is given).

A kept pattern is checked, when it is kept, to be the one ``re.compile`` makes (patterns
compare equal when their text, flags and code are the same); a pattern not kept, and any
failure, is compiled by ``re`` as always. The entry's key holds Python's version (mcl/cache.py).
"""

from __future__ import annotations

import importlib
import re
import types
from collections.abc import Callable
from typing import Any

# What re.compile hands to the engine for a pattern: its flags (with those the pattern sets
# inline), its code, its number of groups, its group names and the name of each group.
Parts = tuple[int, list[int], int, dict[str, int], tuple[Any, ...]]

# Python's own modules behind re.compile (re._parser and re._compiler since 3.11): parsing a
# pattern, writing its code, and making the pattern from that code.
# A Python whose re has them elsewhere keeps no pattern: each is compiled by re as always.
try:
    _PARSER: Any = importlib.import_module("re._parser")
    _COMPILER: Any = importlib.import_module("re._compiler")
    _ENGINE: Any = importlib.import_module("_sre")
except ImportError:  # pragma: no cover - not in Python 3.11 to 3.13
    _PARSER = _COMPILER = _ENGINE = None


def parts_of(pattern: str, flags: int) -> Parts | None:
    """What ``re.compile(pattern, flags)`` makes the pattern from, as re._compiler.compile
    computes it; None where what it makes differs from re.compile's (another Python's re)."""
    if _ENGINE is None:
        return None
    try:
        parsed = _PARSER.parse(pattern, flags)
        code = _COMPILER._code(parsed, flags)
        names = dict(parsed.state.groupdict)
        index: list[Any] = [None] * parsed.state.groups
        for name, i in names.items():
            index[i] = name
        # plain ints: re's opcodes are an int subclass, which marshal does not write
        parts: Parts = (int(flags | parsed.state.flags), [int(c) for c in code],
                        int(parsed.state.groups) - 1, names, tuple(index))
        if _ENGINE.compile(pattern, *parts) != re.compile(pattern, flags):
            return None
    except Exception:  # noqa: BLE001 - this Python's re works otherwise: not kept
        return None
    return parts


def module_with(compile: Callable[[str, int], re.Pattern[str]]) -> types.ModuleType:
    """A copy of the ``re`` module whose ``compile`` (and ``match``, which lark's lexer also
    calls) is ``compile``."""
    copy = types.ModuleType("re")
    copy.__dict__.update(vars(re))

    def match(pattern: str, string: str, flags: int = 0) -> re.Match[str] | None:
        return compile(pattern, flags).match(string)

    copy.compile = lambda pattern, flags=0: compile(pattern, flags)  # type: ignore[attr-defined]
    copy.match = match  # type: ignore[attr-defined]
    return copy


def recording() -> tuple[types.ModuleType, dict[tuple[str, int], Parts]]:
    """An ``re`` that compiles as re does and keeps, in the dictionary given beside it, the
    parts of each pattern it compiles (:func:`parts_of`)."""
    kept: dict[tuple[str, int], Parts] = {}

    def compile(pattern: str, flags: int = 0) -> re.Pattern[str]:
        if isinstance(pattern, str) and (pattern, flags) not in kept:
            parts = parts_of(pattern, flags)
            if parts is not None:
                kept[pattern, flags] = parts
        return re.compile(pattern, flags)

    return module_with(compile), kept


def kept(regexes: dict[tuple[str, int], Parts]) -> types.ModuleType:
    """An ``re`` that makes each pattern of ``regexes`` from its kept parts, once per process,
    and compiles every other as re does."""
    made: dict[tuple[str, int], re.Pattern[str]] = {}

    def compile(pattern: str, flags: int = 0) -> re.Pattern[str]:
        key = (pattern, flags)
        found = made.get(key)
        if found is None:
            parts = regexes.get(key)
            try:
                found = (re.compile(pattern, flags) if parts is None or _ENGINE is None
                         else _ENGINE.compile(pattern, *parts))
            except (RuntimeError, TypeError, ValueError):  # code this engine refuses
                found = re.compile(pattern, flags)
            made[key] = found
        return found

    return module_with(compile)
