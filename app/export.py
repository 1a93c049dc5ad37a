"""``mcl export``: a run log as an MCAP file for Foxglove (docs/MCAP.md).

    mcl export RUN.jsonl [RUN2.jsonl ... channels.jsonl] --mcap OUT.mcap [--no-images]

The log is read and its digest chain (and signatures) verified first
(petri/execution/runlog.py): a log that does not verify is refused (``RUN.jsonl:N: error:
...``, exit 2) and nothing is written. The MCAP file then holds what the log and the files
the run wrote beside it hold: every record as a ``foxglove.Log`` with its MCL line, each task
call's state, the camera's images (``RUN.images/``) with the true and estimated pose of each,
and as attachments the mission, its task libraries and the mosaic. Several logs (a fleet's
runs) go into one file, each vehicle's topics, metadata and attachments under ``/NAME``, its
log's file name without ``.jsonl``; a fleet's channel record among them (its header says
so, whatever its name) is verified too and its events go under ``/channel/NAME``
(mission/mcap_channels.py). ``mcl run --mcap`` writes
the same file at the end of a run, with the simulated vehicle's whole track. Exit statuses
(written, invalid input): docs/EXIT.md.
"""

from __future__ import annotations

import argparse
import os
import stat
import sys
from pathlib import Path
from typing import Any

from diagnostics import MclError, Source
from mcl import parser, tasklib
from mission.exits import Exit
from mission.channels import RECORD_FORMAT
from mission.fleet_evidence import read_record
from mission.mcap_channels import channel_messages, fleet_metadata, track_of_poses
from mission.mcap_export import Run, Shared, Track, Written, camera_index, write_fleet
from mosaic.images import images_folder
from petri.execution.replay import malformed
from petri.execution.runlog import LogError, read_log, verify

from app import arguments
from app.guard import guarded
from app.outputs import OutputError, check_output

MAX_ATTACHED = 4 * 1024 * 1024  # bytes: the largest mission or task library attached
MAX_MOSAIC = 64 * 1024 * 1024  # bytes: the largest mosaic attached (the dam's: 5.5 MB)
MOSAIC_SUFFIXES = (".mosaic.png", ".coverage.png", ".mosaic.json")


def _parser() -> argparse.ArgumentParser:
    p = arguments.Parser(prog="mcl export", description="Write a run log, verified, "
                                "as an MCAP file that Foxglove opens (docs/MCAP.md).")
    p.add_argument("logs", metavar="RUN.jsonl", nargs="+",
                   help="a run log; several (a fleet's): each vehicle under /NAME, its log's "
                        "file name without .jsonl; a fleet's channel record (channels.jsonl): "
                        "its messages under /channel/NAME")
    p.add_argument("--mcap", required=True, metavar="OUT.mcap", help="the MCAP file to write")
    p.add_argument("--no-images", action="store_true",
                   help="leave the camera's images out (a much smaller file)")
    p.add_argument("--debug", action="store_true", help="show tracebacks of internal errors")
    return p


def main(argv: list[str] | None = None) -> int:
    """``mcl export ARGS`` (``argv``: what follows ``export``)."""
    args = _parser().parse_args(sys.argv[1:] if argv is None else argv)
    return guarded("export", args.debug, lambda: _export(args))


def _export(args: argparse.Namespace) -> int:
    check_output(args.mcap, "--mcap")  # as given: Path("") would be the folder "."
    given = [Path(log) for log in args.logs]
    records = [p for p in given if is_channel_record(p)]
    logs = [p for p in given if p not in records]
    if len(records) > 1 or not logs:
        raise MclError(f"{records[-1]}: " + ("two channel records: give one fleet's logs "
                       "and its one record" if logs else "a channel record alone: give the "
                       "fleet's run logs with it"), code="fleet")
    if len(logs) == 1 and not records:
        written = export(logs[0], Path(args.mcap), images=not args.no_images)
    else:
        written = export_fleet(logs, Path(args.mcap), images=not args.no_images,
                               record=records[0] if records else None)
    print(f"{', '.join(args.logs)}: exported to {written.line()}")
    return Exit.OK


def export(log: Path, out: Path, track: Track | None = None, images: bool = True) -> Written:
    """Verify the run log ``log`` (LogError if it does not) and write its MCAP file ``out``;
    ``track``: the vehicle's track when the caller has a better one than the camera's index
    (``mcl run`` of the simulated vehicle)."""
    run = _run(log, images)
    if track is not None:
        run.track = track
    check_output(str(out), "--mcap")
    return _written(out, [run])


