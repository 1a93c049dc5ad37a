"""What ``mcl view RUNDIR FLEET.mcl`` shows of a fleet's finished run: every vehicle's tree.

The folder is what ``mcl run FLEET.mcl --log-dir RUNDIR`` wrote: a run log per vehicle
(``NAME.jsonl``) and the channel record (``channels.jsonl``). Each vehicle's log is checked
as ``mcl view`` checks one (its chain, then every record against that vehicle's net) and must
be of that vehicle of this fleet (its header's ``fleet`` and ``as``); the channel record,
when there is one, has its chain checked too.

The page's data is one mission's (app/view/data.py) made of the vehicles': the tree is the
fleet (``FLEET NAME``) with each vehicle's mission under it (``VEHICLE asv · MISSION ...``),
every block's id and state change prefixed by its vehicle (``asv/CALL@12:9``), so that two
vehicles never share one; the timeline is every vehicle's, each entry under its vehicle's
name, with the channels' messages (sent, delivered, lost, dropped, undelivered), in mission
time (the vehicles share one clock from 0); the proved bounds are each vehicle's, and the
fleet's [best, worst] is the largest of theirs (the fleet ends when its last vehicle does);
the tracks are each vehicle's (``tracks``, by name: its log's poses, or live its navigator's
estimate), drawn on one plan over the scene its log's header gives (``scene``: the dam wall,
paper 003's mine and clutter; mission/poses.py).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from petri.execution.replay import check
from petri.execution.runlog import LogError, read_log, verify

from mcl.fleet import CompiledFleet, compile_fleet_file
from mission.fleet_evidence import RecordProblem, read_record
from mission.poses import is_scene

from app.fleet_replay import fleet_header
from app.view.data import page_data

RECORD = "channels.jsonl"


def load_fleet(folder: str, mission: str
               ) -> tuple[CompiledFleet, dict[str, list[dict[str, Any]]], list[dict[str, Any]]]:
    """The fleet, each vehicle's verified records by name, and the channel record's lines
    (empty when the folder has none); a :class:`RecordProblem` (exit 2) at the first
    problem's line otherwise."""
    where = Path(folder)
    if not where.is_dir():
        raise RecordProblem(folder, None, "not a folder: a fleet's logs are the folder "
                            "'mcl run FLEET.mcl --log-dir DIR' wrote", invalid=True)
    fleet = compile_fleet_file(mission, require_values=True)
    logs: dict[str, list[dict[str, Any]]] = {}
    for name, compiled in fleet.vehicles.items():
        path = where / f"{name}.jsonl"
        if not path.is_file():
            raise RecordProblem(path, None, f"no run log of vehicle {name} of fleet "
                                f"{fleet.name}", invalid=True)
        try:
            records = read_log(path)
            verify(records, path)
        except LogError as exc:
            raise RecordProblem(path, exc.line, exc.reason, invalid=True) from None
        why = fleet_header(records[0], fleet, name)
        if why is not None:
            raise RecordProblem(path, 1, why, invalid=True)
        result = check(compiled.net, records, {})
        if not result.ok:
            raise RecordProblem(path, result.line, f"not a run of vehicle {name} of "
                                f"{mission}: {result.reason}", invalid=True)
        logs[name] = records
    record: list[dict[str, Any]] = []
    if (where / RECORD).is_file():
        record = read_record(where / RECORD)
        for r in record:
            r.pop("_line", None)
    return fleet, logs, record


def prefixed(node: dict[str, Any], name: str) -> dict[str, Any]:
    """A vehicle's tree, each block's id under its vehicle's name (recursive, as the tree)."""
    return {**node, "id": f"{name}/{node['id']}" if node["id"] else "",
            "children": [prefixed(child, name) for child in node["children"]]}


def fleet_line(text: str) -> int:
    """The line of the word FLEET (1 if none is found)."""
    return next((i for i, line in enumerate(text.splitlines(), 1)
                 if line.lstrip().startswith("FLEET")), 1)


def worst_of(values: list[float | None]) -> float | None:
    """The largest, or None (unbounded) if any is."""
    return None if any(v is None for v in values) else max(v for v in values if v is not None)


