"""What ``mcl view`` shows of a finished run, as one JSON-ready dict the page renders.

- ``tree``: the mission as its MCL tree (mcl/ast.py), each block with its id
  (``KIND@LINE:COL``, mission/blocks.py's key), its title as written and its source line;
- ``changes``: every change of a block's state, ``[t, id, state]`` in the order of the
  firings (mission/blocks.py: the one model of block states);
- ``timeline``: the actions, events, long tasks' progress and the end, each with its mission
  time and its line;
- ``bounds``: the proved [best, worst] of the mission and of each block
  (mcl/analysis/duration.py), from which the page says the time left at any instant;
- ``track``: the vehicle's positions ``[t, x, y, z]``: the log's ``pose`` records where it
  has them, else the camera's navigated positions (``RUN.images/index.csv``), else none;
- ``pictures``: the mosaic, coverage map and trajectory plot found beside the log.
"""

from __future__ import annotations

import csv
import math
from pathlib import Path
from typing import Any

from mcl import ast, printer
from mcl.analysis.duration import analyse, json_number
from mcl.api import Compiled
from mission.blocks import KINDS, BlockStates, block_id, key_of

from app.monitor import task_detail

PICTURES = {"mosaic": ".mosaic.png", "coverage": ".coverage.png", "trajectory": ".svg"}
MAX_TRACK = 5000  # points sent to the page, at most (a long run is thinned evenly)


def title(block: ast.Block) -> str:
    """A block's heading in the tree, in MCL's words."""
    match block:
        case ast.Call():
            return printer.call(block)
        case ast.Sequence(items=items):
            return f"sequence of {len(items)}"
        case ast.TryCatchDo():
            return "TRY … CATCH … DO"
        case ast.ParallelAnd():
            return "PARALLEL AND"
        case ast.ParallelOr():
            return "PARALLEL OR"
        case ast.IfThenElse():
            return "IF … THEN … ELSE" if block.else_ is not None else "IF … THEN"
        case ast.WhileDo():
            return "WHILE … DO"
    raise TypeError(f"not a block: {block!r}")


SLOTS: dict[type, tuple[str, ...]] = {  # the words before each child of a construct
    ast.TryCatchDo: ("TRY", "CATCH", "DO"), ast.IfThenElse: ("IF", "THEN", "ELSE"),
    ast.WhileDo: ("WHILE", "DO")}


def node(block: ast.Block, slot: str = "") -> dict[str, Any]:
    """A block and its children as the page's tree (recursive: a mission's depth is that of
    its source, which the parser has already bounded)."""
    words = SLOTS.get(type(block), ())
    kids = ast.children(block)
    return {"id": block_id(key_of(block)), "kind": KINDS[type(block)], "slot": slot,
            "title": title(block), "line": block.span.line,
            "children": [node(child, words[i] if i < len(words) else "")
                         for i, child in enumerate(kids)]}


def tree(mission: ast.Mission, name: str) -> dict[str, Any]:
    """The mission (called ``name``) as a tree: its body, then its stop handler under
    ``ON STOP``."""
    children = [node(mission.body)]
    if mission.on_stop is not None:
        children.append({"id": "", "kind": "ON STOP", "slot": "", "title": "ON STOP",
                         "line": mission.stop_span.line,
                         "children": [node(mission.on_stop)]})
    return {"id": "MISSION", "kind": "MISSION", "slot": "",
            "title": f"MISSION {name}", "line": mission.span.line,
            "children": children}


def line_of(task: str) -> int | None:
    """``GoTo@34:9`` -> 34 (None for ``MISSION`` and other callers without a place)."""
    _, at, where = task.partition("@")
    try:
        return int(where.split(":")[0].split("#")[0]) if at else None
    except ValueError:
        return None


