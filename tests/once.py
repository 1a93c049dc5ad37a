"""A value computed once per test run, shared by pytest-xdist's workers: :class:`Once`
(the ``once`` fixture of tests/conftest.py).

``make test`` runs the suite on two pytest-xdist workers, a test file at a time; a module fixture
is then made once per file, and a run that several files compare against (the dam mission in
process, say) once per file that needs it. ``Once`` makes it once per *run*: the first worker to
ask computes it and leaves it, pickled, in the run's shared temporary folder; a worker that asks
meanwhile waits for it, and every later one reads it.
"""

from __future__ import annotations

import fcntl
import pickle
from collections.abc import Callable
from pathlib import Path
from typing import Any, TypeVar

T = TypeVar("T")


class Once:
    """Values by name, each computed once per test run by ``make(folder)`` (``folder``: a
    directory of its own, kept for the run, for the files it writes) and shared by the workers.
    A ``make`` that raises leaves nothing: the next caller computes it again (and fails again)."""

    def __init__(self, root: Path) -> None:
        self.root = root
        self.made: dict[str, Any] = {}  # this worker's, unpickled once

    def __call__(self, name: str, make: Callable[[Path], T]) -> T:
        if name in self.made:
            value: T = self.made[name]
            return value
        folder = self.root / name.replace(" ", "_").replace("/", "_")
        folder.mkdir(parents=True, exist_ok=True)
        kept = folder / "value.pickle"
        with open(folder / "lock", "a") as lock:
            fcntl.flock(lock, fcntl.LOCK_EX)  # released when the file is closed
            if kept.exists():
                value = pickle.loads(kept.read_bytes())
            else:
                value = make(folder)
                kept.with_suffix(".part").write_bytes(pickle.dumps(value))
                kept.with_suffix(".part").rename(kept)
        self.made[name] = value
        return value
