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
            order the firing just before sent to the vehicle (``task`` MISSION: the cleanup's);
            ``send`` (a fleet's vehicle): the message ``params.message`` the firing gave to
            the channel ``behaviour``, never to the vehicle
event       ``event``, ``data``: an event that fired transitions
ignored     ``event``, ``reason``: an event that fired nothing
note        ``note``: text for people (never read back by a program)
cleanup     ``behaviours``: the player's own switch-off, when the net has left these on at the
            end (or could not end); a plain disable of each, task MISSION, follows
pose        ``x``, ``y``, ``z`` (m), ``yaw`` (rad): where the vehicle was at ``t`` (a simulated
            vehicle's true pose, about one a second: mission/poses.py); not the player's, so
            a replay passes over it
progress    ``task``, ``since``, ``progress`` (what its behaviour says: ``waypoint``, ``of``,
            ``to_go``), ``bound`` and ``left`` when bounded: how far along a long task is, once
            a minute of mission time (mission/progress.py); not the player's either
==========  ===================================================================================

A run log is evidence. Every line is the record's compact JSON (ASCII, each key once, the
one way :func:`json.dumps` writes it) ending in ``"digest"``: ``sha256(previous digest + the
line's bytes before its digest, closed by "}")``, computed over the bytes written, not over a
re-reading of them (the header's previous digest is :data:`GENESIS`). A log signed with the
player's key (``mcl run --log-key``; :mod:`petri.execution.signing`) also ends each line
with ``"sig"``, the Ed25519 signature of its digest, and its header names the public key
(``"key": "ed25519:HEX"``; ``null`` for an unsigned log). An edited, dropped, reordered or
inserted record breaks the chain at the first line that differs; a forger can recompute the
chain of an unsigned log, not the signatures of a signed one. :func:`verify` names the line.
A log cut at a line boundary keeps a valid chain but lacks its end record, and is refused
for that.

:func:`read_log` refuses, at its line, what it will not interpret: a line longer than
:data:`MAX_LINE` (read no further than that), a log larger than :data:`MAX_LOG`, a key twice
in one object, a number out of range (an integer of more than 20 digits, a float that is
not finite, ``NaN``), a kind of record it does not know, and a line not written the way the
run writes it; those are invalid input (``LogError.invalid``: exit 2), the rest of what is
wrong in a log makes it non-conformant (exit 1).
"""

from __future__ import annotations

import hashlib
import json
import math
import os
import stat
from pathlib import Path
from typing import IO, Any

from diagnostics import MclError, Span

from petri.net import Net
from petri.execution.player import Record
from petri.execution.signing import Signer, public_key, signed

FORMAT = "mcl-run-log/3"
GENESIS = "0" * 64  # the "previous digest" of the header
END = "end"  # the kind of the last record of a run that ended (however it ended)
KINDS = ("header", "status", "fire", "action", "event", "ignored", "note", "cleanup", "pose",
         "progress", END)
MAX_LINE = 1024 * 1024  # bytes: the longest record read (a run writes a few hundred)
MAX_LOG = 256 * 1024 * 1024  # bytes: the largest log read (about a million records)
MAX_DIGITS = 20  # the longest integer read (seeds, indices, exit statuses are shorter)
TAIL = ("digest", "sig")  # the fields that end a line, in this order


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
    """A record's line before its digest: compact JSON, in the record's key order, without
    its digest and signature (for a canonical line, exactly its bytes before them)."""
    body = {k: v for k, v in record.items() if k not in TAIL and not k.startswith("_")}
    return json.dumps(body, separators=(",", ":"))


def chain(previous: str, body: str) -> str:
    """The digest of the record whose line, before its digest, is ``body``, following a
    record whose digest is ``previous``."""
    return hashlib.sha256((previous + body).encode("ascii")).hexdigest()


def finite(value: Any) -> Any:
    """``value`` with every float that is not finite written as its text: JSON has no
    infinity, and a reader refuses ``Infinity``."""
    if isinstance(value, float) and not math.isfinite(value):
        return repr(value)
    if isinstance(value, dict):
        return {k: finite(v) for k, v in value.items()}
    if isinstance(value, list):
        return [finite(v) for v in value]
    return value


class RunLog:
    """An observer of the player that appends each record to a file, flushed at once;
    ``signer``: the player's key, which signs every line (None: a chain only)."""

    def __init__(self, path: str | Path, header: dict[str, Any],
                 signer: Signer | None = None):
        self.path = Path(path)
        self.path.parent.mkdir(parents=True, exist_ok=True)
        self._file: IO[str] = open(self.path, "w", encoding="ascii")  # noqa: SIM115
        self._digest = GENESIS
        self._signer = signer
        self._write({"kind": "header", "format": FORMAT, **header,
                     "key": signer.public() if signer is not None else None})

    def __call__(self, record: Record) -> None:
        self._write({"t": round(record.t, 6), "kind": record.kind, **record.data})

    def pose(self, t: float, **where: float) -> None:
        """Where the vehicle was at ``t`` (``x``, ``y``, ``z``, ``yaw``): a ``pose`` record."""
        self._write({"t": round(t, 6), "kind": "pose", **where})

    def progress(self, t: float, **report: Any) -> None:
        """How far along a running task is at ``t``: a ``progress`` record."""
        self._write({"t": round(t, 6), "kind": "progress", **report})

    def end(self, t: float, how: str, why: str = "", **more: Any) -> None:
        """The last record: how the run ended (ok, fail, timeout, stuck, stopped, error...)
        and why."""
        self._write({"t": round(t, 6), "kind": END, "how": how, "why": why, **more})

    def _write(self, obj: dict[str, Any]) -> None:
        # as a reader will see it (tuples become lists, keys strings, odd values text)
        plain = finite(json.loads(json.dumps(obj, default=str)))
        body = json.dumps({k: v for k, v in plain.items() if k not in TAIL},
                          separators=(",", ":"))
        self._digest = chain(self._digest, body)
        tail = f',"digest":"{self._digest}"'
        if self._signer is not None:
            tail += f',"sig":"{self._signer.sign(self._digest)}"'
        self._file.write(body[:-1] + tail + "}\n")
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
    :meth:`format` gives ``file:line:col: error: reason`` (the column of a JSON error).
    ``invalid``: input refused as such (exit 2), not a log that fails to conform (exit 1)."""

    def __init__(self, message: str, line: int | None = None, reason: str = "", *,
                 path: str | Path | None = None, col: int = 1, invalid: bool = False) -> None:
        self.line = line
        self.reason = reason or message  # without the file and line
        self.invalid = invalid or line is None
        span = None
        if path is not None:
            span = Span.of_file(str(path)) if line is None else Span(str(path), line, col)
        super().__init__(self.reason, span=span, code="run-log", text=message)


def read_log(path: str | Path) -> list[dict[str, Any]]:
    """The records of a run log, each with its line number as ``_line`` and its line's bytes
    before its digest as ``_body``. Refuses (LogError, naming the line) a file that is not a
    run log, what the module's doc lists as invalid input, a record that is not a JSON
    object with a ``kind``, a record without a finite time ``t``, and a last line cut off.
    The digest chain, the signatures and the end record are checked by :func:`verify`."""
    records = []
    try:
        with _open(path) as f:
            for number in range(1, MAX_LOG):
                raw = f.readline(MAX_LINE + 1)
                if not raw:
                    break
                if len(raw) > MAX_LINE:
                    raise _bad(path, number, f"a line longer than {MAX_LINE // 1024} KiB (the "
                               "longest record a run log may hold): not read further",
                               invalid=True)
                if not raw.endswith(b"\n"):
                    raise _bad(path, number, "the last record is cut off (the log is "
                               "truncated)", col=len(raw) + 1)
                records.append(_record(path, number, raw))
    except FileNotFoundError:
        raise _unreadable(path, "no such file") from None
    except IsADirectoryError:
        raise _unreadable(path, "is a directory, not a run log") from None
    except PermissionError:
        raise _unreadable(path, "permission denied") from None
    except OSError as exc:
        raise _unreadable(path, f"cannot be read ({exc.strerror or exc})") from None
    if not records or records[0].get("kind") != "header" or \
            not str(records[0].get("format", "")).startswith("mcl-run-log/"):
        raise _bad(path, 1, f"not an MCL run log (no '{FORMAT}' header)")
    return records


def _open(path: str | Path) -> IO[bytes]:
    """The log, opened for reading: a regular file no larger than :data:`MAX_LOG` (a FIFO
    or a device is refused, not read)."""
    fd = os.open(path, os.O_RDONLY | os.O_NONBLOCK)
    mode = os.fstat(fd)
    if not stat.S_ISREG(mode.st_mode) or mode.st_size > MAX_LOG:
        os.close(fd)
        if stat.S_ISDIR(mode.st_mode):
            raise IsADirectoryError(path)
        raise _unreadable(path, "not a regular file (a run log is a file 'mcl run' wrote)"
                          if not stat.S_ISREG(mode.st_mode) else
                          f"larger than {MAX_LOG // 2**20} MiB, the largest run log read")
    return os.fdopen(fd, "rb")


class _Refused(ValueError):
    """A value the reader will not take (a duplicate key, a number out of range)."""


def _pairs(pairs: list[tuple[str, Any]]) -> dict[str, Any]:
    obj: dict[str, Any] = {}
    for key, value in pairs:
        if key in obj:
            raise _Refused(f"the key {json.dumps(key)[:40]} twice in one object (which one "
                           "counts is a matter of the reader)")
        obj[key] = value
    return obj


def _integer(text: str) -> int:
    if len(text.lstrip("-")) > MAX_DIGITS:
        raise _Refused(f"an integer of {len(text.lstrip('-'))} digits (at most {MAX_DIGITS})")
    return int(text)


def _float(text: str) -> float:
    value = float(text)
    if not math.isfinite(value):
        raise _Refused(f"a number out of range ({text[:20]}{'...' if len(text) > 20 else ''})")
    return value


def _constant(text: str) -> Any:
    raise _Refused(f"{text} is not a JSON number")


DECODER = json.JSONDecoder(object_pairs_hook=_pairs, parse_int=_integer, parse_float=_float,
                           parse_constant=_constant)


def _record(path: str | Path, number: int, raw: bytes) -> dict[str, Any]:
    try:
        line = raw.decode("ascii")
    except UnicodeDecodeError as exc:
        raise _bad(path, number, "a byte that is not ASCII (a run writes \\u escapes): not "
                   "written by the run", col=exc.start + 1, invalid=True) from None
    try:
        obj = DECODER.decode(line)
    except json.JSONDecodeError as exc:
        raise _bad(path, number, f"not a JSON record ({exc.msg})", col=exc.colno) from None
    except _Refused as exc:
        raise _bad(path, number, f"refused: {exc}", invalid=True) from None
    except RecursionError:
        raise _bad(path, number, "not a JSON record (nested too deeply)") from None
    if not isinstance(obj, dict) or not isinstance(obj.get("kind"), str):
        raise _bad(path, number, "not a run-log record (a JSON object with a \"kind\")")
    if obj["kind"] not in KINDS:
        raise _bad(path, number, f"a record of an unknown kind {json.dumps(obj['kind'])[:40]} "
                   f"(a run log holds {', '.join(KINDS)})", invalid=True)
    if json.dumps(obj, separators=(",", ":")) + "\n" != line:
        raise _bad(path, number, "not written as the run writes a record (compact JSON, "
                   "one way to write each value)", invalid=True)
    keys = list(obj)
    tail = [k for k in keys if k in TAIL]
    if tail and keys[-len(tail):] != [k for k in TAIL if k in obj]:
        raise _bad(path, number, "the digest and signature do not end the record: it was "
                   "edited after it was written")
    if obj["kind"] != "header":
        t = obj.get("t")
        if isinstance(t, bool) or not isinstance(t, (int, float)) or not math.isfinite(t):
            raise _bad(path, number, f"record {obj['kind']!r} has no valid time ('t' is "
                       f"{json.dumps(t)[:40]}; a number of seconds is needed)")
    ending = "".join(f',"{k}":{json.dumps(obj[k])}' for k in tail) + "}\n"
    obj["_line"] = number  # the bytes the digest is over: the line before its tail
    obj["_body"] = line[:-len(ending)] + "}" if tail else line[:-1]
    return obj


UNSIGNED = "chain intact, not signed: detects accidents, not forgery"


def verify(records: list[dict[str, Any]], path: str | Path, key: str | None = None) -> str:
    """Check the log as evidence (LogError naming the first line that is not right): the
    format, the header's fields, every line's digest in the chain and, for a signed log,
    its signature by the key its header names, which must be ``key`` when given (``ed25519:
    HEX``); time that never goes back, and an end record last. Returns what was
    established: signed by which key, or :data:`UNSIGNED`."""
    header = records[0]
    if header.get("format") != FORMAT:
        raise _bad(path, 1, f"format {header.get('format')!r}, not {FORMAT!r}: this log "
                   "carries no digest chain over its bytes and cannot be checked as evidence")
    for field, kind in (("net", str), ("params", dict), ("tasks", list)):
        if field in header and not isinstance(header[field], kind):
            raise _bad(path, 1, f"the header's {field!r} is not a {kind.__name__}")
    if any(not isinstance(v, str) for v in (header.get("params") or {}).values()):
        raise _bad(path, 1, "the header's 'params' must map names to MCL text")
    if any(not isinstance(v, str) for v in header.get("tasks") or []):
        raise _bad(path, 1, "the header's 'tasks' must be file names")
    named = header.get("key")
    signer = public_key(named) if isinstance(named, str) else None
    if named is not None and signer is None:
        raise _bad(path, 1, "the header's 'key' is not an Ed25519 public key "
                   "('ed25519:' and 64 hex digits) nor null")
    if key is not None and named != key:
        raise _bad(path, 1, "not signed by the key given with --key: " + (
            "the log is not signed at all" if named is None else
            f"its header names another key ({str(named)[:24]}...)"))
    _chain(records, path, signer)
    _ends(records, path)
    if signer is None:
        return UNSIGNED
    return ("signed by the key given (" if key is not None else
            "signed by the key its header names, which --key would check is yours (") + \
        f"{str(named)[:24]}...)"


def _chain(records: list[dict[str, Any]], path: str | Path, signer: Any) -> None:
    """Every line's digest and signature, and time that never goes back."""
    previous, last_t = GENESIS, -math.inf
    for r in records:
        line = r["_line"]
        digest = r.get("digest")
        if not isinstance(digest, str):
            raise _bad(path, line, "the record has no digest: it was not written by the run "
                       "(inserted, or its digest removed)")
        if digest != chain(previous, r["_body"]):
            raise _bad(path, line, "the digest chain breaks here: this record was edited, "
                       "or one before it was dropped, moved or inserted")
        if signer is not None:
            sig = r.get("sig")
            if not isinstance(sig, str) or not signed(signer, digest, sig):
                raise _bad(path, line, "the signature does not hold: this record (or one "
                           "before it) was not signed with the key the header names")
        elif "sig" in r:
            raise _bad(path, line, "a signature in a log whose header names no key")
        previous = digest
        if r["kind"] == "header":
            if line != 1:
                raise _bad(path, line, "a second header")
            continue
        t = float(r["t"])
        if t < last_t:
            raise _bad(path, line, f"time goes back ({t:g} s after {last_t:g} s)")
        last_t = t


def _ends(records: list[dict[str, Any]], path: str | Path) -> None:
    """One end record, the last."""
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


def _bad(path: str | Path, line: int, reason: str, col: int = 1,
         invalid: bool = False) -> LogError:
    return LogError(f"{path}:{line}: {reason}", line, reason, path=path, col=col,
                    invalid=invalid)


def ended(record: dict[str, Any]) -> bool:
    """Is this the record a run writes last, however it ended?"""
    return record.get("kind") == END
