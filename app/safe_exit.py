"""What ``mcl run`` adds to a run, as a process, so that it ends safely however it is stopped.

- :class:`Stops`: SIGINT, SIGTERM and SIGHUP ask the runner to abort the mission (through the
  net, :meth:`petri.execution.player.Player.abort`) instead of killing the process mid-mission.
  Signal handlers belong to the process (and to its main thread only), so they live here, not
  in :func:`mission.run_mission`, which takes the stop request they make.
  Once the run has ended, a signal cuts its report short (:class:`ReportCut`) and the exit
  status stays the end record's.
- :class:`Output`: the timeline and the summary on standard output; a closed standard output
  (``mcl run ... | head -1``) never raises: the run goes on, its safety path untouched, and the
  rest of what it prints is dropped.

The time bound and the capability check are the library's: ``mission/limits.py`` and
``mission/capabilities.py``.
"""

from __future__ import annotations

import signal
import sys
from types import FrameType
from typing import Any
from errno import EPIPE

from mission.run import Stop

from app.streams import closed_at_start, stdout_closed


class ReportCut(BaseException):
    """A stop signal that came once the run had ended and its end record was written: it cuts
    the report after the run short (the mosaic, the plots), and the exit status stays the one
    the end record says. A BaseException, as KeyboardInterrupt is: no ``except Exception``
    of a report swallows it."""

    def __init__(self, signum: int):
        super().__init__(signum)
        self.signum = signum

    def line(self) -> str:
        return (f"mcl run: {signal.Signals(self.signum).name} received after the run ended: "
                "its report was cut short (the run log's end record stands)")


class Stops:
    """Signal handlers that record the first stop signal and count them (a context manager):
    the first stops the mission (its stop handler, if it has one, then runs); the next halts
    the stop handler. Left, they stay in place until :meth:`restore`: a signal then raises
    :class:`ReportCut` (the run has ended; what is left is its report), so that the process
    never dies by a signal with an end record that says otherwise."""

    def __init__(self, names: tuple[str, ...] = ("SIGINT", "SIGTERM", "SIGHUP")):
        self.signals = [getattr(signal, n) for n in names if hasattr(signal, n)]
        self.signal: int | None = None
        self.count = 0  # the stop signals received
        self.ended = False
        self._previous: dict[int, Any] = {}

    def _handle(self, signum: int, frame: FrameType | None) -> None:
        if self.ended:
            raise ReportCut(signum)
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
        self.ended = True

    def restore(self) -> None:
        """The handlers there were before."""
        for s, handler in self._previous.items():
            signal.signal(s, handler)
        self._previous.clear()


class Output:
    """Printing that never raises: the first failed write (a closed pipe, a full disk) closes
    it for good (standard output is pointed at the null device so that the exit flush is
    silent too); a standard output the process was started without is closed from the
    start."""

    def __init__(self) -> None:
        self.closed = "stdout" in closed_at_start()
        self.why = "standard output was closed (nothing was printed)" if self.closed else ""

    def say(self, text: str) -> None:
        if self.closed:
            return
        try:
            sys.stdout.write(text + "\n")
            sys.stdout.flush()
        except (OSError, ValueError) as exc:  # BrokenPipeError, ENOSPC, EIO, a closed file
            self.closed = True
            self.why = ("standard output was closed during the run (the timeline stopped)"
                        if isinstance(exc, BrokenPipeError) and exc.errno in (None, EPIPE)
                        else "standard output could not be written during the run ("
                        + (getattr(exc, "strerror", None) or str(exc)) + "; the timeline "
                        "stopped)")
            stdout_closed()

    def note(self) -> str | None:
        """What the run's end record adds when standard output was closed or could not be
        written."""
        return self.why or None
