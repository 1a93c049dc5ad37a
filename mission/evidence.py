"""What a run log claims that only the mission knows how to check (``mcl replay``): the
header's fields, the exit status its end record gives for how the run ended, its time limit,
and the events the mission's CATCH blocks handled.

The firings, the actions, the marking an end record claims and the vehicle's clock are the
net's to check (``petri/execution/replay.py``); the chain and the signatures the log's
(``petri/execution/runlog.py``). Each check here returns why the log does not conform (the
header's problems are named at line 1, the end record's at its line), or None.
"""

from __future__ import annotations

import math
import re
from collections.abc import Callable
from typing import Any

from mcl.api import Compiled
from mcl.templates.mission import HALT, STOP_FAIL, STOP_OK, STOP_START
from petri.execution.player import Record

from mission.exits import SIGNAL_BASE, Exit
from mission.handled import CatchWatch
from mission.poses import is_scene

# how an end record says the run ended -> the exit statuses it may go with (mission/run.py)
HOW_EXITS: dict[str, frozenset[int]] = {
    "ok": frozenset({Exit.OK}), "fail": frozenset({Exit.FAILED}),
    "time limit": frozenset({Exit.UNDECIDED}), "stuck": frozenset({Exit.UNDECIDED}),
    "zeno": frozenset({Exit.UNDECIDED}),
    "signal": frozenset({Exit.UNDECIDED, *range(SIGNAL_BASE + 1, SIGNAL_BASE + 65)}),
    "error": frozenset({Exit.VEHICLE, Exit.INTERNAL}), "refused": frozenset({Exit.INVALID}),
    "no vehicle": frozenset({Exit.NO_VEHICLE}), "log failed": frozenset({Exit.UNDECIDED}),
    "fleet": frozenset({Exit.UNDECIDED}),  # stopped because another vehicle of its fleet failed
}
FAULT = re.compile(r"^[a-z]+@[0-9.eE+-]{1,30}$")  # --inject FAULT@SECONDS
SETTING = re.compile(r"^[a-z]+=[0-9.eE+-]{1,30}(,[0-9.eE+-]{1,30}){0,3}$")  # current=VX,VY


def _text_map(value: Any) -> bool:
    return isinstance(value, dict) and all(isinstance(v, str) for v in value.values())


def _texts(value: Any) -> bool:
    return isinstance(value, list) and all(isinstance(v, str) for v in value)


def _fault(text: str) -> bool:
    """``FAULT@SECONDS`` with a finite number of seconds, or a setting of the simulated world
    ``NAME=X[,Y...]`` of finite numbers (paper 003's ``current=0.2,0``, docs/MCM.md)."""
    if SETTING.match(text):
        numbers = text.split("=")[1].split(",")
    elif FAULT.match(text):
        numbers = [text.split("@")[1]]
    else:
        return False
    try:
        return all(math.isfinite(float(n)) for n in numbers)
    except ValueError:
        return False


def _seconds(value: Any) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool) and \
        math.isfinite(value) and value > 0


def _seed(value: Any) -> bool:
    """A seed, as ``--seed`` takes it: an integer from 0 to 2**64 - 1."""
    return isinstance(value, int) and not isinstance(value, bool) and 0 <= value < 2**64


# the header's fields: what each must be (the ones every run writes are marked required)
HEADER: dict[str, tuple[bool, str, Callable[[Any], bool]]] = {
    "kind": (True, "header", lambda v: v == "header"),
    "format": (True, "the format", lambda v: isinstance(v, str)),
    "mission": (True, "the mission's name", lambda v: isinstance(v, str)),
    "net": (True, "the net's digest (16 hex digits)",
            lambda v: isinstance(v, str) and re.fullmatch(r"[0-9a-f]{16}", v) is not None),
    "key": (True, "the public key or null", lambda v: v is None or isinstance(v, str)),
    "file": (False, "a file name", lambda v: isinstance(v, str)),
    "params": (False, "names -> MCL text", _text_map),
    "tasks": (False, "a list of file names", _texts),
    "vehicle": (False, "the --vehicle text", lambda v: isinstance(v, str)),
    "seed": (False, "a seed from 0 to 2**64 - 1", lambda v: _seed(v)),
    "inject": (False, "a list of FAULT@SECONDS or NAME=X,Y",
               lambda v: _texts(v) and all(_fault(x) for x in v)),
    "max_time": (False, "a positive number of seconds", _seconds),
    "time": (False, "the note on mission time", lambda v: isinstance(v, str)),
    "fleet": (False, "the fleet's name", lambda v: isinstance(v, str)),  # mission/fleet.py
    "as": (False, "the vehicle's name in its fleet", lambda v: isinstance(v, str)),
    "fleet_seed": (False, "the fleet's seed, from 0 to 2**64 - 1", lambda v: _seed(v)),
    "scene": (False, "the scene (lines and points of [x, y]: mission/poses.py)", is_scene),
}


