"""The files a command writes besides its report (``--dot``, ``--pnml``, ``--mcap``, a run's
logs...): each path checked before any work, and every way writing it can fail one line of
invalid input (:class:`OutputError`, exit 2)."""

from __future__ import annotations

import errno
import os
import stat
from collections.abc import Callable
from pathlib import Path

from diagnostics import MclError, Span


class OutputError(MclError):
    """An output file that cannot be written (a directory, a missing folder, no permission):
    invalid input, reported on one line that starts with the file."""

    def __init__(self, path: str, option: str, reason: str):
        where = path or f"{option} ''"
        super().__init__(f"cannot write it ({option}): {reason}", span=Span.of_file(where),
                         hint="give the path of a file in a folder that exists and that "
                              "you may write to", code="unwritable-output")


def write_output(path: str, option: str, write: Callable[[str], None]) -> None:
    """``write(path)``, turning every way writing can fail into an :class:`OutputError`."""
    check_output(path, option)
    try:
        write(path)
    except OSError as exc:
        raise OutputError(path, option, exc.strerror or str(exc)) from None


def unread_pipe(path: Path) -> bool:
    """Whether ``path`` is a named pipe that no process has open to read (opening it to write
    would wait for one for ever); ``/dev/stdout`` into a pipe has its reader."""
    try:
        if not stat.S_ISFIFO(path.stat().st_mode):
            return False
        os.close(os.open(path, os.O_WRONLY | os.O_NONBLOCK))
    except OSError as exc:
        return exc.errno == errno.ENXIO  # the pipe has no reader
    return False


def check_output(path: str, option: str) -> None:
    """Refuse, before any work, an output path that cannot be a file: empty, a directory, in
    a folder that does not exist or is not a folder."""
    if not path:
        raise OutputError(path, option, "an empty path")
    target = Path(path)
    if target.is_dir():
        raise OutputError(path, option, "is a directory")
    if unread_pipe(target):
        raise OutputError(path, option, "a named pipe nobody reads: writing would wait for ever")
    folder = target.parent
    if not folder.exists():
        raise OutputError(path, option, f"no folder {str(folder)!r}")
    if not folder.is_dir():
        raise OutputError(path, option, f"{str(folder)!r} is not a folder")