def timeline(records: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """The actions, events and the end, each linked to a line: an action to its task
    call's, an event to that of the firing it caused (none if nothing waited for it)."""
    out: list[dict[str, Any]] = []
    waiting: list[dict[str, Any]] = []  # events not yet matched to the firing they caused
    for r in records[1:]:
        kind, t = r.get("kind"), float(r.get("t", 0.0))
        if kind == "action":
            params = ", ".join(f"{k}={v}" for k, v in (r.get("params") or {}).items())
            text = f"{r['action']} {r['behaviour']}" + (f"({params})" if params else "")
            out.append({"t": t, "kind": "action", "text": text[:160], "task": r.get("task"),
                        "line": line_of(str(r.get("task", "")))})
        elif kind in ("event", "ignored"):
            text = str(r["event"])
            if kind == "ignored":
                text += f" (ignored: {r.get('reason', 'nobody waits for it')})"
            entry = {"t": t, "kind": "event", "text": text, "line": None}
            if kind == "event":
                waiting.append(entry)
            out.append(entry)
        elif kind == "fire":
            for entry in waiting:
                if entry["text"] == r.get("cause"):
                    entry["line"] = r.get("line")
                    waiting.remove(entry)
                    break
        elif kind == "progress":  # a long task, once a minute (mission/progress.py)
            task = str(r.get("task", ""))
            out.append({"t": t, "kind": "progress", "task": task, "line": line_of(task),
                        "text": f"{task} … {task_detail(r, t)}"[:200]})
        elif kind == "end":
            out.append({"t": t, "kind": "end", "line": None,
                        "text": f"mission ends {str(r.get('status', r['how'])).upper()}"
                                f" ({r['how']}: {r['why']})"[:200]})
    return out


def bounds(compiled: Compiled) -> dict[str, Any]:
    """The proved [best, worst] of the mission and of each block (null: unbounded)."""
    durations = analyse(compiled.checked)
    kinds = {cls.__name__: kind for cls, kind in KINDS.items()}
    return {"best": json_number(durations.best), "worst": json_number(durations.worst),
            "blocks": {block_id((kinds.get(b.construct, b.construct), b.line, b.col)):
                       [json_number(b.best), json_number(b.worst)]
                       for b in durations.blocks}}


def track(records: list[dict[str, Any]], log: Path) -> tuple[str, list[list[float]]]:
    """The vehicle's positions and where they come from ("" if nowhere)."""
    points = [[float(r["t"]), float(r["x"]), float(r["y"]), float(r["z"])]
              for r in records if r.get("kind") == "pose"
              and all(isinstance(r.get(k), (int, float)) for k in ("t", "x", "y", "z"))]
    source = "the run log's poses"
    if not points:
        source, points = "the camera's navigated positions", images_track(log)
    points = [p for p in points if all(math.isfinite(v) for v in p)]
    if len(points) > MAX_TRACK:
        step = len(points) / MAX_TRACK
        points = [points[int(i * step)] for i in range(MAX_TRACK)]
    return (source if points else ""), points


def images_track(log: Path) -> list[list[float]]:
    """The navigated positions of the run's images (``RUN.images/index.csv``), if any."""
    index = log.with_suffix(".images") / "index.csv"
    try:
        with index.open(newline="", encoding="utf-8") as f:
            return [[float(row["t"]), float(row["nav_x"]), float(row["nav_y"]),
                     float(row["nav_z"])] for row in csv.DictReader(f)]
    except (OSError, KeyError, ValueError, TypeError):
        return []


def pictures(log: Path) -> dict[str, Path]:
    """The pictures beside the run log: name -> file."""
    found = {name: Path(str(log.with_suffix("")) + suffix) for name, suffix in PICTURES.items()}
    return {name: path for name, path in found.items() if path.is_file()}


def mission_data(compiled: Compiled) -> dict[str, Any]:
    """What the page shows of the mission before any run: its tree, source and bounds."""
    return {"mission": compiled.name, "file": compiled.source.name,
            "source": compiled.source.text.splitlines(),
            "tree": tree(compiled.mission, compiled.name), "bounds": bounds(compiled),
            "changes": [], "timeline": [], "end": {"t": 0.0, "status": None},
            "track": [], "track_from": "", "pictures": {}, "live": False}


def page_data(compiled: Compiled, records: list[dict[str, Any]], log: Path) -> dict[str, Any]:
    """Everything the page shows of the run log ``records`` (header first) of ``compiled``."""
    states = BlockStates(compiled.net).read(records)
    end = next((r for r in reversed(records) if r.get("kind") == "end"), None)
    last = max((float(r.get("t", 0.0)) for r in records[1:]), default=0.0)
    source, points = track(records, log)
    return {**mission_data(compiled),
            "changes": [[c.t, block_id(c.block), c.state] for c in states.changes],
            "timeline": timeline(records),
            "end": {"t": last, "status": str(end.get("status", end["how"])) if end else None},
            "track": points, "track_from": source,
            "pictures": {name: f"pictures/{name}" for name in pictures(log)}}
