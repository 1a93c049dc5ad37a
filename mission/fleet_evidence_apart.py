"""What a fleet's logs claim together when its vehicles ran apart, each in its own process over
Zenoh (``mcl run FLEET.mcl --as NAME``, docs/FLEET_ZENOH.md): each vehicle wrote its run log
``NAME.jsonl`` and its own channel record ``channels-NAME.jsonl``, on its own clock.

The checks of :mod:`mission.fleet_evidence`, on two clocks. Each vehicle's log is checked alone
first, as any run log. Then, for each vehicle:

1. its channel record: its lines and digest chain (:func:`mission.fleet_evidence.read_record`),
   its header naming this fleet and this vehicle;
2. its ``sent`` lines are exactly its log's ``Send`` actions, in order, at the vehicle's clock
   (mission time plus the clock's origin, ``vehicle_t0`` in the log's end record);
3. every message it heard (``delivered``, ``lost``, ``dropped``, ``undelivered``) is a ``sent``
   line of the channel's sender, in the sender's record, with the same message and send time
   (no message heard that was not sent), on a channel directed to it, at most once; a
   delivery's ``delay`` is within the channel's DELAY range (its ``t`` is on the receiver's
   clock, its ``sent`` on the sender's: they are not compared); every delivery is in its log
   (the event ``CHANNEL.MESSAGE`` at that time of the vehicle's clock, ``vt``), and its log
   has no such event that was not delivered;
4. ``lost`` only on a LOSSY channel; ``dropped`` only closer than EVERY to the last message
   its sender sent before it.

``refused`` lines (a message the receiver did not take: not from the channel's sender, not on
its key) are evidence of an attempt, not of a message: they are counted, not checked.
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

from mcl.fleet import CompiledFleet
from mission.fleet_evidence import TOLERANCE, RecordProblem, interval_problem, read_record

HEARD = ("delivered", "lost", "dropped", "undelivered")


def record_name(vehicle: str) -> str:
    """The file name of a vehicle's own channel record."""
    return f"channels-{vehicle}.jsonl"


def is_apart(folder: Path, vehicles: list[str]) -> bool:
    """Whether ``folder`` holds a fleet run apart: a record per vehicle, no shared one."""
    return (not (folder / "channels.jsonl").exists()
            and any((folder / record_name(n)).is_file() for n in vehicles))


def read_records(folder: Path, fleet_name: str, vehicles: list[str]
                 ) -> dict[str, list[dict[str, Any]]]:
    """Every vehicle's channel record, read and its header checked."""
    records: dict[str, list[dict[str, Any]]] = {}
    for name in vehicles:
        path = folder / record_name(name)
        if not path.is_file():
            raise RecordProblem(path, None, f"no channel record of vehicle {name}",
                                invalid=True)
        record = read_record(path)
        header = record[0]
        if header.get("fleet") != fleet_name or header.get("as") != name:
            raise RecordProblem(path, 1, f"not the channel record of vehicle {name} of fleet "
                                f"{fleet_name} (its header says {str(header.get('as'))[:40]!r}"
                                f" of {str(header.get('fleet'))[:40]!r})")
        records[name] = record
    return records


def problem_apart(fleet: CompiledFleet, folder: Path, logs: Mapping[str, list[dict[str, Any]]]
                  ) -> RecordProblem | None:
    """What the vehicles' records and logs do not agree on (this module's doc), or None."""
    records = read_records(folder, fleet.name, list(logs))
    sent = {(r["channel"], r["sender"], r["seq"]): r for rec in records.values()
            for r in rec if r["kind"] == "sent"}
    for name, log in logs.items():
        path = folder / record_name(name)
        wrong = sends_problem(name, log, records[name])
        if wrong is not None:
            return RecordProblem(folder / f"{name}.jsonl", wrong[0], wrong[1])
        shown: list[tuple[str, str, float]] = []
        heard: set[tuple[str, str, int]] = set()
        for r in records[name][1:-1]:
            bad = heard_problem(fleet, name, r, sent, heard, shown)
            if bad is not None:
                return RecordProblem(path, r["_line"], bad)
        for sender in {c.sender for c in fleet.channels.values() if name in c.receivers}:
            mine = [r for r in records.get(sender, []) if r["kind"] == "sent"
                    and name in fleet.channels[r["channel"]].receivers]
            drops = [r for r in records[name] if r["kind"] == "dropped"
                     and r["sender"] == sender]
            dropped = interval_problem(fleet, [*mine, *drops])
            if dropped is not None:
                return RecordProblem(path, dropped[0], dropped[1])
        wrong = events_problem(fleet, name, log, shown)
        if wrong is not None:
            return RecordProblem(folder / f"{name}.jsonl", wrong[0], wrong[1])
    return None


