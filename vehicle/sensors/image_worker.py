"""The camera's worker process: renders and writes a run's images beside the simulation.

``mcl run`` simulates the vehicle in its main process, one Python thread bound to one core;
rendering the wall for each image (vehicle/sensors/camera.py) and writing it as a PNG takes
about as long again. An :class:`ImageWorker` does that work in a process of its own, on the
other core: the simulation only sends each image's time, true pose and navigation data down a
queue (a few hundred bytes), and the worker renders and writes the images in the order they
were taken, with the one random generator of the run — the images are the same, bit for bit,
as those rendered in the main process.

Inside the worker, the noise of each image is drawn in order and the rest — lighting,
exposure, PNG encoding, a copy into shared memory — runs in :data:`THREADS` threads (numpy and
OpenCV release the GIL), so that the images the simulation has taken are rendered on both
cores, not one, when it leaves one free (at its end, when the worker has images left). The
worker runs :data:`NICE` steps below the simulation's priority: its three threads would
otherwise take turns with the simulation's one on two cores (the dam run's survey took 7.9 s
where the simulation alone takes 6.0), and the simulation is what the run waits for; the
worker takes what the simulation leaves and catches up once it ends. The worker is stopped on every exit: :meth:`ImageWorker.close`
(after the images are flushed, or at once with ``wait=False``), the interpreter's exit
(``atexit``), and — should the main process die without either (SIGKILL) — the worker itself,
which notices within a second that its parent is gone. SIGINT and SIGHUP, sent by a terminal
to the whole process group, are the main process's to handle: the worker ignores them.

The worker is a spawned interpreter, not a fork: a child forked after the parent has used
OpenCV's thread pool deadlocks at its first OpenCV call (seen in the tests). Spawning costs the
worker a quarter of a second of CPU, on the other core: the interpreter, numpy and OpenCV
(the command's main module, which multiprocessing imports again, is 0.01 s of it); a script
that attaches the camera needs the usual ``if __name__ == "__main__":`` guard.
"""

from __future__ import annotations

import atexit
import multiprocessing
import os
import queue
import signal
import threading
from pathlib import Path
from typing import Any

from vehicle.sensors.image_writer import ImageWriter, Pose
from vehicle.sensors.shared_frames import SharedFrames, SharedImage
from vehicle.sensors.wall_texture import Image, TextureSpec

POLL = 1.0  # s: how often a waiting side checks that the other is still there
THREADS = 2  # the worker's threads that light, expose and encode the images, one a core
NICE = 5  # how much lower the worker's priority is than the simulation's (where os.nice is)


class WorkerError(OSError):
    """The camera's worker failed (a write failed, or the process died): the images are
    incomplete. An OSError, as a failed write in the main process would be."""


