"""The capability check: is a mission within what a vehicle declares it can do?

A vehicle declares its behaviours, their events and the parameters they take in the task
library's own form (:class:`aal.messages.Declaration`, written by
:mod:`behaviours.capabilities`). Before the first action, every behaviour and event the
mission's tasks need, and every parameter they give, must be declared;
:func:`check_capabilities` names each task call that needs more, at its ``file:line:col``.
"""

from __future__ import annotations

import hashlib
from collections.abc import Collection

from aal.messages import Declaration
from diagnostics import Diagnostic, MclError, Source
from mcl import tasklib
from mcl.api import Compiled


def declared_behaviours(declaration: Declaration) -> tasklib.Library:
    """The vehicle's declaration, parsed by the task library's own parser; kept in the cache
    as the shipped libraries are (:func:`mcl.tasklib.cached_library`), one entry for each
    declaration's text: a run checks it before connecting and again after, and parsing it
    (with lark's import) took about 0.1 s of a dam run's start."""
    text = hashlib.sha256(declaration.text.encode("utf-8")).hexdigest()[:16]
    return tasklib.cached_library(f"declaration-{text}",
                                  [Source(declaration.source, declaration.text)])


def check_capabilities(compiled: Compiled, declaration: Declaration,
                       channels: Collection[str] = ()) -> None:
    """MclError (exit 2) naming each task call that needs a behaviour or an event the
    vehicle does not declare, at the call's ``file:line:col``. ``channels``: a fleet's
    channels, which carry Send and Receive, not the vehicle (mission/fleet.py)."""
    library = declared_behaviours(declaration)
    have = library.behaviours
    takes = parameters_taken(library)
    problems: list[Diagnostic] = []
    seen: set[tuple[int, int, str]] = set()
    listing = ", ".join(sorted(have)) or "none"
    for call in compiled.mission.calls():
        resolved = compiled.checked.calls.get(id(call))
        if resolved is None:
            continue
        form = resolved.form
        needed = [a.behaviour for a in form.start + form.stop]
        needed += [b for b in (form.latch, form.unlatch) if b]
        needed = [b for b in needed if b not in channels]
        events = [e for e in form.ok + form.fail
                  if e.partition(".")[0] not in (*tasklib.BUILTIN_SOURCES, *channels)]
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


def parameters_taken(library: tasklib.Library) -> dict[str, set[str]]:
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
