"""The cache of what mclc would otherwise rebuild on every call from inputs that do not change
between calls: the parsers of the two grammars (lark's tables, built from ``mcl/grammar/*.lark``)
and the shipped task libraries (parsed and checked from ``mcl/tasks/*.tasks``).

Each entry is one file in the user's cache folder, named by what it is and by the SHA-256 of
everything it is built from, its *key*: for a parser, the grammar's text, lark's options, lark's
version and Python's; for a library, the libraries' texts, the grammar's, lark's version and
the source of the code that builds it (the ``mcl`` and ``diagnostics`` packages and
``petri/net.py``). A key of contents is finer than the project's version: an edit of the
grammar or of the code in a checkout changes it with no release, and a release that changes
neither keeps it. So a cache never gives a wrong answer: what it holds for a key is what
building from that key's inputs gives.

The folder is ``$MCL_CACHE_DIR`` when set (set to the empty string: no cache), else
``$XDG_CACHE_HOME/mcl-auv``, else ``~/.cache/mcl-auv``. A folder that cannot be made, a file
that cannot be read or is not a whole entry (another process writing it, a disk error), a
file that cannot be written, an entry another user owns (an entry is a pickle: loading it runs
what it says): each is ignored without a word, and the thing is built as if there were no
cache. Entries are written whole or not at all (a file of the process's own, renamed
over the entry), and writing one removes the entries of the same name under other keys.
"""

from __future__ import annotations

import importlib
import marshal
import os
import pickle
import sys
from collections.abc import Callable, Iterable
from pathlib import Path
from typing import IO, Any, TypeVar

T = TypeVar("T")


def builtin_sha256() -> Callable[[bytes], Any]:
    """SHA-256 from Python's own module (``_sha2``, ``_sha256`` before 3.12) when there is one:
    hashlib's takes OpenSSL's, and loading OpenSSL costs 4 ms of every call."""
    for module in ("_sha2", "_sha256", "hashlib"):
        try:
            found: Callable[[bytes], Any] = importlib.import_module(module).sha256
        except (ImportError, AttributeError):
            continue
        return found
    raise ImportError("no SHA-256 in this Python")


SHA256 = builtin_sha256()

FORMAT = b"mcl-cache 1"  # bump when the layout of an entry changes
FOLDER = "mcl-auv"  # the folder under the user's cache home


def folder() -> Path | None:
    """The cache folder (see the module's docstring), or None when the cache is off."""
    chosen = os.environ.get("MCL_CACHE_DIR")
    if chosen is not None:
        return Path(chosen) if chosen else None
    home = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    return Path(home) / FOLDER


def key(parts: Iterable[str | bytes]) -> str:
    """The SHA-256 (hex) of the parts, each length-prefixed (no two lists of parts share a
    key by running together), with the entries' format and Python's version."""
    digest = SHA256(FORMAT)
    for part in (sys.version.encode(), *parts):
        data = part.encode("utf-8") if isinstance(part, str) else part
        digest.update(len(data).to_bytes(8, "little"))
        digest.update(data)
    return str(digest.hexdigest())


def source_files(roots: Iterable[Path]) -> list[bytes]:
    """The contents of the Python files at ``roots`` (a file, or every ``*.py`` under a
    folder), in a fixed order with their names: the code part of a key."""
    found: list[Path] = []
    for root in roots:
        found += sorted(root.rglob("*.py")) if root.is_dir() else [root]
    return [part for path in found for part in (path.name.encode(), path.read_bytes())]


def code_digest(roots: Iterable[Path]) -> str:
    """The SHA-256 (hex) of the Python files at ``roots`` (a file, or every ``*.py`` under a
    folder, sorted), names and contents: the code part of a key. Each file's content is
    hashed once while its size and modification time stay the same: within a process (the
    keys of one call share most of their code: 0.7 MB read once instead of three times), and
    from one call to the next by :data:`DIGESTS`, an entry of the cache (reading and hashing
    the code cost 5 ms of every mclc)."""
    digest = SHA256(b"code")
    for root in roots:
        for path in python_paths(root):
            digest.update(os.path.basename(path).encode() + b"\0" + file_digest(path))
    save_digests()
    return str(digest.hexdigest())


def python_paths(root: Path) -> list[str]:
    """``root`` if it is a file, else every ``*.py`` under it, sorted (os.walk: a third of
    what Path.rglob costs; strings: a half of what the Path of each of mclc's 370 files
    cost)."""
    if not root.is_dir():
        return [str(root)]
    found: list[str] = []
    for folder_path, folders, names in os.walk(root):
        folders[:] = [f for f in folders if f != "__pycache__"]
        found += [os.path.join(folder_path, n) for n in names if n.endswith(".py")]
    return sorted(found)


FILE_DIGESTS: dict[tuple[str, int, int], bytes] = {}  # (path, mtime, size) -> SHA-256
DIGESTS = "file-digests.marshal"  # FILE_DIGESTS kept in the cache folder between calls
DIGESTS_STATE = {"loaded": False, "changed": False}


def file_digest(path: Path | str) -> bytes:
    """The SHA-256 of a file's content, from :data:`FILE_DIGESTS` while it is unchanged."""
    if not DIGESTS_STATE["loaded"]:
        load_digests()
    name = os.fspath(path)
    stat = os.stat(name)
    known = (name if os.path.isabs(name) else os.path.join(os.getcwd(), name),
             stat.st_mtime_ns, stat.st_size)
    found = FILE_DIGESTS.get(known)
    if found is None:
        found = FILE_DIGESTS[known] = bytes(SHA256(Path(name).read_bytes()).digest())
        DIGESTS_STATE["changed"] = True
    return found


