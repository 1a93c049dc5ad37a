"""What ``mcl run`` adds to a run, as a process, so that it ends safely however it is stopped.

- :class:`Stops`: SIGINT, SIGTERM and SIGHUP ask the runner to abort the mission (through the
  net, :meth:`petri.execution.player.Player.abort`) instead of killing the process mid-mission.
  Signal handlers belong to the process (and to its main thread only), so they live here, not
  in :func:`mission.run_mission`, which takes the stop request they make.
- :class:`Output`: the timeline and the summary on standard output; a closed standard output
  (``mcl run ... | head -1``) never raises: the run goes on, its safety path untouched, and the
  rest of what it prints is dropped.

The time bound and the capability check are the library's: ``mission/limits.py`` and
``mission/capabilities.py``.
"""

from __future__ import annotations

import os
import signal
import sys
from types import FrameType
from typing import Any

from mission.run import Stop


class Stops:
    """Signal handlers that record the first stop signal and count them (a context manager):
    the first stops the mission (its stop handler, if it has one, then runs); the next halts
    the stop handler."""

    def __init__(self, names: tuple[str, ...] = ("SIGINT", "SIGTERM", "SIGHUP")):
        self.signals = [getattr(signal, n) for n in names if hasattr(signal, n)]
        self.signal: int | None = None
        self.count = 0  # the stop signals received
        self._previous: dict[int, Any] = {}

    def _handle(self, signum: int, frame: FrameType | None) -> None:
        if self.signal is None:
            self.signal = signum
        self.count += 1

    def reason(self) -> str | None:
        if self.signal is None:
            return None
        return f"{signal.Signals(self.signal).name} received: the run was stopped"

    def request(self) -> Stop | None:
        """The stop a signal asked for (its reason and number), or None: ``run_mission``'s
        ``stop``."""
        why = self.reason()
        if why is None:
            return None
        if self.count > 1:
            why = f"{why} (and {self.count - 1} more stop signal(s))"
        return Stop(why, self.signal, self.count)

    def __enter__(self) -> Stops:
        for s in self.signals:
            self._previous[s] = signal.signal(s, self._handle)
        return self

    def __exit__(self, *exc: object) -> None:
        for s, handler in self._previous.items():
            signal.signal(s, handler)


class Output:
    """Printing that never raises: the first failed write (a closed pipe) closes it for good
    (standard output is pointed at the null device so that the exit flush is silent too)."""

    def __init__(self) -> None:
        self.closed = False

    def say(self, text: str) -> None:
        if self.closed:
            return
        try:
            sys.stdout.write(text + "\n")
            sys.stdout.flush()
        except (OSError, ValueError):  # BrokenPipeError, EPIPE, a closed file
            self.closed = True
            try:
                devnull = os.open(os.devnull, os.O_WRONLY)
                os.dup2(devnull, sys.stdout.fileno())
                os.close(devnull)
            except (OSError, ValueError):
                pass

    def note(self) -> str | None:
        """What the run's end record adds when standard output was closed during the run."""
        if self.closed:
            return "standard output was closed during the run (the timeline stopped)"
        return None
