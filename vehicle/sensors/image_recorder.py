"""The images of a run, kept as the camera takes them (docs/MOSAIC.md): each image rendered
from the true pose by the wall camera (vehicle/sensors/camera.py) and written as a PNG, with
the navigation data of the instant in ``index.csv`` and the camera's figures in
``camera.json``: what the mosaic is built from (mosaic/images.py reads it).

The recorder is what the simulated stack calls; the rendering and writing are an
:class:`~vehicle.sensors.image_writer.ImageWriter`'s, in this process, or with ``background``
(``mcl run``) in the camera's worker process (:mod:`vehicle.sensors.image_worker`), on another
core than the simulation's. The images are the same either way.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from vehicle.sensors.camera import WallCamera
from vehicle.sensors.image_worker import ImageWorker
from vehicle.sensors.image_writer import INDEX_FIELDS, ImageWriter, Pose
from vehicle.sensors.wall_texture import Image, TextureSpec, WallTexture

__all__ = ["INDEX_FIELDS", "ImageRecorder"]


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
    background: bool = False  # render and write in the camera's worker process (mcl run)
    sink: ImageWriter | ImageWorker | None = None
    _failed: str = field(default="", repr=False)  # the failure of a sink since closed

    def start(self) -> ImageWriter | ImageWorker:
        """The writer, or the worker process started (it makes the wall's texture at once,
        while the simulation goes on)."""
        if self.sink is None:
            self.sink = (ImageWorker(self.folder, self.seed, self.wall_curvature, self.texture)
                         if self.background else
                         ImageWriter(self.folder, self.seed, self.wall_curvature, self.texture))
        return self.sink

    def set_plan(self, path: list[tuple[float, float]]) -> None:
        """The planned survey path (y, z) on the wall (the mosaic shows what it missed)."""
        if path and path != self.plan:
            self.plan = list(path)
            self.start().set_plan(self.plan)

    def record(self, t: float, pose: Pose, nav: dict[str, float]) -> Path:
        """Render and write the image taken at t from the true ``pose``; ``nav`` holds the
        navigation data of the instant (the INDEX_FIELDS from nav_x on). With ``background``
        the work is queued to the worker (in order) and :meth:`flush` waits for it."""
        index = self.count
        self.count += 1
        name = f"{index:05d}.png"
        self.start().write(index, name, t, pose, nav)
        return self.folder / name

    def flush(self) -> None:
        """Wait until every image queued is written (raises what writing one raised: an
        OSError)."""
        if self.sink is not None:
            self.sink.flush()

    @property
    def texture_spec(self) -> TextureSpec:
        """The wall's texture the images are rendered from (camera.json's ``texture``)."""
        return self.texture or TextureSpec(seed=self.seed)

    def wall_texture(self) -> WallTexture | None:
        """The wall's texture the images are rendered from: the writer's, or a copy of the
        worker's once made (None: not yet, or the sink is closed)."""
        if isinstance(self.sink, ImageWorker):
            image = self.sink.texture()
            return None if image is None else WallTexture(self.texture_spec, image)
        if isinstance(self.sink, ImageWriter):
            return self.sink.camera().texture  # made with the first image
        return None

    @property
    def failure(self) -> str:
        """Why images stopped being kept ("" while they are): the first that could not be
        written (a full disk, the folder removed); no image is rendered after it. The
        worker's is known once :meth:`flush` has raised it."""
        return self.sink.failure if self.sink is not None else self._failed

    def camera(self) -> WallCamera:
        """The wall camera of the writer in this process (not with ``background``)."""
        sink = self.start()
        if not isinstance(sink, ImageWriter):
            raise TypeError("the camera is the worker process's")
        return sink.camera()

    def frame(self, index: int) -> Image | None:
        """Image ``index``'s pixels in memory (the worker's shared memory, after
        :meth:`flush`, until :meth:`close`), or None: then its PNG has them."""
        return self.sink.frame(index) if isinstance(self.sink, ImageWorker) else None

    def close(self, wait: bool = True) -> None:
        """Stop the writer or the worker (with ``wait``, once what is queued is written)."""
        sink, self.sink = self.sink, None
        if sink is not None:
            self._failed = sink.failure
        if isinstance(sink, ImageWorker):
            sink.close(wait)
        elif sink is not None:
            sink.close()

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
