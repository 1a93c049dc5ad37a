"""``mcl mosaic RUN``: (re)make a run's mosaic and coverage map from its images.

    mcl mosaic RUN.jsonl|RUN.images [--scale MM_PER_PX] [--out PREFIX] [--no-truth]
                                    [--max-memory SIZE]

Writes PREFIX.mosaic.png, PREFIX.coverage.png and PREFIX.mosaic.json (default PREFIX: the run
log without its suffix) and prints where, with the figures. Its exit statuses (made, invalid
input): docs/EXIT.md. The folder's files are checked before one image is decoded, and the
images and canvas are sized against ``--max-memory`` (default 2 GiB) before they are
allocated (mosaic/image_files.py): a folder that fails is refused in one line, exit 2.
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

from app.arguments import memory_size
from app.guard import guarded
from mission.exits import Exit
from mosaic.blending import MM_PER_PX
from mosaic.image_files import MAX_BYTES
from mosaic.images import SurveyError, find
from app import arguments


def _scale(text: str) -> float:
    try:
        v = float(text)
    except ValueError:
        v = math.nan
    if not (math.isfinite(v) and 0.5 <= v <= 100.0):
        raise argparse.ArgumentTypeError(f"{text!r}: the scale is mm per pixel, 0.5 to 100")
    return v


def main(argv: list[str] | None = None) -> int:
    p = arguments.Parser(prog="mcl mosaic", description="Make the photomosaic of a "
                                "run's images (paper 002 §6); see docs/MOSAIC.md.")
    p.add_argument("run", metavar="RUN", help="the run log (RUN.jsonl, its images in "
                   "RUN.images/) or the images folder")
    p.add_argument("--scale", type=_scale, default=MM_PER_PX, metavar="MM_PER_PX",
                   help=f"the mosaic's scale (default {MM_PER_PX:g} mm per pixel)")
    p.add_argument("--out", metavar="PREFIX", help="write PREFIX.mosaic.png, "
                   "PREFIX.coverage.png, PREFIX.mosaic.json (default: beside the run log)")
    p.add_argument("--no-truth", action="store_true",
                   help="do not measure against the simulation's ground truth")
    p.add_argument("--max-memory", type=memory_size, default=MAX_BYTES, metavar="SIZE",
                   help="the memory the mosaic may use, e.g. 512MiB, 4GiB (default 2GiB): the "
                        "images and the canvas are sized before they are allocated; a run "
                        "that needs more is refused (a coarser --scale needs less)")
    p.add_argument("--debug", action="store_true", help="show tracebacks of internal errors")
    args = p.parse_args(argv)
    return guarded("mosaic", args.debug, lambda: _mosaic(args))


def _mosaic(args: argparse.Namespace) -> int:
    from mosaic.build import build, summary_lines, write

    try:
        folder = find(args.run)
        result = build(folder, args.scale, measure=not args.no_truth,
                       max_bytes=args.max_memory)
    except SurveyError as exc:
        msg = str(exc)
        head, _, rest = msg.partition(": ")
        if ": error:" not in msg:
            msg = f"{head}: error: {rest}"
        print(f"{msg}\n  hint: mcl mosaic takes the run log of 'mcl run' (its images are in "
              "RUN.images/) or that folder", file=sys.stderr)
        return Exit.INVALID
    except ValueError as exc:
        print(f"{args.run}: error: {exc}", file=sys.stderr)
        return Exit.INVALID
    prefix = Path(args.out) if args.out else (
        folder.with_suffix("") if folder.suffix == ".images" else folder / "run")
    try:
        prefix.parent.mkdir(parents=True, exist_ok=True)
        paths = write(result, prefix)
    except OSError as exc:
        print(f"{prefix}: error: cannot write: {exc.strerror or exc}", file=sys.stderr)
        return Exit.INVALID
    for line in summary_lines(result, paths):
        print(line)
    return Exit.OK


if __name__ == "__main__":
    sys.exit(main())
