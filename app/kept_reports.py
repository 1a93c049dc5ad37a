"""The reports ``mclc`` keeps between calls: a call whose inputs are those of a call before
prints what that call printed, without compiling or verifying anything (what a linter does
with a file that has not changed since it last looked).

A report is kept for a call on one mission file (``.mcl``, not a fleet) that writes no file
(no ``--dot``, ``--dot-tasks``, ``--pnml``, ``--net-json`` or ``--graphml``), in text or JSON,
once its verdict came from the verdict cache (mcl/analysis/verdicts.py): what that call printed
(its standard output, its standard error and its exit status) is what every later call with
the same inputs prints, so a report replayed says ``cached`` as the verdict it shows was. Its
key (mcl/cache.py) is every input of the report: the command (``mclc``, ``mcl check``), its
arguments and the working folder, the contents of the mission file and of each ``--tasks``
and ``--params`` file, the shipped task libraries, the sources of the packages that make the
report (``app``, ``mission``, ``mcl``, ``petri``, ``aal``, ``diagnostics``), ``MCL_DOCS_URI``
and Python's version. A mission that names its libraries (``USES``) is not kept: which files
it reads is known only once parsed. One report is kept per mission file and arguments, for
the :data:`KEEP` calls kept last.
"""

from __future__ import annotations

import argparse
import io
import os
import sys
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any, TextIO

from mcl import cache

FORMAT = "report 1"  # bump when what is kept changes
KEEP = 500
REPORT_CODE = tuple(Path(__file__).resolve().parents[1] / name
                    for name in ("app", "mission", "mcl", "petri", "aal", "diagnostics"))
SHIPPED_TASKS = Path(__file__).resolve().parents[1] / "mcl" / "tasks"
FILE_OPTIONS = ("dot", "dot_tasks", "pnml", "net_json", "graphml")


def kept_key(args: argparse.Namespace, argv: list[str], fmt: str, prog: str = "mclc"
             ) -> tuple[str, list[str | bytes]] | None:
    """The entry's name and the parts of its key, for a call whose report may be kept; None
    for one whose may not (see the module's docstring)."""
    if cache.folder() is None or len(args.files) != 1 or fmt not in ("text", "json") or any(
            getattr(args, option, None) is not None for option in FILE_OPTIONS):
        return None
    path = args.files[0]
    if not path.endswith(".mcl"):
        return None
    files = [path, *args.tasks, *args.params]
    try:
        if not all(os.path.isfile(f) for f in files):  # a pipe is read once: by the check
            return None
        text, *inputs = [Path(f).read_bytes() for f in files]
    except OSError:
        return None
    if b"FLEET" in text or b"USES" in text:  # a fleet, or libraries of its own
        return None
    shipped = sorted(SHIPPED_TASKS.glob("*.tasks"))
    parts: list[str | bytes] = [FORMAT, prog, repr(argv), os.getcwd(), text, *inputs,
                                *[p.read_bytes() for p in shipped],
                                os.environ.get("MCL_DOCS_URI", ""),
                                cache.code_digest(REPORT_CODE)]
    where = cache.SHA256(f"{os.path.abspath(path)}\0{repr(argv)}".encode()).hexdigest()[:16]
    return f"report-{where}", parts


def replay(name: str, parts: list[str | bytes]) -> int | None:
    """Print the report kept under this key and return its exit status; None when there is
    none."""
    kept = cache.lookup(name, parts)
    if not (isinstance(kept, tuple) and len(kept) == 3):
        return None
    out, err, status = kept
    sys.stderr.write(err)
    sys.stdout.write(out)
    sys.stdout.flush()
    return int(status)


def keep(name: str, parts: list[str | bytes], out: str, err: str, status: int) -> None:
    """Keep what a call printed under its key."""
    cache.put(name, parts, (out, err, int(status)))
    cache.prune("report-", KEEP)


class Recorded:
    """A standard stream that keeps a copy of what is written to it."""

    def __init__(self, stream: TextIO):
        self.stream = stream
        self.copy = io.StringIO()

    def write(self, text: str) -> int:
        self.copy.write(text)
        return self.stream.write(text)

    def __getattr__(self, name: str) -> Any:
        return getattr(self.stream, name)


@contextmanager
def recorded(active: bool = True) -> Iterator[tuple[Recorded, Recorded]]:
    """While the block runs, what is written to standard output and error is kept too (when
    ``active``: else nothing is, and the copies stay empty)."""
    out, err = Recorded(sys.stdout), Recorded(sys.stderr)
    if not active:
        yield out, err
        return
    real_out, real_err = sys.stdout, sys.stderr
    sys.stdout, sys.stderr = out, err
    try:
        yield out, err
    finally:
        sys.stdout, sys.stderr = real_out, real_err
