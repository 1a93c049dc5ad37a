"""The standard streams of every command, however the process was started.

- :func:`open_standard_streams`: a process started with a standard stream closed (``mcl run
  ... >&-``) has the null device put in its place before anything is opened, so that no file
  the command opens (a run log) takes descriptor 0, 1 or 2 and receives what is printed; it
  says which were closed.
- :func:`watched_stdout`: while a command prints, a write to standard output that fails (a
  closed pipe, a full disk ``>/dev/full``, an I/O error) is raised as :class:`StdoutLost`, a
  :class:`BrokenPipeError`, so that every command's closed-pipe path ends it, and the message
  can say what happened (:func:`lost_line`).
"""

from __future__ import annotations

import errno
import os
import sys
from collections.abc import Iterator
from contextlib import contextmanager
from typing import Any, TextIO

STREAMS = ((0, "stdin", "r"), (1, "stdout", "w"), (2, "stderr", "w"))
_closed_at_start: set[str] = set()  # a fact of the process, as sys.stdout itself is


class StdoutLost(BrokenPipeError):
    """A write to standard output failed: a closed pipe, a full disk, an I/O error (its
    ``errno`` and ``strerror`` say which)."""


def open_standard_streams() -> frozenset[str]:
    """Put the null device in place of each standard stream the process was started without
    (its descriptor closed, or Python's ``sys.stdout`` None); the names of those that were."""
    closed: set[str] = set()
    for fd, name, mode in STREAMS:
        try:
            os.fstat(fd)
        except OSError:
            closed.add(name)
            devnull = os.open(os.devnull, os.O_RDWR)
            if devnull != fd:  # descriptors below fd are open: the lowest free is fd itself
                os.dup2(devnull, fd)
                os.close(devnull)
        if getattr(sys, name) is None:
            closed.add(name)
            setattr(sys, name, open(os.devnull, mode, encoding="utf-8"))  # noqa: SIM115
    _closed_at_start.update(closed)
    return frozenset(closed)


def closed_at_start() -> frozenset[str]:
    """The standard streams the process was started without (:func:`open_standard_streams`
    found them closed)."""
    return frozenset(_closed_at_start)


class _Watched:
    """Standard output whose failed writes raise :class:`StdoutLost` (everything else is the
    stream's own)."""

    def __init__(self, stream: TextIO):
        self.stream = stream

    def write(self, text: str) -> int:
        try:
            return self.stream.write(text)
        except OSError as exc:
            raise lost(exc) from None

    def flush(self) -> None:
        try:
            self.stream.flush()
        except OSError as exc:
            raise lost(exc) from None

    def __getattr__(self, name: str) -> Any:
        return getattr(self.stream, name)


def lost(exc: OSError) -> StdoutLost:
    """``exc``, a failed write to standard output, as a :class:`StdoutLost`."""
    if isinstance(exc, StdoutLost):
        return exc
    code = exc.errno if exc.errno is not None else errno.EPIPE
    return StdoutLost(code, exc.strerror or os.strerror(code))


@contextmanager
def watched_stdout() -> Iterator[None]:
    """While the block runs, a write to standard output that fails raises
    :class:`StdoutLost`."""
    real = sys.stdout
    sys.stdout = _Watched(real)
    try:
        yield
    finally:
        sys.stdout = real


def lost_line(command: str, exc: BrokenPipeError) -> str | None:
    """The one line a command says when standard output could not be written, or None for a
    closed pipe (``| head -1``: the reader has what it wanted, nothing is said)."""
    if exc.errno in (None, errno.EPIPE):
        return None
    return (f"{command}: error: standard output could not be written "
            f"({exc.strerror or os.strerror(exc.errno)}): the output is incomplete")


def stdout_closed() -> None:
    """Standard output was closed or cannot be written: point it at the null device, so that
    nothing more is written and the flush at exit is silent (Python's docs, "Note on
    SIGPIPE")."""
    try:
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
        os.close(devnull)
    except (AttributeError, OSError, ValueError):  # not a real file (tests capture it)
        sys.stdout = open(os.devnull, "w", encoding="utf-8")  # noqa: SIM115