def export_fleet(logs: list[Path], out: Path, images: bool = True, record: Path | None = None,
                 tracks: dict[str, Track] | None = None) -> Written:
    """A fleet's run logs (each verified) in one MCAP file, each vehicle's under ``/NAME``:
    its log's file name without ``.jsonl``, which must differ from log to log; ``record``:
    the fleet's channel record (verified: its events on ``/channel/NAME``, its header as
    the ``mcl.fleet`` metadata, the record attached); ``tracks``: a vehicle's track by name,
    when the caller has one (``mcl run FLEET.mcl --mcap``)."""
    names = [log.stem for log in logs]
    twice = sorted({name for name in names if names.count(name) > 1})
    if twice:
        raise MclError(f"two run logs named {twice[0]!r}: each vehicle's namespace is its "
                       "log's file name, so the names must differ", code="fleet")
    runs = []
    for log in logs:
        run = _run(log, images)
        run.namespace = log.stem
        if log.stem in (tracks or {}):
            run.track = (tracks or {})[log.stem]
        runs.append(run)
    shared = Shared()
    if record is not None:
        lines = read_record(record)
        shared = Shared(channel_messages(lines), {"mcl.fleet": fleet_metadata(lines)},
                        [(record.name, record.read_bytes())])
    check_output(str(out), "--mcap")
    return _written(out, runs, shared)


def is_channel_record(path: Path) -> bool:
    """Whether ``path`` is a fleet's channel record: its first line's header says so."""
    try:
        with open(path, "rb") as f:
            first = f.readline(1 << 16)
    except OSError:
        return False  # the run log's own reading says why
    return f'"format":"{RECORD_FORMAT}"'.encode() in first


def _run(log: Path, images: bool) -> Run:
    """A verified run log with what its run left beside it."""
    records = read_log(log)
    verify(records, log)
    wrong = malformed(records)  # a field its kind needs missing, or of the wrong type
    if wrong is not None:
        raise LogError(f"{log}:{wrong.line}: {wrong.reason}", wrong.line, wrong.reason,
                       path=log, invalid=True)
    pictures, indexed = camera_index(images_folder(log))
    if not indexed.truth:  # no camera: the poses the log holds (a fleet's run)
        indexed = logged_track(records)
    return Run(records, indexed, pictures if images else [], attachments(records[0], log))


def logged_track(records: list[dict[str, Any]]) -> Track:
    """The true poses a run log holds (its ``pose`` records), the dam wall drawn when its
    header's scene has one (mission/poses.py)."""
    track = track_of_poses((float(r["t"]), float(r["x"]), float(r["y"]), float(r["z"]),
                            float(r.get("yaw", 0.0))) for r in records if r["kind"] == "pose")
    scene = records[0].get("scene")
    track.plane = isinstance(scene, dict) and "dam wall" in (scene.get("lines") or {})
    return track


def _written(out: Path, runs: list[Run], shared: Shared | None = None) -> Written:
    try:
        return write_fleet(out, runs, shared)
    except OSError as exc:  # a full disk, no permission, an image removed meanwhile
        raise OutputError(str(out), "--mcap", f"{exc.strerror or exc}"
                          + (f" ({exc.filename})" if exc.filename else "")) from None


def attachments(header: dict[str, Any], log: Path) -> list[tuple[str, bytes]]:
    """The files a run came from and made: the mission (as its header names it, else beside
    the log), its task libraries (those the header names, else its USES, else Ictineu's,
    with the core library) and the mosaic beside the log. What cannot be found is left out."""
    found: list[tuple[str, bytes]] = []
    mission = _readable(Path(str(header.get("file", ""))), log)
    if mission is not None:
        found.append((mission.name, mission.read_bytes()))
    found += _libraries(header, mission)
    for suffix in MOSAIC_SUFFIXES:
        path = log.with_suffix(suffix)
        if _regular(path, MAX_MOSAIC):
            found.append((path.name, path.read_bytes()))
    return found


def _libraries(header: dict[str, Any], mission: Path | None) -> list[tuple[str, bytes]]:
    named = [str(t) for t in header.get("tasks") or []]
    if not named and mission is not None:
        try:
            uses = list(parser.parse(Source(str(mission), mission.read_text("utf-8"))).uses)
        except (MclError, UnicodeDecodeError):
            uses = []
        named = [u.library if tasklib.is_shipped(u.library)
                 else str(mission.parent / u.library) for u in uses]
    out = [("core.tasks", tasklib.shipped_source("core.tasks").text.encode())]
    for name in named or ["ictineu"]:
        if tasklib.is_shipped(name):
            out.append((f"{name}.tasks", tasklib.shipped_source(f"{name}.tasks").text.encode()))
        elif _regular(Path(name)):
            out.append((Path(name).name, Path(name).read_bytes()))
    return out


def _readable(path: Path, log: Path) -> Path | None:
    """The mission file as the header names it (relative to here, else to the log's
    folder), if it is a regular file small enough to attach."""
    for candidate in (path, log.parent / path.name):
        if str(path) and _regular(candidate):
            return candidate
    return None


def _regular(path: Path, limit: int = MAX_ATTACHED) -> bool:
    try:
        st = os.stat(path)
    except OSError:
        return False
    return stat.S_ISREG(st.st_mode) and st.st_size <= limit and os.access(path, os.R_OK)


if __name__ == "__main__":
    sys.exit(main())
