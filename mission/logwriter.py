"""The run log as a run writes it, so that a log that cannot be written stops the run safely.

:class:`LogWriter` stands between the player and its :class:`~petri.execution.runlog.RunLog`:

- a write that fails (a full disk, an I/O error) or a log file removed or replaced during the
  run (its folder deleted) is kept as the run's :attr:`~LogWriter.failure`; nothing more is
  written, and :meth:`~LogWriter.stop` asks the runner to stop the mission through its abort
  (``how: "log failed"``, exit 4), so that everything is switched off and confirmed;
- the vehicle's poses, when the run keeps them (:class:`mission.poses.PoseLog`), go in just
  before the first record at or after their time, so that the log's time never goes back;
- the end record that cannot be written is kept (:attr:`~LogWriter.unwritten`), for the caller
  to put where it still can (``mcl run`` prints it on standard error: its stand-in).

A log whose header cannot be written is :class:`LogUnwritable`: the mission never started.
"""

from __future__ import annotations

import math
import os
import time
from pathlib import Path
from typing import Any

from diagnostics import MclError, Span
from petri.execution.player import Record
from petri.execution.runlog import END, RunLog

from mission.poses import PoseLog


LOOK_EVERY = 0.02  # s of wall time: how often stop looks whether the log file is still there


class LogUnwritable(MclError):
    """The run log's header could not be written (``--log /dev/full``, ``/proc/version``):
    the mission never started and nothing was sent."""

    def __init__(self, path: str | Path, exc: OSError):
        reason = exc.strerror or str(exc)
        message = f"cannot write the run log ({reason}): the mission never started"
        super().__init__(message, span=Span.of_file(str(path)),
                         hint="give --log a file on a disk with room, that you may write to",
                         code="unwritable-log", text=f"{path}: {message}")


def identity(path: Path) -> tuple[int, int] | None:
    """The file at ``path`` (its device and inode), or None if there is none."""
    try:
        st = os.stat(path)
    except OSError:
        return None
    return (st.st_dev, st.st_ino)


class LogWriter:
    """An observer of the player that writes each record to the run log and, if the log
    cannot be written, remembers why instead of raising (the runner then stops the run)."""

    def __init__(self, log: RunLog, poses: PoseLog | None = None):
        self.log = log
        self.poses = poses  # the vehicle's poses still to log (None: the run keeps none)
        self.path = log.path
        self.file = identity(log.path)  # what a record is written to; a regular file only
        self.failure = ""  # why the log could not be written (the first failure)
        self.unwritten: dict[str, Any] | None = None  # the end record the log did not take
        self.looked = -math.inf  # when stop last looked at the file (time.monotonic)

    def __call__(self, record: Record) -> None:
        self.poses_until(record.t)
        self.write(lambda: self.log(record))

    def poses_until(self, t: float) -> None:
        """Log the vehicle's poses up to mission time ``t`` (before a record at ``t``)."""
        if self.poses is not None and not self.failure:
            for pose in self.poses.until(t):
                self.write(lambda p=pose: self.log.pose(**p))

    def write(self, writing: Any) -> None:
        if self.failure:
            return
        try:
            writing()
        except OSError as exc:
            self.failure = f"the run log could not be written ({exc.strerror or exc})"
            return
        self.still_there()

    def still_there(self) -> None:
        """Keep as the failure a log file that was removed or replaced (its folder deleted)."""
        if not self.failure and self.file is not None and identity(self.path) != self.file:
            self.failure = (f"the run log {self.path} was removed or replaced during the run "
                            "(its folder deleted?)")

    def stop(self) -> str | None:
        """Why the run must stop now (its log cannot be written, or is gone), or None; asked
        every round, so that a log removed while nothing happens is noticed too: within
        :data:`LOOK_EVERY` s of wall time (a look at the file every round was 2 % of the dam
        mission's simulated run: 24,000 rounds)."""
        now = time.monotonic()
        if now - self.looked >= LOOK_EVERY:
            self.looked = now
            self.still_there()
        return f"{self.failure}: the run was stopped" if self.failure else None

    def progress(self, t: float, report: dict[str, Any]) -> None:
        """Log how far along a running task is at ``t`` (mission/progress.py)."""
        self.poses_until(t)
        self.write(lambda: self.log.progress(t, **report))

    def end(self, t: float, how: str, why: str = "", **more: Any) -> None:
        """Write the end record; kept in :attr:`unwritten` if the log cannot take it."""
        self.poses_until(t)
        self.write(lambda: self.log.end(t, how, why, **more))
        if self.failure:
            self.unwritten = {"t": round(t, 6), "kind": END, "how": how, "why": why, **more}
