"""The run log: JSON Lines, one record per action, event, firing and status change.

Each record is written and flushed as it happens, so a crash loses at most the record being
written. The first record is a header that says which mission, which net (a digest of the
compiled net) and which parameters were run, so that ``mcl replay`` can check the log against
the same net.
"""

from __future__ import annotations

import hashlib
import json
from pathlib import Path
from typing import IO, Any

from .net import Net
from .player import Record

FORMAT = "mcl-run-log/1"


def net_digest(net: Net) -> str:
    text = json.dumps(net.to_dict(), sort_keys=True, separators=(",", ":"), default=str)
    return hashlib.sha256(text.encode()).hexdigest()[:16]


class RunLog:
    """An observer of the player that appends each record to a file, flushed at once."""

    def __init__(self, path: str | Path, header: dict[str, Any]):
        self.path = Path(path)
        self.path.parent.mkdir(parents=True, exist_ok=True)
        self._file: IO[str] = open(self.path, "w", encoding="utf-8")  # noqa: SIM115
        self._write({"kind": "header", "format": FORMAT, **header})

    def __call__(self, record: Record) -> None:
        self._write({"t": round(record.t, 6), "kind": record.kind, **record.data})

    def _write(self, obj: dict[str, Any]) -> None:
        self._file.write(json.dumps(obj, separators=(",", ":"), default=str) + "\n")
        self._file.flush()

    def close(self) -> None:
        self._file.close()

    def __enter__(self) -> RunLog:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


class LogError(ValueError):
    """A run log that cannot be read; says which line."""


def read_log(path: str | Path) -> list[dict[str, Any]]:
    records = []
    try:
        with open(path, encoding="utf-8") as f:
            for number, line in enumerate(f, start=1):
                if not line.endswith("\n"):
                    raise LogError(f"{path}:{number}: the last record is cut off (the log "
                                   "is truncated)")
                try:
                    obj = json.loads(line)
                except json.JSONDecodeError as exc:
                    raise LogError(f"{path}:{number}: not a JSON record ({exc.msg})") from None
                if not isinstance(obj, dict) or "kind" not in obj:
                    raise LogError(f"{path}:{number}: not a run-log record")
                obj["_line"] = number
                records.append(obj)
    except FileNotFoundError:
        raise LogError(f"{path}: no such file") from None
    except UnicodeDecodeError:
        raise LogError(f"{path}: not a text file") from None
    if not records or records[0].get("kind") != "header" or records[0].get("format") != FORMAT:
        raise LogError(f"{path}:1: not an MCL run log (no '{FORMAT}' header)")
    return records
