"""What writes a run's images (docs/MOSAIC.md): each image rendered from its true pose by the
wall camera (vehicle/sensors/camera.py), written as ``NNNNN.png`` with its line of
``index.csv``, and the camera's figures in ``camera.json``.

The sensor noise of the images is drawn in the order they were taken, from one random
generator (seeded by the run's seed), so that a run's images depend on its seed alone —
whichever process renders them (:mod:`vehicle.sensors.image_worker`), and however many
threads. With ``threads`` (the camera's worker), the noise is drawn in the caller's thread and
the rest runs in a pool of that many threads — the light that reaches the sensor
(:meth:`~vehicle.sensors.camera.WallCamera.lit`, a third of an image's rendering), the
noise added, the PNG encoded — while one more thread writes the files and the lines of
``index.csv`` in the images' order.
The PNGs are stored, not compressed (deflate's level 0, no row filter): 0.4 ms an image
against 2.0 ms for Huffman coding with one row filter (AVG) and 4.0 ms for libpng's default
of trying all five filters on every row, for files twice as large (226 kB against 116 kB: 300
MB for the dam mission's 1,329 images against 150 MB); the pixels are the same, PNG being
lossless. The 2 s of CPU saved are the camera worker's, which keeps pace with the simulation
(issue 27).
"""

from __future__ import annotations

import csv
import json
import math
from collections import deque
from collections.abc import Callable
from concurrent.futures import Future, ThreadPoolExecutor
from dataclasses import asdict
from pathlib import Path
from typing import Any

import numpy as np

from vehicle.sensors.camera import FloatImage, WallCamera
from vehicle.sensors.wall_texture import Image, TextureSpec, WallTexture

INDEX_FIELDS = ("index", "t", "file", "x", "y", "z", "psi", "nav_x", "nav_y", "nav_z",
                "nav_psi", "nav_std_x", "nav_std_y", "nav_std_z", "nav_std_psi",
                "wall_distance", "wall_distance_std", "wall_heading", "wall_heading_std")

Pose = tuple[float, float, float, float]


