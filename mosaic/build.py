"""The whole pipeline of paper 002 §6 on a run's images, and what it writes.

:func:`build` reads the images folder, corrects the illumination, sets damaged images aside,
registers consecutive and overlapping non-consecutive pairs, aligns all images globally with
the navigation data as a prior, blends the mosaic, draws the coverage map and — for a
simulated run, whose ``camera.json`` names the wall texture — measures all of it against the
ground truth; each stage is a function of :mod:`mosaic.stages`. :func:`write` puts
``PREFIX.mosaic.png``, ``PREFIX.coverage.png`` and ``PREFIX.mosaic.json`` (the figures) beside
the run log.
"""

from __future__ import annotations

import json
import os
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from concurrent.futures import Future, ThreadPoolExecutor
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt

from mosaic import accuracy, alignment, blending, image_files, registration
from mosaic.annotate import annotate
from mosaic.images import Survey, read
from mosaic.projection import FloatArray
from mosaic.stages import (
    Aligned,
    Blended,
    Detectors,
    Matcher,
    Pairs,
    Prepared,
    align,
    blend,
    prepare,
    register,
    size_on_wall,
)
from vehicle.sensors.wall_texture import WallTexture

Image = npt.NDArray[np.uint8]


@dataclass
class Result:
    survey: Survey
    mosaic: Image
    coverage: Image
    canvas: blending.Canvas
    poses: FloatArray
    skipped: dict[int, str]  # frame index -> why it was set aside
    figures: dict[str, Any] = field(default_factory=dict)


def build(path: str | Path, mm_per_px: float = blending.MM_PER_PX, measure: bool = True,
          compare_without_prior: bool = True, per_image: int = 3,
          max_bytes: int = image_files.MAX_BYTES,
          memory: Callable[[int], Image | None] | None = None,
          release: Callable[[], None] | None = None,
          texture: Future[WallTexture | None] | None = None) -> Result:
    """The mosaic of a run's images folder (or of the run log beside it), stage by stage: the
    images prepared, the pairs registered, the poses aligned, the mosaic blended, the figures
    (and, for a simulated run, the figures against the ground truth). The images and the
    canvas are sized against ``max_bytes`` before they are allocated (mosaic/image_files.py):
    a survey that needs more is refused (SurveyError, ValueError) with the reason.
    ``memory``: an image's pixels by its index where the run still has them (else its PNG is
    read), ``release`` called once every image is read (that memory may go); ``texture``: the
    ground truth's wall texture being made already (:func:`accuracy.truth_texture` of the
    run's ``camera.json``; else it is made here, beside the features)."""
    clock = Clock()
    survey = read(path, max_bytes)
    survey.memory = memory
    if not survey.frames:
        raise ValueError(f"{survey.folder}: the run took no images")
    prior = np.array([f.prior for f in survey.frames], dtype=float)
    prior_std = np.array([f.prior_std for f in survey.frames], dtype=float)
    size = size_on_wall(survey.k, prior)  # of an image, by the navigation data
    truth = np.array([f.truth for f in survey.frames], dtype=float) if all(
        f.truth is not None for f in survey.frames) else None
    measuring = measure and truth is not None
    detectors = Detectors()
    with opencv_threads(1), ThreadPoolExecutor(max(1, min(4, os.cpu_count() or 1))) as \
            workers:  # OpenCV frees the GIL. What the measuring needs is made beside the
        # stages that do not use it: the wall's texture beside the features (class Beside:
        # the registration errors and the alignment without the prior beside the alignment,
        # which runs on one thread, and the blending).
        if measuring and texture is None:
            texture = workers.submit(accuracy.truth_texture, survey.meta)
        images = prepare(survey, workers, detectors)
        survey.memory = None
        if release is not None:
            release()
        clock.lap("features")
        matcher = Matcher(survey.k, images.features, workers, detectors, size)
        pairs = register(matcher, prior, images.usable, per_image)
        clock.lap("registration")
        beside = Beside(workers, survey, images.skipped, prior, prior_std,
                        truth if measuring else None, compare_without_prior)
        beside.registration_errors(pairs.found)  # those found so far, beside the alignment
        aligned = align(matcher, prior, prior_std, pairs, images.usable, per_image,
                        final=beside.without_prior)
        clock.lap("alignment")
        beside.registration_errors(pairs.found)  # the rest, beside the blending
        held = image_files.survey_bytes(len(survey.frames), survey.k.width, survey.k.height)
        blended = blend(survey, images, aligned.poses, size, mm_per_px, workers,
                        min(60_000_000, image_files.canvas_pixels(max_bytes, held)))
        clock.lap("blending")
        figures = _figures(survey, images, pairs, aligned, blended, mm_per_px, clock)
        result = Result(survey, blended.mosaic, blended.coverage, blended.canvas,
                        aligned.poses, images.skipped, figures)
        if measuring:
            assert truth is not None
            _measure(result, truth, beside.errors(), prior, blended.count, beside.alone(),
                     texture.result() if texture is not None and measuring else None)
    return result


