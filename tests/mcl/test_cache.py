"""The cache of what does not change between calls (mcl/cache.py): an entry is built once and
then loaded, under a key of everything it is built from, and every failure of the cache falls
back to building, without a word."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

from mcl import cache


class Builder:
    """A build that counts its calls and returns a fresh value each time."""

    def __init__(self, value: object):
        self.value, self.calls = value, 0

    def __call__(self) -> object:
        self.calls += 1
        return {"value": self.value, "call": self.calls}


def test_an_entry_is_built_once_then_loaded(folder: Path) -> None:
    build = Builder([1, 2, 3])
    first = cache.cached("thing", lambda: ["a"], build)
    again = cache.cached("thing", lambda: ["a"], build)
    assert build.calls == 1
    assert first == again == {"value": [1, 2, 3], "call": 1}
    assert len(list(folder.glob("thing-*.pickle"))) == 1


def test_other_inputs_make_another_key_and_replace_the_old_entry(folder: Path) -> None:
    build = Builder("x")
    cache.cached("thing", lambda: ["a"], build)
    old = list(folder.glob("thing-*.pickle"))
    assert cache.cached("thing", lambda: ["b"], build)["call"] == 2  # type: ignore[index]
    new = list(folder.glob("thing-*.pickle"))
    assert len(new) == 1 and new != old
    cache.cached("other", lambda: ["a"], Builder("y"))  # another name keeps its own entry
    assert len(list(folder.glob("*.pickle"))) == 2


def test_the_key_keeps_the_parts_apart() -> None:
    assert cache.key(["ab", "c"]) != cache.key(["a", "bc"])
    assert cache.key(["ab", "c"]) == cache.key([b"ab", b"c"])
    assert cache.key([]) != cache.key([""])


def test_a_partial_or_foreign_entry_is_rebuilt_and_replaced(folder: Path) -> None:
    build = Builder(7)
    cache.cached("thing", lambda: ["a"], build)
    (entry,) = folder.glob("thing-*.pickle")
    whole = entry.read_bytes()
    for broken in (whole[: len(whole) // 2], b"", b"not a pickle"):
        entry.write_bytes(broken)
        value = cache.cached("thing", lambda: ["a"], build)
        assert value == {"value": 7, "call": build.calls}
        assert entry.read_bytes() != broken
    assert build.calls == 4
    assert not list(folder.glob("*.partial"))


def test_an_unwritable_folder_only_costs_the_build(tmp_path: Path,
                                                   monkeypatch: pytest.MonkeyPatch) -> None:
    blocker = tmp_path / "a-file"
    blocker.write_text("", "utf-8")
    monkeypatch.setenv("MCL_CACHE_DIR", str(blocker / "cache"))  # a folder inside a file
    build = Builder(1)
    assert cache.cached("thing", lambda: ["a"], build) == {"value": 1, "call": 1}
    assert cache.cached("thing", lambda: ["a"], build) == {"value": 1, "call": 2}


def test_an_unreadable_input_or_an_unpicklable_value_only_costs_the_build(folder: Path
                                                                         ) -> None:
    def unreadable() -> list[bytes]:
        return cache.source_files([folder / "missing.py"])

    assert cache.cached("thing", unreadable, lambda: 5) == 5
    assert cache.cached("lambda", lambda: ["a"], lambda: (lambda: 1))() == 1
    assert not folder.exists() or not list(folder.iterdir())


def test_an_empty_setting_turns_the_cache_off(tmp_path: Path,
                                              monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("MCL_CACHE_DIR", "")
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))
    build = Builder(1)
    cache.cached("thing", lambda: ["a"], build)
    cache.cached("thing", lambda: ["a"], build)
    assert build.calls == 2 and cache.folder() is None and not list(tmp_path.iterdir())


def test_the_folder_is_the_users_cache_home(tmp_path: Path,
                                            monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.delenv("MCL_CACHE_DIR", raising=False)
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "xdg"))
    assert cache.folder() == tmp_path / "xdg" / "mcl-auv"
    monkeypatch.delenv("XDG_CACHE_HOME")
    monkeypatch.setenv("HOME", str(tmp_path / "home"))
    assert cache.folder() == tmp_path / "home" / ".cache" / "mcl-auv"


def test_source_files_hold_every_python_file_under_a_folder(tmp_path: Path) -> None:
    (tmp_path / "pkg" / "sub").mkdir(parents=True)
    (tmp_path / "pkg" / "a.py").write_text("A = 1\n", "utf-8")
    (tmp_path / "pkg" / "sub" / "b.py").write_text("B = 2\n", "utf-8")
    (tmp_path / "pkg" / "notes.txt").write_text("not code", "utf-8")
    before = cache.key(cache.source_files([tmp_path / "pkg"]))
    assert b"B = 2\n" in cache.source_files([tmp_path / "pkg"])
    (tmp_path / "pkg" / "sub" / "b.py").write_text("B = 3\n", "utf-8")
    edited = cache.key(cache.source_files([tmp_path / "pkg"]))
    assert edited != before
    os.utime(tmp_path / "pkg" / "a.py", (0, 0))  # a touch without an edit keeps the key
    assert cache.key(cache.source_files([tmp_path / "pkg"])) == edited


def test_an_entry_another_user_owns_is_not_loaded(folder: Path,
                                                  monkeypatch: pytest.MonkeyPatch) -> None:
    build = Builder(1)
    cache.cached("thing", lambda: ["a"], build)
    owner = os.stat(folder).st_uid
    monkeypatch.setattr(os, "getuid", lambda: owner + 1)
    assert cache.cached("thing", lambda: ["a"], build)["call"] == 2  # type: ignore[index]
    monkeypatch.setattr(os, "getuid", lambda: owner)
    assert cache.cached("thing", lambda: ["a"], build)["call"] == 2  # type: ignore[index]


def test_prune_keeps_the_entries_written_last(folder: Path) -> None:
    for i in range(5):
        cache.cached(f"kind-{i}", lambda: ["a"], Builder(i))
        os.utime(next(folder.glob(f"kind-{i}-*.pickle")), ns=(i * 10**9, i * 10**9))
    cache.cached("other", lambda: ["a"], lambda: 0)
    cache.prune("kind-", 2)
    assert sorted(p.name.split("-")[1] for p in folder.glob("kind-*")) == ["3", "4"]
    assert len(list(folder.glob("other-*"))) == 1  # another kind is left
    cache.prune("kind-", 0)
    assert not list(folder.glob("kind-*"))


def test_the_code_digest_changes_with_a_file_and_reads_each_file_once(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    (tmp_path / "pkg").mkdir()
    module = tmp_path / "pkg" / "a.py"
    module.write_text("A = 1\n", "utf-8")
    reads: list[Path] = []
    real = Path.read_bytes

    def read_bytes(self: Path) -> bytes:
        reads.append(self)
        return real(self)

    monkeypatch.setattr(Path, "read_bytes", read_bytes)
    first = cache.code_digest([tmp_path / "pkg"])
    assert cache.code_digest([tmp_path / "pkg"]) == first and reads == [module]
    module.write_text("A = 22\n", "utf-8")
    assert cache.code_digest([tmp_path / "pkg"]) != first and len(reads) == 2
    (tmp_path / "pkg" / "b.py").write_text("", "utf-8")
    assert len({first, cache.code_digest([tmp_path / "pkg"])}) == 2