class ImageWriter:
    """Renders and writes the images of a run into ``folder`` (made at the first write):
    :meth:`write` one image, :meth:`set_plan` the planned area, :meth:`flush` waits for the
    images in flight, :meth:`close` stops the threads."""

    def __init__(self, folder: Path, seed: int = 1, wall_curvature: float = 0.0,
                 texture: TextureSpec | None = None, threads: int = 0,
                 on_image: Callable[[int, Image], object] | None = None) -> None:
        self.folder, self.seed, self.wall_curvature = folder, seed, wall_curvature
        self.spec = texture or TextureSpec(seed=seed)
        self.plan: list[tuple[float, float]] = []
        self._camera: WallCamera | None = None
        self._rng = np.random.default_rng([seed, 6])
        self._started = False
        self.on_image = on_image  # called with each image rendered (in a pool thread)
        self._develop = ThreadPoolExecutor(threads, thread_name_prefix="develop") if (
            threads) else None
        self._files = ThreadPoolExecutor(1, thread_name_prefix="files") if threads else None
        self._ahead: deque[Future[bytes]] = deque()  # images being developed, oldest first
        self._limit = 2 * threads + 2  # images in flight at most (each a few MB)
        self._pending: list[Future[None]] = []
        # the noise arrays of developed images, drawn into again: a new one each image is
        # memory the allocator hands back to the system and takes again (its pages zeroed)
        self._spare: deque[FloatImage] = deque()
        self.failure = ""  # why images stopped being kept: the first that could not be written

    def camera(self) -> WallCamera:
        """The wall camera, its texture made on first use (a quarter of a second), and the
        copy its images sample (before the threads that light them sample it at once)."""
        if self._camera is None:
            self._camera = WallCamera(WallTexture(self.spec), self.wall_curvature)
            _ = self._camera.texture.padded
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
        line (``nav``: the INDEX_FIELDS from nav_x on); the image rendered (None with
        ``threads``: it is rendered in the pool, given to ``on_image`` there). The first image
        that cannot be written (a full disk, the folder removed) raises OSError and sets
        :attr:`failure` (with ``threads``, at :meth:`flush`); no image is rendered after it, and
        nothing more is said (each failed write used to print libpng's error again, 1,312
        lines on a full disk)."""
        if self.failure:
            return None
        self._start()
        cam = self.camera()
        row: dict[str, Any] = {"index": index, "t": round(t, 3), "file": name,
                               "x": pose[0], "y": pose[1], "z": pose[2], "psi": pose[3]}
        row.update(nav)
        line = [_cell(row.get(k)) for k in INDEX_FIELDS]
        if self._develop is None or self._files is None:
            noise = cam.noise(self._rng)  # in the order taken: the generator's sequence
            img = cam.expose(cam.lit(pose), noise)
            if self.on_image is not None:
                self.on_image(index, img)
            self._store(index, name, _encode(img), line)
            return img
        spare = self._spare.popleft() if self._spare else None
        noise = cam.noise(self._rng, spare)  # in the order taken: the generator's sequence
        developed = self._develop.submit(self._developed, index, pose, noise)
        self._pending.append(self._files.submit(self._keep, index, name, developed, line))
        self._ahead.append(developed)
        while len(self._ahead) > self._limit:  # the memory of the images in flight bounded
            self._ahead.popleft().exception()  # waited for; what it raised, at the flush
        return None

    def _developed(self, index: int, pose: Pose, noise: FloatImage) -> bytes:
        """(A pool thread) The image lit, exposed with its noise, given to ``on_image``, and
        its PNG."""
        cam = self.camera()
        try:
            img = cam.expose(cam.lit(pose), noise)
        finally:
            self._spare.append(noise)  # used up: the next image's noise goes there
        if self.on_image is not None:
            self.on_image(index, img)
        return _encode(img)

    def _keep(self, index: int, name: str, developed: Future[bytes], line: list[str]) -> None:
        """(The files thread, in the images' order) Write a developed image and its line."""
        png = developed.result()
        if not self.failure:  # an earlier image could not be written: none after it
            self._store(index, name, png, line)

    def _store(self, index: int, name: str, png: bytes, line: list[str]) -> None:
        """Write the PNG and its line of index.csv; the first failure is kept and raised."""
        try:
            (self.folder / name).write_bytes(png)
            with (self.folder / "index.csv").open("a", newline="", encoding="utf-8") as f:
                csv.writer(f).writerow(line)
        except OSError:
            why = (f"image {name} could not be written in {self.folder} (a full disk? the "
                   f"folder removed?)")
            self.failure = f"only the first {index} images kept; {why}" if index else why
            raise OSError(self.failure) from None

    def flush(self) -> None:
        """Wait until every image is written (raises what writing one raised)."""
        pending, self._pending = self._pending, []
        for job in pending:
            job.result()

    def close(self) -> None:
        for pool in (self._develop, self._files):
            if pool is not None:
                pool.shutdown(wait=True)


def _encode(img: Image) -> bytes:
    """The PNG of an image, stored: deflate's level 0 (the rows copied, with their checksums)
    and no row filter, for speed."""
    import cv2

    ok, png = cv2.imencode(".png", img, [
        cv2.IMWRITE_PNG_COMPRESSION, 0,  # stored: no Huffman coding
        cv2.IMWRITE_PNG_FILTER, cv2.IMWRITE_PNG_FILTER_NONE])  # no filter: nothing to gain
    if not ok:
        raise OSError("the PNG encoder failed")
    return bytes(png.tobytes())


def _cell(v: Any) -> str:
    if v is None:
        return ""
    if isinstance(v, float):
        return "" if not math.isfinite(v) else f"{v:.6g}"
    return str(v)
