"""What a fleet's logs claim together (``mcl replay DIR FLEET.mcl``): the channel record
against the fleet's channels and against every vehicle's run log.

Each vehicle's log is checked alone first, as any run log (``app/replay.py``). Then:

1. the channel record (``channels.jsonl``, :class:`mission.channels.ChannelRecord`): its
   lines, its digest chain, a header first and an end line last;
2. every ``sent`` line is a ``Send`` its sender's log shows (an action ``send`` of that
   channel and message at that time), and every such action has its ``sent`` line;
3. every ``delivered`` line follows a ``sent`` line of the same message, within the
   channel's declared DELAY range, to one of its receivers, at most once per receiver; every
   delivery is in the receiver's log (the event ``CHANNEL.MESSAGE``, handled or ignored, at
   that time), and the receiver's log has no such event that was not delivered;
4. a ``lost`` line only on a LOSSY channel; a ``dropped`` line only closer than EVERY to the
   last message sent before it.
"""

from __future__ import annotations

import json
import math
from collections import Counter
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from diagnostics import MclError, Span
from mcl.fleet import CompiledFleet
from petri.execution.runlog import GENESIS, MAX_LINE, MAX_LOG, chain

from mission.channels import RECORD_FORMAT

KINDS = ("header", "sent", "delivered", "lost", "dropped", "undelivered", "refused", "end")
TOLERANCE = 1e-5  # s: times are written to the microsecond


class RecordProblem(MclError):
    """What is wrong with a fleet's logs: in ``path`` at ``line`` (None: the file);
    ``invalid``: input refused as such (exit 2), not logs that fail to conform (exit 1)."""

    def __init__(self, path: str | Path, line: int | None, reason: str,
                 invalid: bool = False) -> None:
        self.path, self.line, self.reason, self.invalid = str(path), line, reason, invalid
        span = Span.of_file(str(path)) if line is None else Span(str(path), line, 1)
        where = str(path) if line is None else f"{path}:{line}"
        super().__init__(reason, span=span, code="fleet-record", text=f"{where}: {reason}")



def read_record(path: str | Path) -> list[dict[str, Any]]:
    """The channel record's lines, each with its ``_line``; its chain checked (a
    :class:`RecordProblem` at the first line that is not right)."""
    try:
        size = Path(path).stat().st_size
        if size > MAX_LOG:
            raise RecordProblem(path, None, f"larger than {MAX_LOG >> 20} MiB", invalid=True)
        with open(path, "rb") as f:
            raw = f.read(MAX_LOG + 1).split(b"\n")
    except OSError as exc:
        raise RecordProblem(path, None, f"cannot be read: {exc.strerror or exc}",
                            invalid=True) from None
    if raw and raw[-1] == b"":
        raw.pop()
    lines: list[dict[str, Any]] = []
    previous = GENESIS
    for number, data in enumerate(raw, 1):
        if len(data) > MAX_LINE:
            raise RecordProblem(path, number, "a line longer than the limit", invalid=True)
        try:
            obj = json.loads(data.decode("ascii"))
        except (UnicodeDecodeError, json.JSONDecodeError, RecursionError):
            raise RecordProblem(path, number, "not a JSON line written by the run",
                                invalid=True) from None
        if not isinstance(obj, dict) or obj.get("kind") not in KINDS:
            raise RecordProblem(path, number, "not a channel-record line (kinds: "
                                + ", ".join(KINDS) + ")", invalid=True)
        digest = obj.get("digest")
        body = json.dumps({k: v for k, v in obj.items() if k != "digest"},
                          separators=(",", ":"))
        if not isinstance(digest, str) or digest != chain(previous, body):
            raise RecordProblem(path, number, "the digest chain breaks here: this line was "
                                "edited, or one before it dropped, moved or inserted")
        previous = digest
        obj["_line"] = number
        lines.append(obj)
    if not lines or lines[0]["kind"] != "header" or lines[0].get("format") != RECORD_FORMAT:
        raise RecordProblem(path, 1, f"not a channel record (its header says format "
                            f"{RECORD_FORMAT})", invalid=True)
    if lines[-1]["kind"] != "end" or any(r["kind"] == "end" for r in lines[1:-1]):
        raise RecordProblem(path, lines[-1]["_line"], "the record does not end with its end "
                            "line: the run did not finish writing it, or it was cut")
    for r in lines[1:]:
        if not all(isinstance(r.get(k), (int, float)) and not isinstance(r.get(k), bool)
                   and math.isfinite(r[k]) for k in ("t", *(("sent",) if r["kind"] != "end"
                                                             else ()))):
            raise RecordProblem(path, r["_line"], "a line without a valid time")
    return lines


def problem(fleet: CompiledFleet, record: list[dict[str, Any]], path: str | Path,
            logs: Mapping[str, list[dict[str, Any]]]) -> RecordProblem | None:
    """What the channel record and the vehicles' logs (by vehicle) do not agree on, or None
    (this module's doc, points 2 to 4)."""
    sent: dict[tuple[str, str, int], dict[str, Any]] = {}
    delivered: set[tuple[str, str, int, str]] = set()
    shown: dict[str, Counter[tuple[str, str, float]]] = {n: Counter() for n in logs}
    for r in record[1:-1]:
        bad = line_problem(fleet, r, sent, delivered, shown)
        if bad is not None:
            return RecordProblem(path, r["_line"], bad)
    dropped = interval_problem(fleet, record)
    if dropped is not None:
        return RecordProblem(path, dropped[0], dropped[1])
    for name, log in logs.items():
        wrong = log_problem(fleet, name, log, sent, shown[name])
        if wrong is not None:
            return RecordProblem(name, wrong[0], wrong[1])
    return None