def sends_problem(name: str, log: list[dict[str, Any]], record: list[dict[str, Any]]
                  ) -> tuple[int, str] | None:
    """A Send of the log without its ``sent`` line (or the reverse), at the vehicle's clock."""
    origin = float(log[-1].get("vehicle_t0", 0.0) or 0.0)
    mine = [r for r in record if r["kind"] == "sent"]
    sends = [r for r in log if r.get("kind") == "action" and r.get("action") == "send"]
    for i, act in enumerate(sends):
        channel, message = act.get("behaviour"), (act.get("params") or {}).get("message")
        at = float(act["t"]) + origin
        if (i >= len(mine) or abs(mine[i]["sent"] - at) > TOLERANCE
                or (mine[i]["channel"], mine[i]["message"]) != (channel, message)
                or mine[i]["sender"] != name):
            return act["_line"], (f"Send({channel}, {message}) at {act['t']:g} s (vehicle "
                                  f"{at:g} s) has no 'sent' line in {record_name(name)}")
    if len(mine) > len(sends):
        extra = mine[len(sends)]
        return (log[-1]["_line"], f"{record_name(name)} says {name} sent {extra['channel']}."
                f"{extra['message']} at {extra['sent']:g} s; its log shows no such Send")
    return None


def heard_problem(fleet: CompiledFleet, name: str, r: dict[str, Any],
                  sent: Mapping[tuple[str, str, int], dict[str, Any]],
                  heard: set[tuple[str, str, int]],
                  shown: list[tuple[str, str, float]]) -> str | None:
    """What is wrong with one line of vehicle ``name``'s record, given those before it."""
    kind = r["kind"]
    if kind == "sent" or kind not in HEARD:
        return None if kind in ("sent", "refused") else f"a line of kind {kind!r}"
    channel = fleet.channels.get(str(r.get("channel")))
    if channel is None or name not in channel.receivers or r.get("receiver") != name:
        return f"{kind} {str(r.get('channel'))[:40]} to {name}, which it is not directed to"
    key = (channel.name, str(r.get("sender")), int(r.get("seq", -1)))
    first = sent.get(key)
    if (first is None or r.get("sender") != channel.sender
            or first.get("message") != r.get("message") or first["sent"] != r["sent"]):
        return (f"{kind} {channel.name}.{r.get('message')} (seq {key[2]} from "
                f"{str(r.get('sender'))[:40]}), which its sender's record does not send")
    if key in heard:
        return f"message {key[2]} on {channel.name} heard twice"
    heard.add(key)
    if kind == "delivered":
        delay = r.get("delay")
        if not (isinstance(delay, (int, float)) and channel.delay_min - TOLERANCE <= delay
                <= channel.delay_max + TOLERANCE):
            return (f"delivered with delay {delay!r}, outside {channel.name}'s DELAY "
                    f"{channel.delay_min:g} .. {channel.delay_max:g} s")
        shown.append((channel.name, str(r["message"]), float(r["t"])))
    elif kind == "lost" and not channel.lossy:
        return f"a message lost on {channel.name}, which is not LOSSY"
    return None


def events_problem(fleet: CompiledFleet, name: str, log: list[dict[str, Any]],
                   delivered: list[tuple[str, str, float]]) -> tuple[int, str] | None:
    """A channel event in the log that the record does not deliver, or the reverse (times
    on the vehicle's clock, the log's ``vt``, matched within the microsecond the record keeps)."""
    events = {f"{c.name}.{m}" for c in fleet.channels.values() if name in c.receivers
              for m in getattr(c, "messages", ())}
    left = list(delivered)
    for r in log:
        event = r.get("event")
        if r.get("kind") in ("event", "ignored") and event in events:
            channel, _, message = str(event).partition(".")
            at = float(r.get("vt", r["t"]))
            match = next((d for d in left if d[:2] == (channel, message)
                          and abs(d[2] - at) <= TOLERANCE), None)
            if match is None:
                return r["_line"], (f"{event} at {r['t']:g} s, which {record_name(name)} "
                                    "does not deliver")
            left.remove(match)
    if left:
        channel, message, at = left[0]
        return (log[-1]["_line"], f"{record_name(name)} delivers {channel}.{message} at "
                f"{at:g} s (vehicle clock); the log does not show it")
    return None
