"""The methods ``dataclasses`` writes for each class, kept compiled between calls of mclc.

For every dataclass, Python writes the source of its methods (``__init__``, ``__repr__``,
``__eq__``, ``__hash__``, and for a frozen one ``__setattr__`` and ``__delattr__``) and
compiles it with ``exec``, at every start: for the 54 classes a call of mclc imports, about
25 ms of CPU, a fifth of the whole call and as much as a bare Python's start. The source of
a class's methods is a function of its definition alone, so its compiled code is the same
from one call to the next: :func:`kept` keeps each source's code in the cache (mcl/cache.py,
one entry under Python's version: code objects are Python's own ``marshal`` format) and
``dataclasses`` runs the code kept instead of compiling its source again (about 5 ms left).

The code is what ``exec`` would compile from the same text (no ``__future__`` flags, as
``dataclasses`` has none), so the classes are the same: the cache changes only how long they
take to make (tests/mcl/test_dataclass_methods.py). Outside :func:`kept`, and when the cache
is off, ``dataclasses`` compiles as always.
"""

from __future__ import annotations

import builtins
import dataclasses
import marshal
import types
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

from mcl import cache

NAME = "dataclass-methods"  # the cache's entry
FORMAT = "dataclass methods 1"  # a part of its key: bump when its layout changes
# Sources kept at most: one call's classes and those of the calls before, up to this many
# (those of code since edited stay until then); over it, only the last call's are kept.
MOST = 4000


def compiled(source: str) -> types.CodeType:
    """The code ``exec(source, ...)`` runs when called from ``dataclasses``: compiled with
    no ``__future__`` flag of this module's (``dataclasses`` imports none)."""
    return compile(source, "<string>", "exec", dont_inherit=True)


def entry(place: Path) -> Path:
    """The entry's file in the cache folder (named as mcl/cache.py names its entries)."""
    return place / f"{NAME}-{cache.key([FORMAT])}.pickle"


def load() -> dict[str, types.CodeType]:
    """The kept code of each source (none when the cache is off, or the entry is missing,
    damaged or another user's)."""
    place = cache.folder()
    if place is None:
        return {}
    try:
        with open(entry(place), "rb") as f:
            kept = marshal.loads(f.read()) if cache.mine(f.fileno()) else {}
    except Exception:  # noqa: BLE001 - absent, unreadable or partial: compile the sources
        return {}
    if not isinstance(kept, dict):
        return {}
    return {s: c for s, c in kept.items()
            if isinstance(s, str) and isinstance(c, types.CodeType)}


def save(codes: dict[str, types.CodeType]) -> None:
    """Keep the code of each source in the cache, replacing what it held."""
    place = cache.folder()
    if place is not None:
        cache.store(entry(place), NAME, codes, lambda value, f: marshal.dump(value, f))


@contextmanager
def kept() -> Iterator[None]:
    """Within it, the dataclasses made take the code of their methods from the cache (the
    module's docstring), and the code of sources not kept yet is kept at its end."""
    if cache.folder() is None or hasattr(dataclasses, "exec"):  # off, or within another
        yield
        return
    codes = load()
    used: dict[str, types.CodeType] = {}
    made = [0]

    def exec_kept(source: Any, globals: dict[str, Any] | None = None,
                  locals: dict[str, Any] | None = None, /) -> None:
        """``exec`` for dataclasses: a source's code from the cache, compiled when not kept."""
        if isinstance(source, str) and globals is not None:
            code = codes.get(source)
            if code is None:
                code = compiled(source)
                made[0] += 1
            used[source] = code
            source = code
        builtins.exec(source, globals, locals)  # noqa: S102 - the code dataclasses wrote

    dataclasses.exec = exec_kept  # type: ignore[attr-defined]  # before the builtin
    try:
        yield
    finally:
        del dataclasses.exec  # type: ignore[attr-defined]
        if made[0]:
            every = {**codes, **used}
            save(every if len(every) <= MOST else used)
