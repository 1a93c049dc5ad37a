"""What ``mcl run`` does with the camera: keep the images, then make the mosaic.

:func:`attach` gives the simulated stack an image recorder writing beside the run log
(``RUN.images/``), rendering and writing them in the camera's worker process while the
simulation runs (vehicle/sensors/image_worker.py); :func:`report` builds the mosaic and the
coverage map when the run took images, writes them beside the run log and says where, with the
figures; :func:`detach` stops the camera's worker (every exit of ``mcl run`` calls it).
"""

from __future__ import annotations

import time
from concurrent.futures import Future, ThreadPoolExecutor
from dataclasses import asdict
from pathlib import Path
from typing import Any

from mosaic.images import images_folder
from vehicle.sensors.image_recorder import ImageRecorder


def attach(stack: Any, log_path: Path) -> None:
    """Record the stack's camera images into ``RUN.images/`` beside the run log."""
    cfg = getattr(stack, "config", None)
    stack.images = ImageRecorder(images_folder(log_path), seed=getattr(cfg, "seed", 1),
                                 wall_curvature=getattr(cfg, "wall_curvature", 0.0),
                                 background=True)  # rendering overlaps the simulation
    stack.images.start()  # the worker makes the wall's texture while the vehicle dives


def detach(stack: Any, wait: bool = False) -> None:
    """Stop the camera's worker: with ``wait`` once the images queued are written, else at
    once (a run stopped from outside). Safe to call twice."""
    recorder = getattr(stack, "images", None)
    if recorder is not None:
        recorder.close(wait)


def report(stack: Any, log_path: Path, say: Any) -> None:
    """Build and write the mosaic if the run took images; one line if it could not."""
    recorder = getattr(stack, "images", None)
    if recorder is None or recorder.count == 0:
        return
    from mosaic.accuracy import truth_texture  # lazy: SciPy only for a mosaic
    from mosaic.build import build, summary_lines, write

    try:
        with ThreadPoolExecutor(1, thread_name_prefix="truth") as early:
            # The ground truth's texture is the camera worker's; else it is made while the
            # worker writes its last images, on the core the simulation has left.
            made = recorder.wall_texture()  # the worker's: not made a second time
            texture = early.submit(truth_texture, {"texture": asdict(recorder.texture_spec)}) \
                if made is None else _done(made)
            recorder.flush()  # the camera's worker may still be writing the last images
            started = time.perf_counter()
            result = build(recorder.folder, memory=recorder.frame,  # the pixels, not the PNGs
                           release=recorder.close, texture=texture)
        paths = write(result, log_path.with_suffix(""))
    except (ValueError, OSError) as exc:
        say(f"  mosaic: not made: {exc}")
        return
    except Exception as exc:  # a bug of the mosaic must not change how the mission ended
        say(f"  mosaic: not made: internal error: {type(exc).__name__}: {exc} (a bug; "
            f"'mcl mosaic {log_path}' retries it)")
        return
    finally:
        recorder.close()  # the worker, and the images' shared memory
    say(f"  images: {recorder.folder} ({recorder.count})")
    for line in summary_lines(result, paths):
        say("  " + line)
    took = time.perf_counter() - started
    if took > 60:
        say(f"  (making and measuring the mosaic took {took:.0f} s, over a minute; "
            f"'mcl mosaic {log_path}' remakes it)")


def _done(value: Any) -> Future[Any]:
    """A future already holding ``value``."""
    done: Future[Any] = Future()
    done.set_result(value)
    return done