class Beside:
    """What the measuring against the truth needs of the registration, made in the workers
    while the main thread aligns and blends: each pair's registration error, and the poses
    aligned without the prior (once the pairs are all found). Nothing if ``truth`` is None."""

    def __init__(self, workers: ThreadPoolExecutor, survey: Survey, skipped: dict[int, str],
                 prior: FloatArray, prior_std: FloatArray, truth: FloatArray | None,
                 compare_without_prior: bool) -> None:
        self.workers, self.survey, self.skipped = workers, survey, skipped
        self.prior, self.prior_std = prior, prior_std  # the navigation data at the images
        self.truth, self.compare = truth, compare_without_prior
        self.done = 0  # pairs whose registration error is being worked out
        self.reg: list[Future[FloatArray]] = []
        self.poses: Future[FloatArray] | None = None

    def registration_errors(self, found: list[registration.Pair]) -> None:
        """Work out the registration error of the pairs ``found`` not yet given."""
        if self.truth is not None:
            self.reg.append(self.workers.submit(accuracy.registration_errors,
                                                found[self.done:], self.truth, self.survey.k))
            self.done = len(found)

    def without_prior(self, found: list[registration.Pair]) -> None:
        """Align the images without the prior on these pairs (:func:`stages.align`'s
        ``final``)."""
        if self.truth is not None and self.compare and found and self.poses is None:
            self.poses = self.workers.submit(_without_prior, self.survey, self.skipped,
                                             self.prior, self.prior_std, list(found))

    def errors(self) -> FloatArray:
        """The registration error of every pair given, in their order."""
        return np.concatenate([r.result() for r in self.reg]) if self.reg else np.zeros(0)

    def alone(self) -> FloatArray | None:
        """The poses aligned without the prior (None: not compared)."""
        return None if self.poses is None else self.poses.result()


@contextmanager
def opencv_threads(n: int) -> Iterator[None]:
    """OpenCV's own pool held to ``n`` threads meanwhile (then put back): the pipeline's
    threads are one a core already, and OpenCV's pool beside them only takes turns with them
    (its threads also spin a while after each call, taking a core from the alignment)."""
    import cv2

    before = cv2.getNumThreads()
    cv2.setNumThreads(n)
    try:
        yield
    finally:
        cv2.setNumThreads(before)


class Clock:
    """The wall time of each stage and the process's CPU time since the build started."""

    def __init__(self) -> None:
        self.t0, self.cpu0 = time.perf_counter(), time.process_time()
        self.last = self.t0
        self.stages: dict[str, float] = {}

    def lap(self, stage: str) -> None:
        now = time.perf_counter()
        self.stages[stage], self.last = now - self.last, now

    @property
    def elapsed(self) -> float:
        return self.last - self.t0


