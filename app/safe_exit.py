"""What ``mcl run`` needs to end every run safely and to refuse what a vehicle cannot run.

- :class:`Stops`: SIGINT, SIGTERM and SIGHUP ask the runner to abort the mission (through the
  net, :meth:`petri.execution.player.Player.abort`) instead of killing the process mid-mission.
- :class:`Output`: the timeline and the summary on standard output; a closed standard output
  (``mcl run ... | head -1``) never raises: the run goes on, its safety path untouched, and the
  rest of what it prints is dropped.
- :func:`max_time`: the default ``--max-time``, derived from the mission's timeouts.
- :func:`check_capabilities`: before the first action, every behaviour and event the mission's
  tasks need must be declared by the vehicle (its declaration, in the task library's form).
"""

from __future__ import annotations

import math
import os
import signal
import sys
from types import FrameType
from typing import Any

from aal.messages import Declaration
from diagnostics import Diagnostic, MclError, Source, file_error
from mcl import ast, tasklib
from mcl.api import Compiled

UNBOUNDED = 7200.0  # s: the default limit of a mission its timeouts do not bound
MARGIN, SLACK = 0.10, 60.0  # the default limit: the bound + 10 % + 60 s


class Stops:
    """Signal handlers that record the first stop signal (a context manager)."""

    def __init__(self, names: tuple[str, ...] = ("SIGINT", "SIGTERM", "SIGHUP")):
        self.signals = [getattr(signal, n) for n in names if hasattr(signal, n)]
        self.signal: int | None = None
        self._previous: dict[int, Any] = {}

    def _handle(self, signum: int, frame: FrameType | None) -> None:
        if self.signal is None:
            self.signal = signum

    def reason(self) -> str | None:
        if self.signal is None:
            return None
        return f"{signal.Signals(self.signal).name} received: the run was stopped"

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


def max_time(compiled: Compiled, given: float | None) -> tuple[float, str]:
    """The mission time limit and where it comes from."""
    if given is not None:
        if not math.isfinite(given) or given <= 0:
            raise file_error("--max-time", f"--max-time {given:g}: must be a positive number "
                             "of seconds", "e.g. --max-time 3600")
        return given, "--max-time"
    bound = mission_bound(compiled)
    if bound is None:
        return UNBOUNDED, (f"default: the mission's timeouts do not bound it, so "
                           f"{UNBOUNDED:g} s")
    limit = round(bound * (1 + MARGIN) + SLACK, 3)
    return limit, f"default: its timeouts bound it to {bound:g} s, + 10 % + {SLACK:g} s"


def mission_bound(compiled: Compiled) -> float | None:
    """The longest the mission can last, proved from its timeouts (mcl/analysis/duration.py; None:
    they do not bound it)."""
    from mcl.analysis.duration import analyse

    worst = analyse(compiled.checked).worst
    return worst if math.isfinite(worst) else None


def declared_behaviours(declaration: Declaration) -> tasklib.Library:
    """The vehicle's declaration, parsed by the task library's own parser."""
    return tasklib.load_sources([Source(declaration.source, declaration.text)])


def check_capabilities(compiled: Compiled, declaration: Declaration) -> None:
    """MclError (exit 2) naming each task call that needs a behaviour or an event the
    vehicle does not declare, at the call's ``file:line:col``."""
    library = declared_behaviours(declaration)
    have = library.behaviours
    takes = _parameters(library)
    problems: list[Diagnostic] = []
    seen: set[tuple[int, int, str]] = set()
    listing = ", ".join(sorted(have)) or "none"
    for call in ast.calls(compiled.mission.body):
        resolved = compiled.checked.calls.get(id(call))
        if resolved is None:
            continue
        form = resolved.form
        needed = [a.behaviour for a in form.start + form.stop]
        needed += [b for b in (form.latch, form.unlatch) if b]
        events = [e for e in form.ok + form.fail
                  if e.partition(".")[0] not in tasklib.BUILTIN_SOURCES]
        for behaviour in dict.fromkeys(needed + [e.partition(".")[0] for e in events]):
            key = (call.span.line, call.span.col, behaviour)
            if behaviour not in have and key not in seen:
                seen.add(key)
                problems.append(compiled.source.diagnostic(
                    "error", f"{call.name} needs behaviour {behaviour}, which vehicle "
                    f"{declaration.vehicle} does not have", call.span,
                    f"the vehicle declares ({declaration.source}): {listing}; run the mission "
                    "on a vehicle that has it", "vehicle-lacks-behaviour"))
        for action in form.start + form.stop:
            given = {k for k, _ in action.bindings}
            allowed = takes.get(action.behaviour)
            extra = sorted(given - allowed) if allowed is not None else []
            key = (call.span.line, call.span.col, f"{action.behaviour}({extra})")
            if extra and key not in seen:
                seen.add(key)
                problems.append(compiled.source.diagnostic(
                    "error", f"{call.name} gives {action.behaviour} the parameter(s) "
                    f"{', '.join(extra)}, which vehicle {declaration.vehicle} does not take",
                    call.span, f"its {action.behaviour} takes: "
                    f"{', '.join(sorted(allowed or ())) or 'no parameters'} "
                    f"({declaration.source})", "vehicle-lacks-parameter"))
        for event in events:
            behaviour, _, name = event.partition(".")
            key = (call.span.line, call.span.col, event)
            if behaviour in have and name not in have[behaviour].events and key not in seen:
                seen.add(key)
                problems.append(compiled.source.diagnostic(
                    "error", f"{call.name} waits for {event}, which vehicle "
                    f"{declaration.vehicle} never raises", call.span,
                    f"its {behaviour} raises: {', '.join(have[behaviour].events) or 'nothing'}"
                    f" ({declaration.source})", "vehicle-lacks-event"))
    if problems:
        raise MclError(problems)


def _parameters(library: tasklib.Library) -> dict[str, set[str]]:
    """The parameters each behaviour takes, as the declaring library's own actions give
    them (a behaviour no action of it enables: not declared, not checked)."""
    takes: dict[str, set[str]] = {}
    for forms in library.tasks.values():
        for form in forms:
            for action in form.start + form.stop:
                if action.kind in ("enable", "configure"):
                    takes.setdefault(action.behaviour, set()).update(
                        k for k, _ in action.bindings)
    return takes
