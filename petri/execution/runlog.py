"""The run log: JSON Lines, one record per action, event, firing and status change.

Each record is written and flushed as it happens, so a crash loses at most the record being
written. The first record is a header that says which mission, which net (a digest of the
compiled net) and which parameters were run, so that ``mcl replay`` can check the log against
the same net; the last record says how and why the run ended (``"kind": "end"``).

Between them, one record per :class:`~petri.execution.reporting.Record` of the player, with its
mission time ``t``, its ``kind`` and its fields:

==========  ===================================================================================
kind        fields
==========  ===================================================================================
status      ``status``: running, ok or fail
fire        ``transition``, ``index``, ``cause`` (immediate, timer, abort, replay, or the event),
            ``label``, ``construct``, ``line``
action      ``action`` (enable, disable, configure), ``behaviour``, ``params``, ``task``: an
            order the firing just before sent to the vehicle (``task`` MISSION: the cleanup's)
event       ``event``, ``data``: an event that fired transitions
ignored     ``event``, ``reason``: an event that fired nothing
note        ``note``: text for people (never read back by a program)
cleanup     ``behaviours``: the player's own switch-off, when the net has left these on at the
            end (or could not end); a plain disable of each, task MISSION, follows
==========  ===================================================================================

A run log is evidence: every record carries a ``digest`` chained over the records before it,
``sha256(previous digest + the record's canonical JSON)`` (the canonical JSON is the record
without its digest, keys sorted, no spaces; the header's previous digest is :data:`GENESIS`).
An edited, dropped, reordered or inserted record breaks the chain at the first record that
differs; :func:`verify` names it by its line. A log cut at a line boundary keeps a valid
chain but lacks its end record, and is refused for that.
"""

from __future__ import annotations

import hashlib
import json
import math
from pathlib import Path
from typing import IO, Any

from diagnostics import MclError, Span

from petri.net import Net
from petri.execution.player import Record

FORMAT = "mcl-run-log/2"
GENESIS = "0" * 64  # the "previous digest" of the header
END = "end"  # the kind of the last record of a run that ended (however it ended)


def net_digest(net: Net) -> str:
    """A digest of the net itself: its places, transitions, arcs, actions, timers, events and
    the mission lines they come from, but not the names of the files (the same mission named
    ``missions/x.mcl`` at the run and ``x.mcl`` at the replay is the same net)."""
    described = net.to_dict()
    for element in [*described["places"], *described["transitions"]]:
        origin = element.get("origin") if isinstance(element, dict) else None
        if isinstance(origin, dict):
            origin["file"] = ""
    text = json.dumps(described, sort_keys=True, separators=(",", ":"), default=str)
    return hashlib.sha256(text.encode()).hexdigest()[:16]


def canonical(record: dict[str, Any]) -> str:
    """The text a record's digest is computed over: JSON, keys sorted, no digest, no spaces."""
    body = {k: v for k, v in record.items() if k not in ("digest", "_line")}
    return json.dumps(body, sort_keys=True, separators=(",", ":"))


def chain(previous: str, record: dict[str, Any]) -> str:
    """The digest of ``record`` following a record whose digest is ``previous``."""
    return hashlib.sha256((previous + canonical(record)).encode()).hexdigest()


class RunLog:
    """An observer of the player that appends each record to a file, flushed at once."""

    def __init__(self, path: str | Path, header: dict[str, Any]):
        self.path = Path(path)
        self.path.parent.mkdir(parents=True, exist_ok=True)
        self._file: IO[str] = open(self.path, "w", encoding="utf-8")  # noqa: SIM115
        self._digest = GENESIS
        self._write({"kind": "header", "format": FORMAT, **header})

    def __call__(self, record: Record) -> None:
        self._write({"t": round(record.t, 6), "kind": record.kind, **record.data})

    def end(self, t: float, how: str, why: str = "", **more: Any) -> None:
        """The last record: how the run ended (ok, fail, timeout, stuck, stopped, error...)
        and why."""
        self._write({"t": round(t, 6), "kind": END, "how": how, "why": why, **more})

    def _write(self, obj: dict[str, Any]) -> None:
        # as a reader will see it (tuples become lists, keys strings, odd values text)
        plain = json.loads(json.dumps(obj, default=str))
        self._digest = chain(self._digest, plain)
        plain["digest"] = self._digest
        self._file.write(json.dumps(plain, separators=(",", ":")) + "\n")
        self._file.flush()

    def close(self) -> None:
        self._file.close()

    def __enter__(self) -> RunLog:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


class LogError(MclError, ValueError):
    """A run log that cannot be read or is not what the run wrote; says which line.

    ``str()`` is ``file:line: reason`` (``file: reason`` for the file as a whole);
    :meth:`format` gives ``file:line:col: error: reason`` (the column of a JSON error)."""

    def __init__(self, message: str, line: int | None = None, reason: str = "", *,
                 path: str | Path | None = None, col: int = 1) -> None:
        self.line = line
        self.reason = reason or message  # without the file and line
        span = None
        if path is not None:
            span = Span.of_file(str(path)) if line is None else Span(str(path), line, col)
        super().__init__(self.reason, span=span, code="run-log", text=message)


