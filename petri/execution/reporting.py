"""How the player reports to its observers (petri/execution/player.py): its records, and when
they are told.

A :class:`Record` is one thing the player did. A :class:`Reporting` gives the records to the
player's observers, in order, and keeps two promises:

- *a step is whole*: the records emitted inside a step (a firing, the end) wait for the step's
  end, when its marking, its orders in the outbox and its timers are complete, so that an
  observer reads a settled player;
- *a call is whole*: an observer that raises (a run log on a full disk) stops neither the
  other observers nor the player. The call under way (a method marked :func:`whole`:
  ``start``, ``settle``, ``handle_event``, ``abort``, ...) runs to its end, and then the first
  such exception propagates to the caller; outside a call it propagates at once.
"""

from __future__ import annotations

import functools
from collections import deque
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from typing import Any, Concatenate, ParamSpec, Protocol, TypeVar


@dataclass(frozen=True)
class Record:
    """One thing that happened: kind is "fire", "action", "event", "ignored", "status",
    "note" or "cleanup" (the behaviours the player itself switches off because the net left
    them on, before the disables it sends for them). ``data`` holds the details
    (JSON-ready)."""

    t: float
    kind: str
    data: dict[str, Any]


Observer = Callable[[Record], None]


class Reporting:
    """The player's observers (the very list ``Player.observers``), the records not yet told
    them, the step and the call under way, and the first error an observer raised in it."""

    def __init__(self, observers: list[Observer]) -> None:
        self.observers = observers
        self.untold: deque[Record] = deque()  # records not yet given to the observers
        self.steps = 0  # > 0 inside a step (a firing, the end): records wait for its end
        self.calls = 0  # > 0 inside a call of the player: an observer's error waits for it
        self.failure: Exception | None = None  # the first observer error of the call

    def emit(self, record: Record) -> None:
        """Tell ``record`` now, or at the end of the step under way."""
        self.untold.append(record)
        if not self.steps:
            self.tell()

    @contextmanager
    def step(self) -> Iterator[None]:
        """A step of the player: the records emitted inside wait for its end."""
        self.steps += 1
        try:
            yield
        finally:
            self.end_step()

    def end_step(self) -> None:
        """The end of a step (:meth:`step`, or a ``steps += 1`` written out on a hot path)."""
        self.steps -= 1
        if not self.steps:
            self.tell()

    def tell(self) -> None:
        """Give every waiting record to every observer, in order; keep the first exception
        an observer raises for the end of the call (:func:`whole`)."""
        while self.untold:
            record = self.untold.popleft()
            for observe in self.observers:
                try:
                    observe(record)
                except Exception as exc:  # an observer's failure must not cut the player
                    if self.failure is None:
                        self.failure = exc
        if not self.calls and self.failure is not None:  # outside a call: at once
            failure, self.failure = self.failure, None
            raise failure


class Reported(Protocol):
    """What :func:`whole` needs of the object whose method it wraps."""

    reporting: Reporting


S = TypeVar("S", bound=Reported)
P = ParamSpec("P")
R = TypeVar("R")


def whole(method: Callable[Concatenate[S, P], R]) -> Callable[Concatenate[S, P], R]:
    """A call that runs to its end whatever the observers do: the first exception an
    observer raised during it propagates once it is over (the module's doc). A call's own
    error is the one reported."""
    def call(self: S, /, *args: P.args, **kwargs: P.kwargs) -> R:
        reporting = self.reporting
        reporting.calls += 1
        try:
            result = method(self, *args, **kwargs)
        except BaseException:
            reporting.calls -= 1
            if reporting.calls == 0:
                reporting.failure = None  # the call's own error is the one to report
            raise
        reporting.calls -= 1
        if reporting.calls == 0 and reporting.failure is not None:
            failure, reporting.failure = reporting.failure, None
            raise failure
        return result
    functools.update_wrapper(call, method)  # its name and docstring
    return call
