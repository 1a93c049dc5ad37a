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

Beyond the firings, the replay checks what the log claims of them: an ``ignored`` event's
reason against the marking (nobody waited for it, or the mission had ended); the ``end``
record's ``status`` against the last status the net reached, its ``how`` (ok, fail) against
the marking, nothing left on unless it says the run broke down (``error``), what it says
was switched off against what was on when the stop began and what the log disabled; and, where
the log carries the vehicle's clock (an event's ``vt``, the end record's ``vehicle_t0``, the
vehicle's clock at the mission's start), that no event was delivered before the vehicle
raised it nor raised before the mission started. The exit status an end record claims, the
header's fields and the events the CATCH blocks handled are the mission's to check
(``mission/evidence.py``).
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
    "end": {"how": str, "why": str},
    "pose": {"x": (int, float), "y": (int, float), "z": (int, float)},  # not played
    "progress": {"task": str, "progress": dict},  # not played
}
NUMBER = (int, float)
# Fields a record may carry, checked when it does (a library caller's end record may say less).
OPTIONAL: dict[str, dict[str, type | tuple[type, ...]]] = {
    "event": {"vt": NUMBER, "data": dict},
    "ignored": {"reason": str, "vt": NUMBER},
    "end": {"exit": int, "status": str, "switched_off": list, "confirmed": str,
            "vehicle_t": NUMBER, "vehicle_t0": NUMBER, "limit": NUMBER, "limit_from": str,
            "handled": list},
    "pose": {"yaw": NUMBER},
}
STOPPED_HOWS = ("time limit", "stuck", "signal", "zeno")  # ended through the abort
BROKE_DOWN = ("error", "refused", "no vehicle")  # how an end that claims no clean exit says
CLOCK_SLACK = 1e-3  # s: the rounding of the times a log holds (6 decimals), with margin


def malformed(records: list[dict[str, Any]]) -> Conformance | None:
    """The first record that lacks a field its kind needs, or has one of the wrong type."""
    for r in records[1:]:
        fields = {**FIELDS.get(r["kind"], {}),
                  **{k: v for k, v in OPTIONAL.get(r["kind"], {}).items() if k in r}}
        for name, kind in fields.items():
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
        if r["kind"] == "end" and not all(isinstance(b, str)
                                          for b in r.get("switched_off", [])):
            return Conformance(False, len(records), 0, r.get("_line"),
                               "an end record's 'switched_off' names behaviours")
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
    """Does the run log ``records`` (header first, each with its ``_line``) conform to
    ``net`` run with ``params``? The first record that does not is named by its line."""
    bad_record = malformed(records) or unexplained(records)
    if bad_record is not None:
        return bad_record
    header = records[0]
    if header.get("net") != net_digest(net):
        return Conformance(False, len(records), 0, header["_line"],
                           "the log was made with a different net: the mission, its task "
                           "library or its parameters have changed since the run")
    replay = Replay(net, params)
    for r in records[1:]:
        reason = replay.step(r)
        if reason is not None:
            return Conformance(False, len(records), replay.firings, r["_line"], reason)
    if replay.pending:
        return Conformance(False, len(records), replay.firings, records[-1]["_line"],
                           "the log ends before the last firing's actions")
    late = replay.clock()
    if late is not None:
        return Conformance(False, len(records), replay.firings, late[0], late[1])
    return Conformance(True, len(records), replay.firings)