def serve(jobs: Any, answers: Any, folder: str, seed: int, wall_curvature: float,
          texture: TextureSpec | None, parent: int, texture_block: str | None = None) -> None:
    """The worker's loop (in the child process): each job is ``("plan", path)``,
    ``("image", index, name, t, pose, nav, block)`` (``block``: the name of the shared memory
    where the image's pixels go, when it is a new one; vehicle/sensors/shared_frames.py) or ``("flush", n)`` (answered with ``("flushed",
    n)``, or ``("error", text)`` once a write failed); ``None`` ends it. The wall's texture is
    made first, while the simulation starts, and copied into the shared memory named
    ``texture_block`` (the mosaic measures against it)."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # the terminal's: the parent decides
    signal.signal(signal.SIGHUP, signal.SIG_IGN)
    if hasattr(os, "nice"):  # the simulation's thread first: see NICE
        os.nice(NICE)
    import cv2  # the worker's own: one core, the other is the simulation's

    cv2.setNumThreads(1)  # no OpenCV thread pool spinning against the simulation
    frames = SharedFrames(owner=False)  # the pixels for the mosaic, beside the PNGs
    writer = ImageWriter(Path(folder), seed=seed, wall_curvature=wall_curvature,
                         texture=texture, threads=THREADS, on_image=frames.put)
    made = writer.camera().texture.image
    if texture_block is not None:
        shared = SharedImage(made.shape, texture_block)
        shared.put(made)
        shared.close()
    failed: str | None = None
    while True:
        try:
            job = jobs.get(timeout=POLL)
        except queue.Empty:
            if os.getppid() != parent:  # orphaned: the main process died (SIGKILL)
                break
            continue
        if job is None:
            break
        try:
            if failed is None and job[0] == "plan":
                writer.set_plan(job[1])
            elif failed is None and job[0] == "image":
                index, block = job[1], job[6]
                if block is not None:
                    frames.open(index, block)
                writer.write(*job[1:6])
            elif job[0] == "flush":
                if failed is None:
                    writer.flush()
                answers.put(("flushed", job[1]) if failed is None else ("error", failed))
        except Exception as exc:  # noqa: BLE001 - reported to the parent at its next flush
            failed = writer.failure or f"writing the images failed: {type(exc).__name__}: {exc}"
            if job[0] == "flush":
                answers.put(("error", failed))
    try:
        writer.flush()
    except OSError:  # already reported at a flush, or no one waits for it any more
        pass
    finally:
        writer.close()
        frames.close()


class ImageWorker:
    """The main process's handle on the camera's worker: :meth:`send` queues a job,
    :meth:`flush` waits until every image queued is written, :meth:`close` stops it."""

    def __init__(self, folder: Path, seed: int, wall_curvature: float,
                 texture: TextureSpec | None) -> None:
        ctx = multiprocessing.get_context("spawn")  # a fresh interpreter: no thread or lock
        # of the simulation is inherited
        self._jobs: Any = ctx.Queue()
        self._answers: Any = ctx.Queue()
        self._flushes = 0
        self.failure = ""  # why images stopped being kept, once a flush has said it
        self.frames = SharedFrames(owner=True)
        rows, cols = (texture or TextureSpec(seed=seed)).shape
        self.wall = SharedImage((rows, cols, 3))  # the worker's wall texture, once made
        self._lock = threading.Lock()
        self.process = ctx.Process(
            target=serve, name="camera",
            args=(self._jobs, self._answers, str(folder), seed, wall_curvature, texture,
                  os.getpid(), self.wall.name), daemon=True)
        self.process.start()
        atexit.register(self.close, False)  # every exit of the interpreter stops it

    def set_plan(self, path: list[tuple[float, float]]) -> None:
        self.send("plan", list(path))

    def write(self, index: int, name: str, t: float, pose: Pose, nav: dict[str, float]) -> None:
        """Queue image ``index``; once the worker has stopped, nothing (the simulation goes
        on: :meth:`flush` says what was lost)."""
        if not self.process.is_alive():
            if not self.failure:
                self.failure = (f"the camera's worker stopped (exit {self.process.exitcode}) "
                                f"before image {name}: the images are incomplete")
            return
        self.send("image", index, name, t, pose, nav, self.frames.block_for(index))

    def frame(self, index: int) -> Image | None:
        """Image ``index``'s pixels as the worker rendered them (after :meth:`flush`), in
        shared memory until :meth:`close`; None if they are only in its PNG."""
        return self.frames.get(index)

    def texture(self) -> Image | None:
        """A copy of the wall's texture the worker made (None before it has, or once
        closed)."""
        return self.wall.get()

    def send(self, *job: Any) -> None:
        if not self.process.is_alive():
            raise WorkerError(f"the camera's worker has stopped (exit {self.process.exitcode})")
        self._jobs.put(job)

    def flush(self) -> None:
        """Wait until the worker has written every image queued; WorkerError if it failed."""
        with self._lock:
            if self.failure:
                raise WorkerError(self.failure)
            self._flushes += 1
            n = self._flushes
            self.send("flush", n)
            while True:
                try:
                    answer = self._answers.get(timeout=POLL)
                except queue.Empty:
                    if not self.process.is_alive():
                        raise WorkerError("the camera's worker died (exit "
                                          f"{self.process.exitcode}): the images are "
                                          "incomplete") from None
                    continue
                if answer == ("flushed", n):
                    return
                if answer[0] == "error":
                    self.failure = answer[1]
                    raise WorkerError(self.failure)

    def close(self, wait: bool = True) -> None:
        """Stop the worker: with ``wait``, once it has written what is queued; else at once.
        Safe to call twice, and from ``atexit``."""
        if self.process.pid is None or self.process.exitcode is not None:
            self._release()
            return
        if wait:
            try:
                self._jobs.put(None)
            except (OSError, ValueError):
                pass
            self.process.join(timeout=60.0)
        if self.process.is_alive():
            self.process.terminate()
            self.process.join(timeout=5.0)
        if self.process.is_alive():
            self.process.kill()
            self.process.join()
        self._release()

    def _release(self) -> None:
        atexit.unregister(self.close)
        self.frames.close()
        self.wall.close()
        for q in (self._jobs, self._answers):
            q.close()
            q.cancel_join_thread()  # never block the exit on a job no one will read
