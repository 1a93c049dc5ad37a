"""What ``mcl run`` adds for Foxglove (docs/MCAP.md): ``--foxglove HOST:PORT``, the run
served live while it goes on (mission/foxglove_live.py), and ``--mcap FILE``, the run written
as an MCAP file once its log is (app/export.py). Neither ever changes the run's exit status
once it has started; an address or a file refused before the start is invalid input."""

from __future__ import annotations

import argparse
import sys
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING, Any

from diagnostics import MclError

if TYPE_CHECKING:
    from mcl.api import Compiled
    from mission.foxglove_live import LiveView


def address(text: str) -> tuple[str, int]:
    """``--foxglove``: HOST:PORT, as argparse wants a type."""
    from mission.foxglove_live import address as parsed  # start-up speed: only --foxglove

    try:
        return parsed(text)
    except ValueError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None


def serve(where: tuple[str, int] | None, compiled: Compiled, stack: Any,
          header: dict[str, Any]) -> LiveView | None:
    """The live view of ``--foxglove`` (None without it), serving before the run starts and
    following the simulated vehicle's survey (``stack``: None for another vehicle)."""
    if where is None:
        return None
    from mission.foxglove_live import LiveView, task_calls  # start-up speed: only --foxglove

    live = LiveView(*where, {**header, "mission": compiled.name}, task_calls(compiled.net))
    print(f"mcl run: serving Foxglove at ws://{where[0]}:{live.port} (foxglove.sdk.v1)",
          file=sys.stderr, flush=True)
    if stack is not None:
        live.follow(stack.survey)
    return live


def write_at_end(path: Path, stack: Any, log_path: Path, say: Callable[[str], None],
                 warn: Callable[[str], None]) -> None:
    """``--mcap``: the run as an MCAP file, from its log once written, with the simulated
    vehicle's whole track; why not, on one line (``warn``)."""
    from app.export import export  # here for start-up speed: only a run that asks for it
    from mission.mcap_export import track_of_survey

    track = track_of_survey(stack.survey) if stack is not None else None
    try:
        written = export(log_path, path, track)
    except MclError as exc:
        warn(f"mcl run: --mcap {path}: not written: {exc.format().splitlines()[0]}")
        return
    say(f"  mcap: {written.line()}")
