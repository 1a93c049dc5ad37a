"""The images of a run, written as the camera takes them (docs/MOSAIC.md): each image rendered
from the true pose by the wall camera (vehicle/sensors/camera.py) and written as a PNG, with
the navigation data of the instant in ``index.csv`` and the camera's figures in
``camera.json``: what the mosaic is built from (mosaic/images.py reads it).
"""

from __future__ import annotations

import csv
import json
import math
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from vehicle.sensors.camera import WallCamera
from vehicle.sensors.wall_texture import TextureSpec, WallTexture


INDEX_FIELDS = ("index", "t", "file", "x", "y", "z", "psi", "nav_x", "nav_y", "nav_z",
                "nav_psi", "nav_std_x", "nav_std_y", "nav_std_z", "nav_std_psi",
                "wall_distance", "wall_distance_std", "wall_heading", "wall_heading_std")


@dataclass
class ImageRecorder:
    """Writes the images of a run into ``folder``: ``NNNNN.png``, ``index.csv`` (one line per
    image: time, true pose, navigator's pose and standard deviations, wall tracker's distance
    and relative heading) and ``camera.json`` (intrinsics, texture, wall, planned area)."""

    folder: Path
    seed: int = 1
    wall_curvature: float = 0.0
    count: int = 0
    plan: list[tuple[float, float]] = field(default_factory=list)
    texture: TextureSpec | None = None  # default: TextureSpec(seed)
    background: bool = False  # render and write in a worker thread (mcl run)
    failure: str = ""  # why images stopped being kept: the first that could not be written
    _pool: Any = None
    _pending: list[Any] = field(default_factory=list)
    _camera: WallCamera | None = None
    _rng: np.random.Generator | None = None

    def camera(self) -> WallCamera:
        if self._camera is None:
            spec = self.texture or TextureSpec(seed=self.seed)
            self._camera = WallCamera(WallTexture(spec),
                                      self.wall_curvature)
            self._rng = np.random.default_rng([self.seed, 6])
            self.folder.mkdir(parents=True, exist_ok=True)
            with (self.folder / "index.csv").open("w", newline="", encoding="utf-8") as f:
                csv.writer(f).writerow(INDEX_FIELDS)
            self._write_meta()
        return self._camera

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
        """The planned survey path (y, z) on the wall (the mosaic shows what it missed)."""
        if path and path != self.plan:
            self.plan = list(path)
            self._run(self._write_meta)

    def record(self, t: float, pose: tuple[float, float, float, float],
               nav: dict[str, float]) -> Path:
        """Render and write the image taken at t from the true ``pose``; ``nav`` holds the
        navigation data of the instant (the INDEX_FIELDS from nav_x on). With ``background``
        the work is queued to one worker thread (in order) and :meth:`flush` waits for it."""
        index = self.count
        self.count += 1
        name = f"{index:05d}.png"
        self._run(self._write, index, name, t, pose, nav)
        return self.folder / name

    def _run(self, job: Any, *args: Any) -> None:
        if not self.background:
            job(*args)
            return
        if self._pool is None:
            from concurrent.futures import ThreadPoolExecutor

            self._pool = ThreadPoolExecutor(1, thread_name_prefix="camera")
        self._pending.append(self._pool.submit(job, *args))

    def flush(self) -> None:
        """Wait until every image queued is written (raises what writing one raised)."""
        pending, self._pending = self._pending, []
        for job in pending:
            job.result()

    def _write(self, index: int, name: str, t: float, pose: tuple[float, float, float, float],
               nav: dict[str, float]) -> None:
        """Render and keep one image; the first that cannot be kept (a full disk, the folder
        removed) raises OSError and sets :attr:`failure`, and no image is rendered after it
        (each failed write used to print libpng's error again, 1,312 lines on a full disk)."""
        if self.failure:
            return
        try:
            self._keep(index, name, t, pose, nav)
        except OSError as exc:
            self.failure = (f"only the first {index} images kept; {exc}"
                            if index else str(exc))
            raise OSError(self.failure) from None

    def _keep(self, index: int, name: str, t: float, pose: tuple[float, float, float, float],
              nav: dict[str, float]) -> None:
        import cv2

        cam = self.camera()
        assert self._rng is not None
        img = cam.render(pose, self._rng)
        if not cv2.imwrite(str(self.folder / name), img, [
                cv2.IMWRITE_PNG_COMPRESSION, 1,  # fast
                cv2.IMWRITE_PNG_STRATEGY, cv2.IMWRITE_PNG_STRATEGY_HUFFMAN_ONLY]):
            raise OSError(f"image {name} could not be written in {self.folder} (a full disk? "
                          "the folder removed?)")
        row: dict[str, Any] = {"index": index, "t": round(t, 3), "file": name,
                               "x": pose[0], "y": pose[1], "z": pose[2], "psi": pose[3]}
        row.update(nav)
        with (self.folder / "index.csv").open("a", newline="", encoding="utf-8") as f:
            csv.writer(f).writerow([_cell(row.get(k)) for k in INDEX_FIELDS])

    def from_stack(self, stack: Any, image: Any) -> Path | None:
        """Record a :class:`vehicle.sensors.readings.CameraImage` taken by the stack's camera, with the
        navigator's and the wall tracker's estimates at that instant."""
        if image.pose is None:
            return None
        survey = stack.surveying()  # the wall survey's behaviour, its path the plan
        if survey is not None and getattr(survey, "path", None):
            self.set_plan([(float(y), float(z)) for y, z in survey.path])
        n, p = stack.navigator.x, stack.navigator.P
        nav: dict[str, float] = {
            "nav_x": float(n[0]), "nav_y": float(n[1]), "nav_z": float(n[2]),
            "nav_psi": float(n[3]), "nav_std_x": math.sqrt(float(p[0, 0])),
            "nav_std_y": math.sqrt(float(p[1, 1])), "nav_std_z": math.sqrt(float(p[2, 2])),
            "nav_std_psi": math.sqrt(float(p[3, 3]))}
        if stack.tracker is not None:
            d, h = stack.tracker.distance_to_wall(), stack.tracker.relative_heading()
            nav.update({"wall_distance": d.value, "wall_distance_std": d.std,
                        "wall_heading": h.value, "wall_heading_std": h.std})
        return self.record(image.t, image.pose, nav)


def _cell(v: Any) -> str:
    if v is None:
        return ""
    if isinstance(v, float):
        return "" if not math.isfinite(v) else f"{v:.6g}"
    return str(v)
