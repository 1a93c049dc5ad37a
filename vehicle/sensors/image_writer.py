"""What writes a run's images (docs/MOSAIC.md): each image rendered from its true pose by the
wall camera (vehicle/sensors/camera.py), written as ``NNNNN.png`` with its line of
``index.csv``, and the camera's figures in ``camera.json``.

The images are rendered in the order they were taken, with one random generator for the
sensor noise (seeded by the run's seed), so that a run's images depend on its seed alone —
whichever process renders them (:mod:`vehicle.sensors.image_worker`). With ``encoder`` the PNG
encoding and writing run in a thread of their own, in order, overlapping the next rendering.
The PNGs are encoded for speed: Huffman coding only, and one row filter (AVG) where libpng by
default tries all five on every row — half the time (2.0 ms an image instead of 4.0) for files
1 % larger; the pixels are the same, PNG being lossless.
"""

from __future__ import annotations

import csv
import json
import math
from concurrent.futures import Future, ThreadPoolExecutor
from dataclasses import asdict
from pathlib import Path
from typing import Any

import numpy as np

from vehicle.sensors.camera import WallCamera
from vehicle.sensors.wall_texture import Image, TextureSpec, WallTexture

INDEX_FIELDS = ("index", "t", "file", "x", "y", "z", "psi", "nav_x", "nav_y", "nav_z",
                "nav_psi", "nav_std_x", "nav_std_y", "nav_std_z", "nav_std_psi",
                "wall_distance", "wall_distance_std", "wall_heading", "wall_heading_std")

Pose = tuple[float, float, float, float]


class ImageWriter:
    """Renders and writes the images of a run into ``folder`` (made at the first write):
    :meth:`write` one image, :meth:`set_plan` the planned area, :meth:`flush` waits for the
    encoder, :meth:`close` stops it."""

    def __init__(self, folder: Path, seed: int = 1, wall_curvature: float = 0.0,
                 texture: TextureSpec | None = None, encoder: bool = False) -> None:
        self.folder, self.seed, self.wall_curvature = folder, seed, wall_curvature
        self.spec = texture or TextureSpec(seed=seed)
        self.plan: list[tuple[float, float]] = []
        self._camera: WallCamera | None = None
        self._rng = np.random.default_rng([seed, 6])
        self._started = False
        self._encoder = ThreadPoolExecutor(1, thread_name_prefix="png") if encoder else None
        self._pending: list[Future[None]] = []
        self.failure = ""  # why images stopped being kept: the first that could not be written

    def camera(self) -> WallCamera:
        """The wall camera, its texture made on first use (about a second)."""
        if self._camera is None:
            self._camera = WallCamera(WallTexture(self.spec), self.wall_curvature)
            _ = self._camera.texture.image
        return self._camera

    def _start(self) -> None:
        if not self._started:
            self.folder.mkdir(parents=True, exist_ok=True)
            with (self.folder / "index.csv").open("w", newline="", encoding="utf-8") as f:
                csv.writer(f).writerow(INDEX_FIELDS)
            self._started = True
            self._write_meta()

    def _write_meta(self) -> None:
        cam = self.camera()
        meta = {"intrinsics": asdict(cam.k), "texture": asdict(cam.texture.spec),
                "wall": {"x": 0.0, "curvature": self.wall_curvature,
                         "frame": "y along the wall, z depth (down), m; the wall plane x = 0"},
                "lighting": asdict(cam.light), "visibility": cam.visibility,
                "plan": [list(p) for p in self.plan]}
        (self.folder / "camera.json").write_text(json.dumps(meta, indent=1) + "\n",
                                                 encoding="utf-8")

    def set_plan(self, path: list[tuple[float, float]]) -> None:
        """The planned survey path (y, z) on the wall, written into ``camera.json``."""
        self.flush()  # camera.json after the images queued before it, as it was asked
        self.plan = list(path)
        self._start()
        self._write_meta()

    def write(self, index: int, name: str, t: float, pose: Pose,
              nav: dict[str, float]) -> Image | None:
        """Render the image taken at t from the true ``pose`` and write it with its index
        line (``nav``: the INDEX_FIELDS from nav_x on); the image rendered. The first image
        that cannot be written (a full disk, the folder removed) raises OSError and sets
        :attr:`failure`; no image is rendered after it (None), and nothing more is said (each
        failed write used to print libpng's error again, 1,312 lines on a full disk)."""
        if self.failure:
            return None
        self._start()
        img = self.camera().render(pose, self._rng)  # in order: the generator's sequence
        row: dict[str, Any] = {"index": index, "t": round(t, 3), "file": name,
                               "x": pose[0], "y": pose[1], "z": pose[2], "psi": pose[3]}
        row.update(nav)
        line = [_cell(row.get(k)) for k in INDEX_FIELDS]
        if self._encoder is None:
            self._save(index, name, img, line)
        else:
            self._pending.append(self._encoder.submit(self._save, index, name, img, line))
        return img

    def _save(self, index: int, name: str, img: Image, line: list[str]) -> None:
        import cv2

        if self.failure:  # an earlier image, encoded in the thread, could not be written
            return
        ok, png = cv2.imencode(".png", img, [
            cv2.IMWRITE_PNG_COMPRESSION, 1, cv2.IMWRITE_PNG_STRATEGY,
            cv2.IMWRITE_PNG_STRATEGY_HUFFMAN_ONLY,  # fast: Huffman coding only
            cv2.IMWRITE_PNG_FILTER, cv2.IMWRITE_PNG_FILTER_AVG])  # one filter, not five tried
        try:
            if not ok:
                raise OSError("the PNG encoder failed")
            (self.folder / name).write_bytes(png.tobytes())
            with (self.folder / "index.csv").open("a", newline="", encoding="utf-8") as f:
                csv.writer(f).writerow(line)
        except OSError as exc:
            why = (f"image {name} could not be written in {self.folder} (a full disk? the "
                   f"folder removed?)" if ok else f"image {name}: {exc.strerror or exc}")
            self.failure = f"only the first {index} images kept; {why}" if index else why
            raise OSError(self.failure) from None

    def flush(self) -> None:
        """Wait until every image is written (raises what writing one raised)."""
        pending, self._pending = self._pending, []
        for job in pending:
            job.result()

    def close(self) -> None:
        if self._encoder is not None:
            self._encoder.shutdown(wait=True)


def _cell(v: Any) -> str:
    if v is None:
        return ""
    if isinstance(v, float):
        return "" if not math.isfinite(v) else f"{v:.6g}"
    return str(v)