# -- the figures --------------------------------------------------------------------------------
def _figures(survey: Survey, images: Prepared, pairs: Pairs, aligned: Aligned,
             blended: Blended, mm_per_px: float, clock: Clock) -> dict[str, Any]:
    n, canvas, count = len(survey.frames), blended.canvas, blended.count
    registered = np.zeros(n, bool)
    for p in pairs.found:
        registered[p.i] = registered[p.j] = True
    seconds = {stage: round(s, 2) for stage, s in clock.stages.items()}
    seconds["total"] = round(clock.elapsed, 2)
    seconds["cpu"] = round(time.process_time() - clock.cpu0, 2)
    return {
        "images": n, "used": int(sum(images.usable)), "set_aside": len(images.skipped),
        "registered_images": int(registered.sum()),
        "pairs_tried": len(pairs.tried), "pairs_registered": len(pairs.found),
        "consecutive_pairs": sum(1 for p in pairs.found if p.consecutive),
        "non_consecutive_pairs": sum(1 for p in pairs.found if not p.consecutive),
        "pairs_failed": pairs.failed,
        "pairs_rejected_by_alignment": len(aligned.alignment.rejected),
        "alignment_rounds": aligned.rounds,
        "mm_per_px": mm_per_px, "size_px": [canvas.cols, canvas.rows],
        "wall_area_m2": [round(canvas.y0, 3), round(canvas.z0, 3),
                         round(canvas.y0 + canvas.cols * canvas.s, 3),
                         round(canvas.z0 + canvas.rows * canvas.s, 3)],
        "area_seen_m2": round(float((count > 0).sum()) * canvas.s**2, 2),
        "area_seen_twice_m2": round(float((count > 1).sum()) * canvas.s**2, 2),
        "images_per_cell": _per_cell(count),
        "seconds": seconds,
        "images_per_second": round(n / clock.elapsed, 1),
    }


def _per_cell(count: npt.NDArray[np.uint16]) -> dict[str, float]:
    seen = count[count > 0]
    if seen.size == 0:
        return {"median": 0.0, "p10": 0.0, "max": 0.0}
    return {"median": float(np.median(seen)), "p10": float(np.percentile(seen, 10)),
            "max": float(seen.max())}


def _without_prior(survey: Survey, skipped: dict[int, str], prior: FloatArray,
                   prior_std: FloatArray, pairs: list[registration.Pair]) -> FloatArray:
    """The images' poses aligned without the navigation prior (the first used image held)."""
    used = np.array([f.index not in skipped for f in survey.frames])
    anchor = int(np.flatnonzero(used)[0])
    return alignment.align(prior, prior_std, pairs, survey.k, use_prior=False,
                           anchor=anchor).poses


def _measure(result: Result, truth: FloatArray, reg: FloatArray,
             prior: FloatArray, count: npt.NDArray[np.uint16], alone: FloatArray | None,
             texture: WallTexture | None) -> None:
    """The figures against the ground truth; ``reg``: the registration error of each pair
    registered (:func:`accuracy.registration_errors`); ``alone``: the poses aligned without
    the prior (None: not compared); ``texture``: the run's wall texture, if already made."""
    k, fig = result.survey.k, result.figures
    used = np.array([f.index not in result.skipped for f in result.survey.frames])
    fig["registration_error_px"] = {
        "median": round(float(np.median(reg)), 3) if reg.size else None,
        "rms": round(float(np.sqrt(np.mean(reg**2))), 3) if reg.size else None,
        "max": round(float(reg.max()), 3) if reg.size else None}
    fig["alignment_error_mm"] = accuracy.stats_mm(
        accuracy.position_errors(result.poses, truth, k)[used])
    fig["navigation_error_mm"] = accuracy.stats_mm(
        accuracy.position_errors(prior, truth, k)[used])
    if alone is not None:
        fig["alignment_error_without_prior_mm"] = accuracy.stats_mm(
            accuracy.position_errors(alone, truth, k)[used])
    gt = accuracy.truth_on_canvas(result.survey.meta, result.canvas, texture)
    if gt is not None:
        cp = accuracy.control_points(result.mosaic, gt, count, result.canvas)
        fig["control_points"] = len(cp)
        fig["mosaic_error_mm"] = accuracy.stats_mm(np.hypot(cp[:, 2], cp[:, 3]))


