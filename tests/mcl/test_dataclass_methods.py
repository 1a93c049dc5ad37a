"""The methods of dataclasses kept compiled between calls (mcl/dataclass_methods.py): the
classes made with the kept code are those ``dataclasses`` makes alone, a source is compiled
once, and outside kept() or with the cache off nothing changes."""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import pytest

from mcl import dataclass_methods


class Counted:
    """dataclass_methods.compiled, counting the sources it compiles."""

    def __init__(self) -> None:
        self.sources: list[str] = []
        self.compile = dataclass_methods.compiled

    def __call__(self, source: str) -> Any:
        self.sources.append(source)
        return self.compile(source)


def make() -> list[type]:
    """Three dataclasses as the project writes them (frozen with defaults, a factory, plain
    with ordering), made anew at each call."""

    @dataclass(frozen=True)
    class Point:
        x: float
        y: float = 0.0
        tags: tuple[str, ...] = ()

    @dataclass
    class Bag:
        name: str
        items: list[int] = field(default_factory=list)

    @dataclass(order=True, slots=True)
    class Rank:
        level: int
        label: str = "?"

    return [Point, Bag, Rank]


def methods(cls: type) -> dict[str, tuple[bytes, tuple[Any, ...], tuple[str, ...], Any]]:
    """What each method dataclasses wrote for ``cls`` is: its bytecode, constants, names and
    annotations."""
    found = {}
    for name, value in vars(cls).items():
        code = getattr(value, "__code__", None)
        if code is not None and code.co_filename == "<string>":
            found[name] = (code.co_code, code.co_consts, code.co_names,
                           getattr(value, "__annotations__", None))
    return found


def behaviour(classes: list[type]) -> list[object]:
    """What instances of the three classes do: equality, hashing, repr, order, defaults."""
    point, bag, rank = classes
    p = point(1.0, tags=("a",))
    with pytest.raises(dataclasses.FrozenInstanceError):
        p.x = 2.0
    b1, b2 = bag("b"), bag("b")
    b1.items.append(1)
    return [repr(p), p == point(1.0, 0.0, ("a",)), hash(p) == hash(point(1.0, 0.0, ("a",))),
            repr(b1), b1 == b2, b2.items, rank(2) < rank(3), rank(1, "x") > rank(1, "a"),
            repr(rank(4)), [f.name for f in dataclasses.fields(point)]]


def test_classes_made_from_kept_code_are_those_dataclasses_makes(
        folder: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    alone = make()
    counted = Counted()
    monkeypatch.setattr(dataclass_methods, "compiled", counted)
    with dataclass_methods.kept():
        first = make()
    compiled_first = len(counted.sources)
    assert compiled_first >= 9  # __init__, __repr__, __eq__ at least, of each class
    assert len(list(folder.glob("dataclass-methods-*.pickle"))) == 1
    with dataclass_methods.kept():
        second = make()
    assert len(counted.sources) == compiled_first  # the second call compiled nothing
    for made in (first, second):
        assert [methods(c) for c in made] == [methods(c) for c in alone]
        assert behaviour(made) == behaviour(alone)
    assert not hasattr(dataclasses, "exec")  # dataclasses left as it was


def test_a_source_not_kept_is_compiled_and_then_kept(
        folder: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    with dataclass_methods.kept():
        make()
    counted = Counted()
    monkeypatch.setattr(dataclass_methods, "compiled", counted)

    @dataclass
    class Other:
        depth_m: float

    with dataclass_methods.kept():
        make()

        @dataclass
        class Newer:
            heading_deg: float

    assert len(counted.sources) >= 2 and all("heading_deg" in s for s in counted.sources)
    with dataclass_methods.kept():
        @dataclass
        class NewerAgain:  # the same source as Newer: kept
            heading_deg: float

    assert len(counted.sources) >= 2 and all("heading_deg" in s for s in counted.sources)
    assert NewerAgain(3.0) == NewerAgain(3.0) and repr(NewerAgain(3.0)).endswith(
        "NewerAgain(heading_deg=3.0)")


def test_with_the_cache_off_dataclasses_compile_as_always(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("MCL_CACHE_DIR", "")
    counted = Counted()
    monkeypatch.setattr(dataclass_methods, "compiled", counted)
    with dataclass_methods.kept():
        assert not hasattr(dataclasses, "exec")
        made = make()
    assert counted.sources == []
    assert behaviour(made) == behaviour(make())
    assert list(tmp_path.iterdir()) == []


def test_a_damaged_entry_is_compiled_over(folder: Path) -> None:
    with dataclass_methods.kept():
        make()
    [entry] = folder.glob("dataclass-methods-*.pickle")
    entry.write_bytes(b"not marshal data")
    with dataclass_methods.kept():
        made = make()
    assert behaviour(made) == behaviour(make())
    assert entry.stat().st_size > 100  # written anew, whole