def read_log(path: str | Path) -> list[dict[str, Any]]:
    """The records of a run log, each with its line number as ``_line``. Refuses (LogError,
    naming the line) a file that is not a run log, a record that is not a JSON object with a
    ``kind``, a record without a finite time ``t``, and a last line cut off. The digest chain
    and the end record are checked by :func:`verify`."""
    records = []
    try:
        with open(path, encoding="utf-8") as f:
            for number, line in enumerate(f, start=1):
                if not line.endswith("\n"):
                    raise _bad(path, number, "the last record is cut off (the log is "
                               "truncated)", col=len(line) + 1)
                records.append(_record(path, number, line))
    except FileNotFoundError:
        raise _unreadable(path, "no such file") from None
    except IsADirectoryError:
        raise _unreadable(path, "is a directory, not a run log") from None
    except PermissionError:
        raise _unreadable(path, "permission denied") from None
    except UnicodeDecodeError:
        raise _unreadable(path, "not a text file") from None
    except OSError as exc:
        raise _unreadable(path, f"cannot be read ({exc.strerror or exc})") from None
    if not records or records[0].get("kind") != "header" or \
            not str(records[0].get("format", "")).startswith("mcl-run-log/"):
        raise _bad(path, 1, f"not an MCL run log (no '{FORMAT}' header)")
    return records


def _record(path: str | Path, number: int, line: str) -> dict[str, Any]:
    try:
        obj = json.loads(line)
    except json.JSONDecodeError as exc:
        raise _bad(path, number, f"not a JSON record ({exc.msg})", col=exc.colno) from None
    except RecursionError:
        raise _bad(path, number, "not a JSON record (nested too deeply)") from None
    if not isinstance(obj, dict) or not isinstance(obj.get("kind"), str):
        raise _bad(path, number, "not a run-log record (a JSON object with a \"kind\")")
    if obj["kind"] != "header":
        t = obj.get("t")
        if isinstance(t, bool) or not isinstance(t, (int, float)) or not math.isfinite(t):
            raise _bad(path, number, f"record {obj['kind']!r} has no valid time ('t' is "
                       f"{t!r}; a number of seconds is needed)")
    obj["_line"] = number
    return obj


def verify(records: list[dict[str, Any]], path: str | Path) -> None:
    """Check the log as evidence (LogError naming the first record that is not right): the
    format, the header's fields, every record's digest in the chain, time that never goes
    back, and an end record last."""
    header = records[0]
    if header.get("format") != FORMAT:
        raise _bad(path, 1, f"format {header.get('format')!r}, not {FORMAT!r}: this log "
                   "carries no digest chain and cannot be checked as evidence")
    for field, kind in (("net", str), ("params", dict), ("tasks", list)):
        if field in header and not isinstance(header[field], kind):
            raise _bad(path, 1, f"the header's {field!r} is not a {kind.__name__}")
    if any(not isinstance(v, str) for v in (header.get("params") or {}).values()):
        raise _bad(path, 1, "the header's 'params' must map names to MCL text")
    if any(not isinstance(v, str) for v in header.get("tasks") or []):
        raise _bad(path, 1, "the header's 'tasks' must be file names")
    previous, last_t = GENESIS, -math.inf
    for r in records:
        line = r["_line"]
        digest = r.get("digest")
        if not isinstance(digest, str):
            raise _bad(path, line, "the record has no digest: it was not written by the run "
                       "(inserted, or its digest removed)")
        if digest != chain(previous, r):
            raise _bad(path, line, "the digest chain breaks here: this record was edited, "
                       "or one before it was dropped, moved or inserted")
        previous = digest
        if r["kind"] == "header":
            if line != 1:
                raise _bad(path, line, "a second header")
            continue
        t = float(r["t"])
        if t < last_t:
            raise _bad(path, line, f"time goes back ({t:g} s after {last_t:g} s)")
        last_t = t
    last = records[-1]
    if len(records) == 1:
        raise _bad(path, 2, "the log has only its header: the run never started, or the log "
                   "was cut after line 1")
    if not ended(last):
        raise _bad(path, last["_line"] + 1, "the log ends without its end record: the run "
                   f"did not finish writing it, or the log was cut after line {last['_line']}")
    for r in records[1:-1]:
        if r["kind"] == END:
            raise _bad(path, r["_line"], "an end record before the end of the log")


def _unreadable(path: str | Path, reason: str) -> LogError:
    return LogError(f"{path}: {reason}", None, reason, path=path)


def _bad(path: str | Path, line: int, reason: str, col: int = 1) -> LogError:
    return LogError(f"{path}:{line}: {reason}", line, reason, path=path, col=col)


def ended(record: dict[str, Any]) -> bool:
    """Is this the record a run writes last, however it ended?"""
    return record.get("kind") == END