def line_problem(fleet: CompiledFleet, r: dict[str, Any], sent: dict[tuple[str, str, int], Any],
                 delivered: set[tuple[str, str, int, str]],
                 shown: dict[str, Counter[tuple[str, str, float]]]) -> str | None:
    """What is wrong with one line of the channel record, given those before it."""
    kind, name = r["kind"], r.get("channel")
    channel = fleet.channels.get(name) if isinstance(name, str) else None
    if channel is None:
        return f"a message on {str(name)[:40]!r}, which is not a channel of the fleet"
    key = (channel.name, str(r.get("sender")), int(r.get("seq", -1)))
    if r.get("sender") != channel.sender:
        return f"a message on {channel.name} from {str(r.get('sender'))[:40]!r}: only " \
               f"{channel.sender} sends on it"
    if kind == "sent":
        if key in sent:
            return f"message {key[2]} on {channel.name} sent twice"
        sent[key] = r
        return None
    first = sent.get(key)
    if first is None or first.get("message") != r.get("message") or first["sent"] != r["sent"]:
        return f"{kind} {channel.name}.{r.get('message')} (seq {key[2]}), which was not sent"
    receiver = r.get("receiver")
    if receiver not in channel.receivers:
        return f"{kind} to {str(receiver)[:40]!r}, not a receiver of {channel.name}"
    if kind == "delivered":
        delay = r["t"] - r["sent"]
        if not channel.delay_min - TOLERANCE <= delay <= channel.delay_max + TOLERANCE:
            return (f"delivered {delay:.6g} s after its send, outside {channel.name}'s DELAY "
                    f"{channel.delay_min:g} .. {channel.delay_max:g} s")
        if (*key, str(receiver)) in delivered:
            return f"message {key[2]} on {channel.name} delivered twice to {receiver}"
        delivered.add((*key, str(receiver)))
        if str(receiver) in shown:
            shown[str(receiver)][(channel.name, str(r.get("message")), round(r["t"], 5))] += 1
    elif kind == "lost" and not channel.lossy:
        return f"a message lost on {channel.name}, which is not LOSSY"
    return None


def interval_problem(fleet: CompiledFleet, record: list[dict[str, Any]]) -> tuple[int, str] | None:
    """A message dropped that was not closer than EVERY to the last one kept before it on its
    channel (the line and why), or None."""
    drops = {(r["channel"], r["seq"]) for r in record if r["kind"] == "dropped"}
    last_kept: dict[str, float] = {}  # channel -> the send time of the last message kept
    for r in record:
        if r["kind"] != "sent":
            continue
        channel = fleet.channels[r["channel"]]
        if (r["channel"], r["seq"]) not in drops:
            last_kept[channel.name] = r["sent"]
            continue
        before = last_kept.get(channel.name)
        if before is None or r["sent"] - before >= channel.interval - TOLERANCE:
            line = next(x["_line"] for x in record if x["kind"] == "dropped"
                        and (x["channel"], x["seq"]) == (r["channel"], r["seq"]))
            return line, (f"a message dropped on {channel.name} that was not closer than "
                          f"EVERY {channel.interval:g} s to the one before")
    return None


def log_problem(fleet: CompiledFleet, name: str, log: list[dict[str, Any]],
                sent: dict[tuple[str, str, int], dict[str, Any]],
                delivered: Counter[tuple[str, str, float]]) -> tuple[int, str] | None:
    """What vehicle ``name``'s run log shows that the channel record does not: a Send with no
    ``sent`` line (or the reverse), a message it got that was not delivered (or the reverse)."""
    mine = sorted((r["sent"], c, r.get("message")) for (c, s, _), r in sent.items() if s == name)
    sends = [(r["t"], r["behaviour"], (r.get("params") or {}).get("message"), r["_line"])
             for r in log if r.get("kind") == "action" and r.get("action") == "send"]
    for i, (t, channel, message, line) in enumerate(sends):
        if i >= len(mine) or (abs(mine[i][0] - t) > TOLERANCE or mine[i][1:] != (channel, message)):
            return line, f"Send({channel}, {message}) at {t:g} s has no 'sent' line in the " \
                         "channel record"
    if len(mine) > len(sends):
        return (log[-1]["_line"], f"the channel record says {name} sent {mine[len(sends)][1]}."
                f"{mine[len(sends)][2]} at {mine[len(sends)][0]:g} s; its log shows no such Send")
    events = {f"{c.name}.{m}" for c in fleet.channels.values() if name in c.receivers
              for m in getattr(c, "messages", ())}
    events |= {f"{c}.{m}" for c, m, _ in delivered}
    got: Counter[tuple[str, str, float]] = Counter()
    for r in log:
        event = r.get("event")
        if r.get("kind") in ("event", "ignored") and event in events:
            channel, _, message = str(event).partition(".")
            key = (channel, message, round(float(r["t"]), 5))
            got[key] += 1
            if got[key] > delivered[key]:
                return r["_line"], f"{event} at {r['t']:g} s, which the channel record does " \
                                   "not deliver"
    for key, count in delivered.items():
        if got[key] < count:
            return (log[-1]["_line"], f"the channel record delivers {key[0]}.{key[1]} at "
                    f"{key[2]:g} s; the log does not show it")
    return None
