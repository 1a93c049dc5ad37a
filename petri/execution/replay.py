"""Conformance: is a run log a legal firing sequence of the compiled net?

Every firing must be of a transition enabled in the marking the previous firings led to; a
firing caused by an event must wait for that event; a firing caused by a timer must come after
its time; the actions after a firing must be exactly those the transition sends; the status
records must agree with the marking. The rules (enabled, fire, the timers' clocks, which
disables a holder keeps back) are :class:`petri.semantics.Semantics`'s, as the player's.

The player's own switch-off at the end (the last line of defence) is read from its
``cleanup`` record, which names the behaviours still on; only a plain disable of each, sent by
``MISSION``, may follow it. A log written before the cleanup was a record of its own (it said
so only in a note's text) is refused at its first such disable, with that reason.
The first record that does not conform is named by its line.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from petri.net import Net, resolve
from petri.execution.runlog import net_digest
from petri.semantics import LINK_LOST, Semantics


@dataclass
class Conformance:
    ok: bool
    records: int
    firings: int
    line: int | None = None
    reason: str = ""


# The fields each kind of record must have, and their types: a record without them is named
# by its line instead of upsetting the checks below.
FIELDS: dict[str, dict[str, type | tuple[type, ...]]] = {
    "fire": {"transition": str, "index": int, "cause": str},
    "action": {"action": str, "behaviour": str, "params": dict, "task": str},
    "event": {"event": str},
    "ignored": {"event": str},
    "status": {"status": str},
    "note": {"note": str},
    "cleanup": {"behaviours": list},
}


def malformed(records: list[dict[str, Any]]) -> Conformance | None:
    """The first record that lacks a field its kind needs, or has one of the wrong type."""
    for r in records[1:]:
        for name, kind in FIELDS.get(r["kind"], {}).items():
            value = r.get(name)
            if not isinstance(value, kind) or isinstance(value, bool):
                what = kind.__name__ if isinstance(kind, type) else "/".join(
                    k.__name__ for k in kind)
                return Conformance(False, len(records), 0, r.get("_line"),
                                   f"a {r['kind']!r} record needs {name!r} ({what}), "
                                   f"not {value!r}")
        if r["kind"] == "cleanup" and not all(isinstance(b, str) for b in r["behaviours"]):
            return Conformance(False, len(records), 0, r.get("_line"),
                               "a 'cleanup' record names behaviours (a list of names)")
    return None


UNPROMPTED = ("immediate", "timer", "abort", "replay")  # causes that are not vehicle events


def unexplained(records: list[dict[str, Any]]) -> Conformance | None:
    """The first firing said to be caused by an event that no ``event`` record delivered just
    before it (in the same instant), or the first event record that caused no firing."""
    delivered: dict[str, Any] | None = None  # the last event record of this instant
    used = True
    for r in records[1:]:
        kind = r["kind"]
        if kind == "event":
            if not used and delivered is not None:
                break
            delivered, used = r, False
        elif kind == "fire" and r["cause"] not in UNPROMPTED:
            if delivered is None or delivered["event"] != r["cause"] or \
                    delivered["t"] != r["t"]:
                return Conformance(False, len(records), 0, r.get("_line"),
                                   f"{r['transition']} fired on {r['cause']}, but no event "
                                   f"{r['cause']} was received just before it")
            used = True
    else:
        if used or delivered is None:
            return None
    assert delivered is not None
    return Conformance(False, len(records), 0, delivered.get("_line"),
                       f"event {delivered['event']} was received, but nothing fired on it")


def check(net: Net, records: list[dict[str, Any]], params: dict[str, Any]) -> Conformance:
    bad_record = malformed(records) or unexplained(records)
    if bad_record is not None:
        return bad_record
    header = records[0]
    if header.get("net") != net_digest(net):
        return Conformance(False, len(records), 0, header["_line"],
                           "the log was made with a different net: the mission, its task "
                           "library or its parameters have changed since the run")
    rules = Semantics(net)
    marking = rules.initial()
    since: dict[int, float] = {}
    pending: list[dict[str, Any]] = []  # actions the last firing must have sent
    firings = 0
    ends = rules.ends

    def enabled(t: int) -> bool:
        return rules.enabled(marking, t)

    def bad(r: dict[str, Any], reason: str) -> Conformance:
        return Conformance(False, len(records), firings, r["_line"], reason)

    cleanup: set[str] | None = None  # what the player's cleanup has still to switch off
    on: set[str] = set()  # behaviours the logged actions have switched on
    for r in records[1:]:
        kind, now = r["kind"], float(r.get("t", 0.0))
        if kind == "status" and r.get("status") == "running":
            rules.rearm(marking, since, now)
            continue
        if kind == "action":
            expected = pending.pop(0) if pending else None
            got = {k: r.get(k) for k in ("action", "behaviour", "params")}
            if expected is None and cleanup is not None:  # the last line of defence
                if got != {"action": "disable", "behaviour": got["behaviour"], "params": {}} \
                        or got["behaviour"] not in cleanup or r.get("task") != "MISSION":
                    return bad(r, f"{got['action']} {got['behaviour']} at the end: only a "
                                  "plain disable of a behaviour the cleanup names may follow")
                cleanup.discard(str(got["behaviour"]))
                on.discard(str(got["behaviour"]))
                continue
            if expected is None and r.get("task") == "MISSION":
                return bad(r, f"{got['action']} {got['behaviour']} by MISSION with no "
                              "'cleanup' record before it (a log from before cleanup "
                              "records cannot be replayed)")
            if expected != got:
                return bad(r, f"action {got['action']} {got['behaviour']} is not what the last "
                              f"firing sends (expected {expected})")
            if got["action"] == "enable":
                on.add(str(got["behaviour"]))
            elif got["action"] == "disable":
                on.discard(str(got["behaviour"]))
            continue
        if pending:
            return bad(r, f"the last firing should have sent {pending[0]['action']} "
                          f"{pending[0]['behaviour']} first")
        if kind == "fire":
            t = r.get("index")
            if not isinstance(t, int) or not 0 <= t < len(net.transitions) or \
                    net.transitions[t].name != r.get("transition"):
                return bad(r, f"no transition {r.get('transition')!r} at index {t} in the net")
            tr = net.transitions[t]
            if not enabled(t):
                return bad(r, f"{tr.name} is not enabled here")
            cause = r.get("cause")
            stop = t in rules.stops and cause in (LINK_LOST, "abort")
            if tr.event is not None and cause != tr.event and not stop:
                return bad(r, f"{tr.name} waits for {tr.event}, but the log says {cause}")
            if tr.timer is not None:
                seconds = rules.seconds(t, params)
                due = since.get(t, now) + seconds
                if now + 1e-6 < due:
                    return bad(r, f"{tr.name} fired before its {seconds:g} s were up")
                if now > due + 1e-6:  # the player fires a timer at its time, never later
                    return bad(r, f"{tr.name} fired at {now:g} s, after its time "
                                  f"({due:g} s): a timer fires when it falls due")
            if tr.immediate and cause != "immediate":
                return bad(r, f"{tr.name} is immediate but the log says {cause}")
            rules.fire(marking, t)
            firings += 1
            # a disable that leaves another holder is not sent (a shared watcher stays on)
            pending = [{"action": a.kind, "behaviour": a.behaviour,
                        "params": {k: resolve(v, params) for k, v in a.params}}
                       for a in tr.actions
                       if a.kind != "disable" or not rules.held(marking, a.behaviour)]
            rules.rearm(marking, since, now, fired=t)
        elif kind == "cleanup":
            named = set(r["behaviours"])
            if cleanup is not None:
                return bad(r, "a second cleanup")
            if named != on:
                return bad(r, f"a cleanup of {sorted(named)}, but the behaviours on are "
                              f"{sorted(on)}")
            cleanup = named
        elif kind == "status":
            if on:  # the player switches off whatever is left before it says so
                return bad(r, f"the mission ends with {', '.join(sorted(on))} still on")
            status = r.get("status")
            marked = {s for p, s in ends.items() if marking[p] > 0}
            if status not in marked:
                return bad(r, f"status {status!r}, but the net's marking says "
                              f"{sorted(marked) or 'still running'}")
    if pending:
        return Conformance(False, len(records), firings, records[-1]["_line"],
                           "the log ends before the last firing's actions")
    return Conformance(True, len(records), firings)