def channel_timeline(record: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """The channel record's messages as timeline entries (no MCL line of their own)."""
    out = []
    for r in record[1:]:
        if r.get("kind") in ("header", "end"):
            continue
        to = f" to {r['receiver']}" if r.get("receiver") else ""
        text = f"channel {r['channel']}: {r['message']} {r['kind']}{to}"
        out.append({"t": float(r["t"]), "kind": "channel", "line": None, "text": text[:200]})
    return out


def fleet_data(fleet: CompiledFleet, logs: dict[str, list[dict[str, Any]]],
               record: list[dict[str, Any]], folder: Path) -> dict[str, Any]:
    """Everything the page shows of the fleet's run (this module's doc)."""
    runs = {name: page_data(compiled, logs[name], folder / f"{name}.jsonl")
            for name, compiled in fleet.vehicles.items()}
    scenes = [logs[name][0].get("scene") for name in fleet.vehicles]
    return {**vehicles_page(fleet, runs, channel_timeline(record)),
            "scene": scene([s for s in scenes if s is not None and is_scene(s)])}


def scene(scenes: list[dict[str, Any]]) -> dict[str, Any]:
    """The vehicles' scenes (their logs' headers: mission/poses.py) as one: each line and
    each set of points once, by name (the vehicles of one world say the same)."""
    lines: dict[str, Any] = {}
    points: dict[str, Any] = {}
    for one in scenes:
        lines = {**one["lines"], **lines}
        points = {**one["points"], **points}
    return {"lines": lines, "points": points}


def vehicles_page(fleet: CompiledFleet, runs: dict[str, dict[str, Any]],
                  channels: list[dict[str, Any]]) -> dict[str, Any]:
    """The fleet's page made of its vehicles' pages (app/view/data.py's, by vehicle name) and
    the channels' timeline entries: a finished run's, or a live one's (app/view/live_fleet.py),
    whose vehicles still running have no end status (then neither has the fleet)."""
    children: list[dict[str, Any]] = []
    changes: list[list[Any]] = []
    timeline: list[dict[str, Any]] = []
    blocks: dict[str, Any] = {}
    for name, data in runs.items():
        tree = prefixed(data["tree"], name)
        tree["title"] = f"VEHICLE {name} · {tree['title']}"
        children.append(tree)
        changes += [[t, f"{name}/{block}", state] for t, block, state in data["changes"]]
        timeline += [{**e, "text": f"{name}: {e['text']}"} for e in data["timeline"]]
        blocks |= {f"{name}/{block}": b for block, b in data["bounds"]["blocks"].items()}
        blocks[f"{name}/MISSION"] = [data["bounds"]["best"], data["bounds"]["worst"]]
    end_t = max(data["end"]["t"] for data in runs.values())
    ends = {name: data["end"]["status"] for name, data in runs.items()}
    status = (None if None in ends.values() else "ok" if all(s == "ok" for s in ends.values())
              else ", ".join(f"{name} {s}" for name, s in ends.items()))
    changes = [[0.0, "MISSION", "running"], *sorted(changes, key=lambda c: c[0])]
    if status is not None:
        changes.append([end_t, "MISSION", "ok" if status == "ok" else "fail"])
    timeline += channels
    timeline.sort(key=lambda e: float(e["t"] or 0))  # (stable: each vehicle's order stays)
    bests = [d["bounds"]["best"] for d in runs.values()]
    return {"mission": f"fleet {fleet.name}", "file": fleet.source.name,
            "source": fleet.source.text.splitlines(),
            "tree": {"id": "MISSION", "kind": "MISSION", "slot": "",
                     "line": fleet_line(fleet.source.text),
                     "title": f"FLEET {fleet.name}", "children": children},
            "bounds": {"best": worst_of(bests),
                       "worst": worst_of([d["bounds"]["worst"] for d in runs.values()]),
                       "blocks": blocks},
            "changes": changes, "timeline": timeline,
            "end": {"t": end_t, "status": status}, "track": [], "track_from": "",
            "tracks": {name: data["track"] for name, data in runs.items()},
            "tracks_from": {name: data["track_from"] for name, data in runs.items()},
            "scene": {"lines": {}, "points": {}},
            "pictures": {}, "live": False, "vehicles": list(runs)}
