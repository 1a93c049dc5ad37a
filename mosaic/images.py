"""A run's images and the navigation data of each (what
vehicle.sensors.image_recorder.ImageRecorder wrote).

A folder holds ``camera.json`` (intrinsics, the wall plane, the texture's seed and scale, the
planned survey path), ``index.csv`` (one line per image) and the PNG images. :func:`find`
accepts the folder or the run log beside it (``RUN.jsonl`` -> ``RUN.images/``).
"""

from __future__ import annotations

import csv
import io
import json
import math
from dataclasses import dataclass, field
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt

from diagnostics import MclError, Span

from mosaic import image_files
from mosaic.projection import Intrinsics, pose_from_world

Image = npt.NDArray[np.uint8]


class SurveyError(MclError):
    """A folder that is not a run's images, with what to do instead. ``str()`` is
    ``PATH: reason`` (``PATH:LINE: error: ...`` for a bad line of ``index.csv``); :meth:`format`
    gives ``file[:line:col]: error: reason``."""

    def __init__(self, message: str, span: Span | None = None, reason: str = "") -> None:
        super().__init__(reason or message, span=span, code="survey", text=message)


def _refuse(path: Path, reason: str, span: Span | None = None) -> SurveyError:
    return SurveyError(f"{path}: {reason}", span or Span.of_file(str(path)), reason)


@dataclass(frozen=True)
class Frame:
    index: int
    t: float
    file: str
    truth: tuple[float, float, float, float] | None  # camera pose (y, z, d, yaw), simulation
    prior: tuple[float, float, float, float]  # the navigation data's camera pose
    prior_std: tuple[float, float, float, float]


@dataclass
class Survey:
    folder: Path
    k: Intrinsics
    frames: list[Frame]
    wall_x: float = 0.0
    meta: dict[str, Any] = field(default_factory=dict)
    memory: Callable[[int], Image | None] | None = None  # an image's pixels by its index,
    # when the run that took them still has them (mcl run: the camera worker's shared memory)

    def load(self, frame: Frame) -> Image | None:
        """The image of ``frame``: its pixels from :attr:`memory` if the run still has them,
        else decoded from bytes read without following a link and whose PNG header gives the
        camera's size (else None: a damaged image); :func:`read` checked the files, this
        checks them again as they are read."""
        import cv2

        if self.memory is not None:
            kept = self.memory(frame.index)
            if kept is not None:
                return kept
        data = image_files.read_image(self.folder, frame.file, self.k.width, self.k.height)
        if data is None:
            return None
        img = cv2.imdecode(np.frombuffer(data, np.uint8), cv2.IMREAD_COLOR)
        return None if img is None else np.asarray(img, dtype=np.uint8)

    def plan(self) -> list[tuple[float, float]]:
        return [(float(p[0]), float(p[1])) for p in self.meta.get("plan") or []]


def images_folder(log: Path) -> Path:
    """Where a run log's images go: ``RUN.jsonl`` -> ``RUN.images``."""
    return log.with_suffix(".images")


def find(path: str | Path) -> Path:
    """The images folder of a run log, or the folder itself."""
    p = Path(path)
    if p.is_dir():
        return p
    folder = images_folder(p)
    if folder.is_dir():
        return folder
    if not p.exists():
        raise _refuse(p, "no such run log or folder")
    raise _refuse(p, f"no images beside this run log (expected the folder {folder})")


def _f(row: dict[str, str], key: str) -> float:
    v = row.get(key, "")
    return float(v) if v not in ("", None) else math.nan


def read(path: str | Path, max_bytes: int = image_files.MAX_BYTES) -> Survey:
    """Read a run's images folder (or the run log beside it); SurveyError if it is not one,
    or if its files are not what they must be (mosaic/image_files.py: file names in the
    folder, regular files, PNG headers of the camera's size, all within ``max_bytes``).
    Nothing is decoded here."""
    folder = find(path)
    meta_path, index_path = folder / "camera.json", folder / "index.csv"
    if not meta_path.exists() or not index_path.exists():
        raise _refuse(folder, "not a run's images (camera.json and index.csv missing)")
    try:
        meta = json.loads(image_files.read_text(meta_path))
        k = Intrinsics.from_dict(meta["intrinsics"])
        wall_x = float(meta.get("wall", {}).get("x", 0.0))
        image_files.check_camera(k.width, k.height)
        image_files.check_optics(k.width, k.height, (k.fx, k.fy), (k.cx, k.cy))
    except (ValueError, KeyError, TypeError, AttributeError, OSError) as exc:
        at = (Span(str(meta_path), exc.lineno, exc.colno)
              if isinstance(exc, json.JSONDecodeError) else None)
        raise _refuse(meta_path, f"unreadable camera description ({exc})", at) from None
    try:
        index = image_files.read_text(index_path)
    except (ValueError, OSError) as exc:
        raise _refuse(index_path, f"unreadable index ({exc})") from None
    frames = []
    for line, row in enumerate(csv.DictReader(io.StringIO(index, newline="")), start=2):
        try:
            frames.append(_frame(row, wall_x))
            image_files.check_image(folder, row["file"], k.width, k.height)
        except (ValueError, KeyError, TypeError, OverflowError) as exc:
            reason = f"bad index line ({exc})"
            raise SurveyError(f"{index_path}:{line}: error: {reason}",
                              Span(str(index_path), line, 1), reason) from None
    need = image_files.survey_bytes(len(frames), k.width, k.height)
    if need > max_bytes:
        raise _refuse(folder, f"{len(frames):,} images of {k.width} x {k.height} pixels need "
                              f"about {need / 2**20:,.0f} MiB, more than the mosaic's memory "
                              f"budget of {max_bytes / 2**20:,.0f} MiB (--max-memory)")
    return Survey(folder, k, frames, wall_x, meta)


def _frame(row: dict[str, str], wall_x: float) -> Frame:
    """The frame of one line of ``index.csv``."""
    truth = None
    if row.get("x"):
        truth = pose_from_world(_f(row, "x"), _f(row, "y"), _f(row, "z"), _f(row, "psi"),
                                wall_x)
    nx, ny, nz, npsi = (_f(row, k_) for k_ in ("nav_x", "nav_y", "nav_z", "nav_psi"))
    d, dstd = _f(row, "wall_distance"), _f(row, "wall_distance_std")
    head, hstd = _f(row, "wall_heading"), _f(row, "wall_heading_std")
    if not math.isfinite(d):  # no wall tracker: the navigator's x
        d, dstd = wall_x - nx, _f(row, "nav_std_x")
    if not math.isfinite(head):
        head, hstd = npsi, _f(row, "nav_std_psi")
    prior = (ny, nz, d, math.remainder(head, 2 * math.pi))
    std = (_f(row, "nav_std_y"), _f(row, "nav_std_z"), dstd, hstd)
    if not all(math.isfinite(v) for v in prior + std):
        raise ValueError("missing navigation data")
    return Frame(int(row["index"]), _f(row, "t"), row["file"], truth, prior,
                 tuple(max(s, 1e-4) for s in std))  # type: ignore[arg-type]