class Replay:
    """The rules played over a log, record by record: the marking the logged firings led to,
    the timers' clocks, the actions the last firing must still have sent, the behaviours the
    logged actions have switched on, and what the player's cleanup has still to switch off.
    Each step returns why its record breaks a rule, or None."""

    def __init__(self, net: Net, params: dict[str, Any]) -> None:
        self.net = net
        self.params = params
        self.rules = Semantics(net)
        self.marking = self.rules.initial()
        self.since: dict[int, float] = {}  # the timers' clocks
        self.pending: list[dict[str, Any]] = []  # actions the last firing must have sent
        self.firings = 0
        self.cleanup: set[str] | None = None  # what the player's cleanup has still to switch off
        self.on: set[str] = set()  # behaviours the logged actions have switched on
        self.last_status = "ready"  # the last status record's (the player's before it starts)
        self.disabled: set[str] = set()  # every behaviour a logged action disabled
        self.on_at_stop: set[str] | None = None  # on when the mission's abort began
        self.raised: list[tuple[int, float, float]] = []  # events: line, t, the vehicle's clock
        self.origin: float | None = None  # the vehicle's clock at the mission's start

    def step(self, r: dict[str, Any]) -> str | None:
        """Play one record."""
        kind, now = r["kind"], float(r.get("t", 0.0))
        if kind in ("pose", "progress"):  # what the vehicle said: nothing the player did
            return None
        if kind == "status":
            self.last_status = str(r.get("status"))
        if kind == "status" and r.get("status") == "running":
            self.rules.rearm(self.marking, self.since, now)
            return None
        if kind == "action":
            return self.action(r)
        if self.pending:
            return (f"the last firing should have sent {self.pending[0]['action']} "
                    f"{self.pending[0]['behaviour']} first")
        if kind == "fire":
            return self.fire(r, now)
        if kind == "cleanup":
            return self.clean_up(r)
        if kind == "status":
            return self.status(r)
        if kind == "event" and "vt" in r:
            self.raised.append((r["_line"], now, float(r["vt"])))
        if kind == "ignored":
            return self.ignored(r)
        if kind == "end":
            return self.end(r)
        return None

    def action(self, r: dict[str, Any]) -> str | None:
        """An action must be the next of those the last firing sends, or, after the cleanup,
        a plain disable of a behaviour it names."""
        expected = self.pending.pop(0) if self.pending else None
        got = {k: r.get(k) for k in ("action", "behaviour", "params")}
        if expected is None and self.cleanup is not None:  # the last line of defence
            if got != {"action": "disable", "behaviour": got["behaviour"], "params": {}} \
                    or got["behaviour"] not in self.cleanup or r.get("task") != "MISSION":
                return (f"{got['action']} {got['behaviour']} at the end: only a plain "
                        "disable of a behaviour the cleanup names may follow")
            self.cleanup.discard(str(got["behaviour"]))
            self.on.discard(str(got["behaviour"]))
            return None
        if expected is None and r.get("task") == "MISSION":
            return (f"{got['action']} {got['behaviour']} by MISSION with no 'cleanup' record "
                    "before it (a log from before cleanup records cannot be replayed)")
        if expected != got:
            return (f"action {got['action']} {got['behaviour']} is not what the last firing "
                    f"sends (expected {expected})")
        if got["action"] == "enable":
            self.on.add(str(got["behaviour"]))
        elif got["action"] == "disable":
            self.on.discard(str(got["behaviour"]))
            self.disabled.add(str(got["behaviour"]))
        return None

    def fire(self, r: dict[str, Any], now: float) -> str | None:
        """A firing must be of an enabled transition, for its cause, at its time; it then
        fires, and the actions it sends are expected next."""
        net, rules, t = self.net, self.rules, r.get("index")
        if not isinstance(t, int) or not 0 <= t < len(net.transitions) or \
                net.transitions[t].name != r.get("transition"):
            return f"no transition {r.get('transition')!r} at index {t} in the net"
        tr = net.transitions[t]
        if not rules.enabled(self.marking, t):
            return f"{tr.name} is not enabled here"
        cause = r.get("cause")
        stop = t in rules.stops and cause in (LINK_LOST, "abort")
        if stop and self.on_at_stop is None:
            self.on_at_stop = set(self.on)
        if tr.event is not None and cause != tr.event and not stop:
            return f"{tr.name} waits for {tr.event}, but the log says {cause}"
        if tr.timer is not None:
            late_or_early = self.timer(t, now)
            if late_or_early is not None:
                return late_or_early
        if tr.immediate and cause != "immediate":
            return f"{tr.name} is immediate but the log says {cause}"
        rules.fire(self.marking, t)
        self.firings += 1
        # a disable that leaves another holder is not sent (a shared watcher stays on)
        self.pending = [{"action": a.kind, "behaviour": a.behaviour,
                         "params": {k: resolve(v, self.params) for k, v in a.params}}
                        for a in tr.actions
                        if a.kind != "disable" or not rules.held(self.marking, a.behaviour)]
        rules.rearm(self.marking, self.since, now, fired=t)
        return None

    def timer(self, t: int, now: float) -> str | None:
        """A timer fires when it falls due: not before its time, and never later."""
        name = self.net.transitions[t].name
        seconds = self.rules.seconds(t, self.params)
        due = self.since.get(t, now) + seconds
        if now + 1e-6 < due:
            return f"{name} fired before its {seconds:g} s were up"
        if now > due + 1e-6:  # the player fires a timer at its time, never later
            return (f"{name} fired at {now:g} s, after its time ({due:g} s): a timer fires "
                    "when it falls due")
        return None

    def clean_up(self, r: dict[str, Any]) -> str | None:
        """The player's own switch-off: one, naming exactly the behaviours still on."""
        named = set(r["behaviours"])
        if self.cleanup is not None:
            return "a second cleanup"
        if named != self.on:
            return f"a cleanup of {sorted(named)}, but the behaviours on are {sorted(self.on)}"
        self.cleanup = named
        if self.on_at_stop is None:
            self.on_at_stop = set(self.on)
        self.disabled |= named
        return None

    def status(self, r: dict[str, Any]) -> str | None:
        """An end status must be what the end places show, with every behaviour off."""
        if self.on:  # the player switches off whatever is left before it says so
            return f"the mission ends with {', '.join(sorted(self.on))} still on"
        status = r.get("status")
        marked = {s for p, s in self.rules.ends.items() if self.marking[p] > 0}
        if status not in marked:
            return (f"status {status!r}, but the net's marking says "
                    f"{sorted(marked) or 'still running'}")
        return None

    def ignored(self, r: dict[str, Any]) -> str | None:
        """An event that fired nothing: its reason must hold in the marking."""
        event, reason = r["event"], r.get("reason")
        ended = self.rules.end_status(self.marking) is not None or \
            self.last_status in ("ok", "fail")  # (a forced end: the player's own abort)
        if reason == "the mission has ended":
            return None if ended else f"{event} ignored as after the end, but the mission " \
                "is still running"
        if reason == "nobody waits for it":
            waiting = [self.net.transitions[t].name for t in self.rules.waiting.get(event, [])
                       if self.rules.enabled(self.marking, t)]
            if event == LINK_LOST:
                waiting += [self.net.transitions[t].name for t in self.rules.stops
                            if self.rules.enabled(self.marking, t)]
            if ended:
                return f"{event} ignored as waited for by nobody, but the mission had ended"
            if waiting:
                return f"{event} ignored as waited for by nobody, but {waiting[0]} waits for it"
            return None
        if isinstance(reason, str) and reason.startswith("seq ") and \
                reason.endswith(": duplicate or out of order"):
            return None  # the runner's: the event's sequence number is not logged
        return f"{event} ignored for a reason the player never gives ({reason!r})"

    def end(self, r: dict[str, Any]) -> str | None:
        """The end record against the marking the firings reached and what the actions left
        on (``status``, ``how``, what was switched off)."""
        how = r["how"]
        if "status" in r and r["status"] != self.last_status:
            return (f"the end record says status {r['status']!r}, but the log's last status "
                    f"is {self.last_status!r}")
        reached = self.rules.end_status(self.marking)
        if how in ("ok", "fail") and reached != how:
            return (f"the end record says the mission ended {how}, but the net's marking says "
                    f"{reached or 'still running'}")
        if self.on and how not in BROKE_DOWN:
            return (f"the end record says {how}, but {', '.join(sorted(self.on))} "
                    "is still on by the log's own actions")
        said = set(r.get("switched_off", []))
        if said - self.disabled:
            return (f"the end record says {', '.join(sorted(said - self.disabled))} was "
                    "switched off, but no action in the log disabled it")
        if "switched_off" in r and how in ("ok", "fail") and said:
            return "the mission ended by itself, yet the end record lists a switch-off"
        missed = (self.on_at_stop or set()) - said
        if "switched_off" in r and how in STOPPED_HOWS and missed:
            return (f"the end record leaves out {', '.join(sorted(missed))}, on when the "
                    "abort began and switched off by it")
        if "vehicle_t0" in r:
            self.origin = float(r["vehicle_t0"])
        return None

    def clock(self) -> tuple[int, str] | None:
        """The first event delivered before the vehicle raised it, or raised before the
        mission started, by the vehicle's clock (where the log carries it)."""
        if self.origin is None:
            return None
        for line, t, vt in self.raised:
            if vt - self.origin > t + CLOCK_SLACK:
                return line, (f"delivered at {t:g} s, but the vehicle raised it at "
                              f"{vt - self.origin:g} s of mission time (its clock {vt:g} s)")
            if vt < self.origin - CLOCK_SLACK:
                return line, (f"raised at {vt:g} s of the vehicle's clock, before the "
                              f"mission started ({self.origin:g} s)")
        return None
