"""Conformance: is a run log a legal firing sequence of the compiled net?

Every firing must be of a transition enabled in the marking the previous firings led to; a
firing caused by an event must wait for that event; a firing caused by a timer must come after
its time; the actions after a firing must be exactly those the transition sends; the status
records must agree with the marking. The first record that does not is named by its line.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from .net import Net, resolve
from .runlog import net_digest


@dataclass
class Conformance:
    ok: bool
    records: int
    firings: int
    line: int | None = None
    reason: str = ""


def check(net: Net, records: list[dict[str, Any]], params: dict[str, Any]) -> Conformance:
    header = records[0]
    if header.get("net") != net_digest(net):
        return Conformance(False, len(records), 0, header["_line"],
                           "the log was made with a different net: the mission, its task "
                           "library or its parameters have changed since the run")
    marking = [0] * len(net.places)
    for p, n in net.initial.items():
        marking[p] = n
    since: dict[int, float] = {}
    pending: list[dict[str, Any]] = []  # actions the last firing must have sent
    firings = 0
    ends = {net.place(n): n.split(".")[1] for n in ("MISSION.ok", "MISSION.fail")
            if n in net._index}

    def enabled(t: int) -> bool:
        return all(marking[p] >= w for p, w in net.transitions[t].inputs)

    def rearm(now: float) -> None:
        for t, tr in enumerate(net.transitions):
            if tr.timer is not None:
                if enabled(t):
                    since.setdefault(t, now)
                else:
                    since.pop(t, None)

    def bad(r: dict[str, Any], reason: str) -> Conformance:
        return Conformance(False, len(records), firings, r["_line"], reason)

    cleanup = False
    on: set[str] = set()  # behaviours the logged actions have switched on
    for r in records[1:]:
        kind, now = r["kind"], float(r.get("t", 0.0))
        if kind == "status" and r.get("status") == "running":
            rearm(now)
            continue
        if kind == "action":
            expected = pending.pop(0) if pending else None
            got = {k: r.get(k) for k in ("action", "behaviour", "params")}
            if expected is None and cleanup:  # the player's last line of defence at the end
                if got != {"action": "disable", "behaviour": got["behaviour"], "params": {}} \
                        or got["behaviour"] not in on or r.get("task") != "MISSION":
                    return bad(r, f"{got['action']} {got['behaviour']} at the end: only a "
                                  "plain disable of a behaviour still on may follow")
                on.discard(got["behaviour"])
                continue
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
            if tr.event is not None and cause not in (tr.event, "Link.lost"):
                return bad(r, f"{tr.name} waits for {tr.event}, but the log says {cause}")
            if tr.timer is not None:
                seconds = float(params.get(tr.timer, 0.0)) if isinstance(tr.timer, str) \
                    else float(tr.timer)
                if now + 1e-6 < since.get(t, now) + seconds:
                    return bad(r, f"{tr.name} fired before its {seconds:g} s were up")
            if tr.immediate and cause != "immediate":
                return bad(r, f"{tr.name} is immediate but the log says {cause}")
            for p, w in tr.inputs:
                marking[p] -= w
            for p, w in tr.outputs:
                marking[p] += w
            firings += 1
            pending = [{"action": a.kind, "behaviour": a.behaviour,
                        "params": {k: resolve(v, params) for k, v in a.params}}
                       for a in tr.actions]
            rearm(now)
        elif kind == "note" and "switching off" in str(r.get("note", "")):
            cleanup = True
        elif kind == "status":
            if cleanup and on:
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