def load_digests() -> None:
    """Add the digests kept in the cache folder to :data:`FILE_DIGESTS` (none when the cache
    is off, or the entry is missing, damaged or another user's)."""
    DIGESTS_STATE["loaded"] = True
    place = folder()
    if place is None:
        return
    try:
        with open(place / DIGESTS, "rb") as f:
            kept = marshal.loads(f.read()) if mine(f.fileno()) else {}
        if isinstance(kept, dict):
            FILE_DIGESTS.update((k, v) for k, v in kept.items() if k not in FILE_DIGESTS
                                and isinstance(k, tuple) and isinstance(v, bytes))
    except Exception:  # noqa: BLE001 - absent, unreadable or partial: hash the files
        pass


def save_digests() -> None:
    """Keep :data:`FILE_DIGESTS` in the cache folder if it gained a digest: the latest of
    each file only, written whole or not at all."""
    place = folder()
    if place is None or not DIGESTS_STATE["changed"]:
        return
    DIGESTS_STATE["changed"] = False
    latest: dict[str, tuple[str, int, int]] = {}
    for known in FILE_DIGESTS:
        if known[0] not in latest or known[1:] > latest[known[0]][1:]:
            latest[known[0]] = known
    kept = {known: FILE_DIGESTS[known] for known in latest.values()}
    store(place / DIGESTS, DIGESTS, kept, lambda value, f: marshal.dump(value, f))


def cached(name: str, parts: Callable[[], Iterable[str | bytes]], build: Callable[[], T],
           save: Callable[[T, IO[bytes]], None] | None = None,
           load: Callable[[IO[bytes]], T] | None = None) -> T:
    """What ``build()`` returns, from the entry ``name`` under the key of ``parts()`` when
    there is one, else built and stored there. ``save`` and ``load`` write and read the
    object (default: pickle). Every failure of the cache falls back to ``build()``."""
    place = folder()
    if place is None:
        return build()
    try:
        path = place / f"{name}-{key(parts())}.pickle"
    except (OSError, ValueError, TypeError, AttributeError, RecursionError,
            pickle.PicklingError):
        return build()  # an input cannot be read (or serialised, for a key): no key, no cache
    try:
        with open(path, "rb") as f:
            if mine(f.fileno()):
                return load(f) if load is not None else pickle.load(f)
    except Exception:  # noqa: BLE001 - absent, unreadable or partial: build it instead
        pass
    value = build()
    store(path, name, value, save)
    return value


def lookup(name: str, parts: Iterable[str | bytes]) -> Any:
    """What is kept under the entry ``name`` and the key of ``parts`` (:func:`put`), or None
    (none, unreadable, another user's, or the cache off)."""
    place = folder()
    if place is None:
        return None
    try:
        with open(place / f"{name}-{key(parts)}.pickle", "rb") as f:
            return pickle.load(f) if mine(f.fileno()) else None
    except Exception:  # noqa: BLE001 - absent, unreadable or partial: nothing kept
        return None


def put(name: str, parts: Iterable[str | bytes], value: Any) -> None:
    """Keep ``value`` under the entry ``name`` and the key of ``parts``, replacing the entry
    of the same name under another key (any failure keeps nothing)."""
    place = folder()
    if place is not None:
        store(place / f"{name}-{key(parts)}.pickle", name, value, None)


def prune(prefix: str, keep: int) -> None:
    """Remove all but the ``keep`` most recently written entries whose names start with
    ``prefix``: the kinds kept per file (syntax trees, verdicts) would otherwise grow with every
    file ever checked (a test suite's temporary files). Any failure leaves them."""
    place = folder()
    if place is None:
        return
    try:
        with os.scandir(place) as listing:  # names only: a stat each only when over
            named = [e.name for e in listing
                     if e.name.startswith(prefix) and e.name.endswith(".pickle")]
        if len(named) <= keep:
            return
        entries = sorted((place / n for n in named), key=lambda p: p.stat().st_mtime_ns)
        for old in entries[:-keep] if keep > 0 else entries:
            old.unlink(missing_ok=True)
    except OSError:  # another process removed one first, or the folder is unreadable
        pass


def mine(fd: int) -> bool:
    """Whether the open entry belongs to this user: an entry is a pickle, and loading one runs
    what it says, so one that another user could have put in a shared folder is not read."""
    getuid = getattr(os, "getuid", None)  # POSIX; elsewhere the folder is the user's own
    return getuid is None or os.fstat(fd).st_uid == getuid()


def store(path: Path, name: str, value: Any, save: Callable[[Any, IO[bytes]], None] | None
          ) -> None:
    """Write the entry whole (a file of this process's own, renamed over it), then remove the
    entries of ``name`` under other keys; any failure leaves the cache as it was."""
    partial = path.with_name(f"{path.name}.{os.getpid()}.partial")
    try:
        path.parent.mkdir(mode=0o700, parents=True, exist_ok=True)
        with open(partial, "wb") as f:
            if save is not None:
                save(value, f)
            else:
                pickle.dump(value, f, protocol=pickle.HIGHEST_PROTOCOL)
        os.replace(partial, path)
        with os.scandir(path.parent) as listing:  # names only (glob: 3 ms of a full folder)
            older = [e.name for e in listing if e.name.startswith(f"{name}-")
                     and e.name.endswith(".pickle") and e.name != path.name]
        for old in older:
            (path.parent / old).unlink(missing_ok=True)
    except Exception:  # noqa: BLE001 - unwritable, full, or not picklable: no entry
        try:
            partial.unlink(missing_ok=True)
        except OSError:
            pass