def header_problem(header: dict[str, Any], compiled: Compiled) -> str | None:
    """Why the header is not one a run of ``compiled`` writes, or None: every field known,
    each of its kind, the mission's name the one its MISSION declares (if it does)."""
    for name in header:
        if name.startswith("_") or name in ("digest", "sig"):
            continue
        if name not in HEADER:
            return (f"the header has a field no run writes ({name[:40]!r}): what it claims "
                    "cannot be checked")
    for name, (required, what, good) in HEADER.items():
        if name not in header:
            if required:
                return f"the header lacks {name!r} ({what})"
            continue
        if not good(header[name]):
            return f"the header's {name!r} is not {what}"
    declared = compiled.mission.name  # (an unnamed mission is named by its file's stem,
    if declared and header["mission"] != declared:  # which the replay may spell otherwise)
        return (f"the log is of mission {header['mission'][:40]!r}, not of "
                f"{declared!r}")
    return None


def end_problem(header: dict[str, Any], end: dict[str, Any],
                records: list[dict[str, Any]], compiled: Compiled) -> str | None:
    """Why the end record's exit, limit or handled events are not what the log shows, or
    None (its how, status and switch-off against the marking: petri's replay)."""
    how = end["how"]
    if how not in HOW_EXITS:
        return f"the end record says the run ended {how[:40]!r}, which no run says"
    if "exit" in end and end["exit"] not in HOW_EXITS[how]:
        return (f"the end record says exit {end['exit']} for a run that ended {how!r} "
                f"(which exits {', '.join(str(x) for x in sorted(HOW_EXITS[how])[:3])}"
                f"{'...' if len(HOW_EXITS[how]) > 3 else ''})")
    if "limit" in end and "max_time" in header and end["limit"] != header["max_time"]:
        return (f"the end record's limit ({end['limit']:g} s) is not the header's max_time "
                f"({header['max_time']:g} s)")
    handler = end.get("stop_handler")
    after = handler.get("bound", 0.0) if isinstance(handler, dict) else 0.0
    if "limit" in end and how != "no vehicle" and end["t"] > end["limit"] + after + 1e-6:
        return f"the run ended at {end['t']:g} s, past its limit of {end['limit']:g} s"
    problem = stop_handler_problem(end, records)
    if problem is not None:
        return problem
    if "handled" in end:
        watch = CatchWatch(compiled)
        for r in records[1:-1]:
            if r["kind"] == "fire":
                watch(Record(float(r["t"]), "fire", r))
        seen = [h.as_record() for h in watch.handled]
        if end["handled"] != seen:
            return (f"the end record's handled events ({_events(end['handled'])}) are not "
                    f"those the firings show ({_events(seen)})")
    return None


def stop_handler_problem(end: dict[str, Any], records: list[dict[str, Any]]) -> str | None:
    """Why the end record's ``stop_handler`` is not what the firings show (the mission's
    ON STOP started, ended ok or fail, or was halted, and when), or None."""
    fired = {r["transition"]: float(r["t"]) for r in records[1:-1] if r["kind"] == "fire"
             and r.get("transition") in (STOP_START, STOP_OK, STOP_FAIL, HALT)}
    claim = end.get("stop_handler")
    if STOP_START not in fired:
        return None if claim is None else ("the end record says the stop handler ran, but "
                                           "the firings never started it")
    if not isinstance(claim, dict):
        return "the stop handler ran, but the end record does not say how it went"
    how = ("ended ok" if STOP_OK in fired else "ended fail" if STOP_FAIL in fired
           else "halted" if HALT in fired else "running")
    if claim.get("how") != how:
        return (f"the end record says the stop handler {str(claim.get('how'))[:20]!r}, but "
                f"the firings show it {how}")
    if not isinstance(claim.get("end"), float | int) or abs(claim["end"] - end["t"]) > 1e-6:
        return "the end record's stop handler does not end when the run ends"
    return None


def _events(handled: Any) -> str:
    if not isinstance(handled, list) or not handled:
        return "none"
    return ", ".join(str(h.get("event"))[:40] if isinstance(h, dict) else "?"
                     for h in handled[:5])