def write(result: Result, prefix: Path) -> dict[str, Path]:
    """Write PREFIX.mosaic.png, PREFIX.coverage.png and PREFIX.mosaic.json."""
    import cv2

    paths = {"mosaic": prefix.with_name(prefix.name + ".mosaic.png"),
             "coverage": prefix.with_name(prefix.name + ".coverage.png"),
             "figures": prefix.with_name(prefix.name + ".mosaic.json")}
    with ThreadPoolExecutor(1, thread_name_prefix="coverage") as beside:  # the two PNGs
        # encoded at once (OpenCV releases the interpreter's lock)
        coverage = beside.submit(_write_coverage, result, paths["coverage"])
        mosaic, frame = annotate(result.mosaic, result.canvas)
        cv2.imwrite(str(paths["mosaic"]), mosaic)
        coverage.result()
    doc = dict(result.figures)
    doc["picture"] = frame.json()  # where the canvas lies in both PNGs, the grid's lines
    doc["set_aside"] = {str(k): v for k, v in sorted(result.skipped.items())}
    doc["frame"] = ("wall frame: y along the wall (columns, left to right), z depth (rows, "
                    "down), m; canvas pixel (r, c) centred at y0 + (c + 0.5) s, z0 + (r + 0.5) s, "
                    "drawn at (r + picture.top, c + picture.left) in the PNGs, framed by the "
                    "wall's coordinates, a grid and a scale bar (mosaic/annotate.py)")
    paths["figures"].write_text(json.dumps(doc, indent=1) + "\n", encoding="utf-8")
    return paths


def _write_coverage(result: Result, path: Path) -> None:
    """The coverage map, framed as the mosaic is, its legend under it, written as a PNG."""
    import cv2

    rows = result.canvas.rows
    coverage, frame = annotate(result.coverage[:rows], result.canvas)
    legend = np.zeros((result.coverage.shape[0] - rows, coverage.shape[1], 3), np.uint8)
    legend[:, frame.left:frame.left + result.coverage.shape[1]] = result.coverage[rows:]
    cv2.imwrite(str(path), np.vstack([coverage, legend]))


def summary_lines(result: Result, paths: dict[str, Path]) -> list[str]:
    """What ``mcl run`` and ``mcl mosaic`` print."""
    f = result.figures
    lines = [f"mosaic: {paths['mosaic']} ({f['size_px'][0]} x {f['size_px'][1]} px at "
             f"{f['mm_per_px']:g} mm/px, {f['area_seen_m2']} m² seen) built from {f['used']} "
             f"of {f['images']} images in {f['seconds']['total']:.1f} s "
             f"({f['images_per_second']:g} images/s; {f['seconds']['cpu']:.1f} s of CPU)",
             f"  coverage map: {paths['coverage']}; figures: {paths['figures']}",
             f"  pairs registered {f['pairs_registered']} of {f['pairs_tried']} "
             f"({f['consecutive_pairs']} consecutive, {f['non_consecutive_pairs']} "
             f"non-consecutive)"]
    if result.skipped:
        shown = ", ".join(f"#{i} {why}" for i, why in list(sorted(result.skipped.items()))[:4])
        more = f" and {len(result.skipped) - 4} more" if len(result.skipped) > 4 else ""
        lines.append(f"  set aside {len(result.skipped)} images: {shown}{more}")
    if "alignment_error_mm" in f:
        a, r = f["alignment_error_mm"], f["registration_error_px"]
        line = (f"  against ground truth: registration {r['median']} px median "
                f"({r['max']} max); image positions {a['rms']} mm RMS ({a['max']} max) "
                f"with the navigation prior")
        if "alignment_error_without_prior_mm" in f:
            b = f["alignment_error_without_prior_mm"]
            line += f", {b['rms']} mm RMS ({b['max']} max) without"
        lines.append(line)
    if "mosaic_error_mm" in f:
        m = f["mosaic_error_mm"]
        lines.append(f"  mosaic against the wall at {f['control_points']} control points: "
                     f"{m['rms']} mm RMS ({m['max']} max)")
    return lines
