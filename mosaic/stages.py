"""The stages of the mosaic's pipeline (paper 002 §6), each a function that :func:`mosaic.build.build`
calls in turn: :func:`prepare` (read the images, set the damaged and textureless aside,
correct the illumination, find the features), :func:`register` (consecutive pairs, then
overlapping ones from other passages), :func:`align` (global alignment with the navigation
data as a prior, rounds of new overlaps), :func:`blend` (the mosaic and the coverage map).
"""

from __future__ import annotations

import threading
from collections import deque
from collections.abc import Callable
from concurrent.futures import Future, ThreadPoolExecutor
from dataclasses import dataclass
from typing import Any

import numpy as np
import numpy.typing as npt

from mosaic import alignment, blending, illumination, registration
from mosaic.images import Survey
from mosaic.projection import FloatArray, Intrinsics, homography, wall_points

Image = npt.NDArray[np.uint8]


# -- the images: read, damaged ones set aside, illumination corrected, features found -----------
@dataclass
class Prepared:
    """The survey's images ready to register and blend: each corrected image and its features
    (None for an image set aside, with why in ``skipped``)."""

    images: list[Image | None]
    features: list[registration.Features | None]
    skipped: dict[int, str]  # frame index -> why it was set aside

    @property
    def usable(self) -> list[bool]:
        return [f is not None for f in self.features]


class Detectors:
    """One feature detector per worker thread (a detector is not shared between threads)."""

    def __init__(self) -> None:
        self._local = threading.local()

    def get(self) -> registration.Detector:
        detector: registration.Detector | None = getattr(self._local, "detector", None)
        if detector is None:
            detector = self._local.detector = registration.Detector()
        return detector


def prepare(survey: Survey, workers: ThreadPoolExecutor, detectors: Detectors) -> Prepared:
    """Read every image once, set the damaged aside, correct the illumination with the flat
    field of the survey, set the textureless aside, find the features of the rest."""
    frames, k = survey.frames, survey.k
    skipped: dict[int, str] = {}
    raw: list[Image | None] = list(workers.map(survey.load, frames))  # read once
    for i, f in enumerate(frames):  # damaged images set aside at once
        why = illumination.damaged(raw[i])
        if why is not None:
            skipped[f.index] = why
            raw[i] = None
    field_ = _flat_field(raw, k)

    def one(i: int) -> tuple[str | None, Image | None, registration.Features | None]:
        img = raw[i]
        if img is None:
            return None, None, None
        corrected = illumination.correct(img, field_)
        grey = illumination.grey(corrected)  # once, for both steps below
        why = illumination.textureless(grey)
        if why is not None:
            return why, None, None
        feat = detectors.get().detect(illumination.grey_u8(grey))
        return None, np.asarray(np.clip(corrected, 0, 255), dtype=np.uint8), feat

    feats: list[registration.Features | None] = []
    for i, (why, kept, feat) in enumerate(workers.map(one, range(len(frames)))):
        if why is not None:
            skipped[frames[i].index] = why
        raw[i] = kept  # the corrected image, kept for blending
        feats.append(feat)
    return Prepared(raw, feats, skipped)


def _flat_field(raw: list[Image | None], k: Any,
                sample: int = 150) -> illumination.FloatImage:
    """The flat field from up to ``sample`` undamaged images spread over the survey."""
    good = [img for img in raw if img is not None]
    step = max(1, len(good) // sample)
    if not good:
        return np.ones((k.height, k.width, 3), np.float32)
    return illumination.flat_field(good[::step])


# -- registration: consecutive usable images, then overlapping ones from other passages --------
Job = tuple[int, int, bool]  # (image a, image b, consecutive)


def size_on_wall(k: Intrinsics, poses: FloatArray) -> tuple[float, float]:
    """The width and height (m) of an image on the wall at the poses' median distance."""
    d = float(np.median(poses[:, 2]))
    return d * k.width / k.fx, d * k.height / k.fy


@dataclass
class Matcher:
    """Registers pairs of prepared images, each guessed from the poses given (§6.3-6.5); finds
    the pairs that overlap, an image taken to be ``size`` (m) on the wall."""

    k: Intrinsics
    features: list[registration.Features | None]
    workers: ThreadPoolExecutor
    detectors: Detectors
    size: tuple[float, float]

    def match(self, jobs: list[Job], poses: FloatArray) -> list[registration.Pair | str]:
        """Each pair registered, or why it was not (in the order of ``jobs``)."""
        hw = {i: homography(poses[i], self.k) for i in sorted({i for a, b, _ in jobs
                                                                for i in (a, b)})}
        shape = (self.k.height, self.k.width)

        def one(job: Job) -> registration.Pair | str:
            a, b, consecutive = job
            fa, fb = self.features[a], self.features[b]
            assert fa is not None and fb is not None
            guess = np.linalg.inv(hw[a]) @ hw[b]
            got: registration.Pair | str = self.detectors.get().match(
                fa, fb, shape, a, b, consecutive, guess)
            return got

        return list(self.workers.map(one, jobs))

    def overlapping(self, poses: FloatArray, usable: list[bool],
                    per_image: int) -> list[tuple[int, int]]:
        """Non-consecutive pairs whose images overlap on the wall, placed at ``poses``."""
        ca, cb = self.k.slopes(np.array([[self.k.cx, self.k.cy]]))
        centres = wall_points(poses, ca[0], cb[0])
        return registration.candidates(centres, self.size, usable, per_image=per_image)


@dataclass
class Pairs:
    """The pairs tried, those registered, and why the others failed (by reason)."""

    tried: list[Job]
    found: list[registration.Pair]
    failed: dict[str, int]


def register(matcher: Matcher, prior: FloatArray, usable: list[bool],
             per_image: int) -> Pairs:
    """Consecutive usable images, then overlapping ones from other passages, placed by the
    navigation data (the prior)."""
    order = [i for i in range(len(usable)) if usable[i]]
    tried: list[Job] = [(a, b, True) for a, b in zip(order, order[1:])]
    tried += [(a, b, False) for a, b in matcher.overlapping(prior, usable, per_image)]
    found: list[registration.Pair] = []
    failed: dict[str, int] = {}
    for got in matcher.match(tried, prior):
        if isinstance(got, str):
            key = got.split(" ", 1)[-1] if got[0].isdigit() else got
            failed[key] = failed.get(key, 0) + 1
        else:
            found.append(got)
    return Pairs(tried, found, failed)


# -- global alignment (§6.6) -------------------------------------------------------------------
@dataclass
class Aligned:
    """The poses of every image, the last alignment and how many rounds it took."""

    poses: FloatArray
    alignment: alignment.Alignment
    rounds: int


def align(matcher: Matcher, prior: FloatArray, prior_std: FloatArray, pairs: Pairs,
          usable: list[bool], per_image: int, max_rounds: int = 3,
          final: Callable[[list[registration.Pair]], None] | None = None) -> Aligned:
    """Align all images with the navigation data as a prior; then look for overlaps again
    from the aligned poses, register the new ones (added to ``pairs``) and align again, until
    no new pair (at most ``max_rounds`` alignments). ``final`` is called once with the pairs
    registered as soon as no more can come (before the last alignment when it is the
    ``max_rounds``-th), so that what needs them all may start beside that alignment."""
    k = matcher.k
    told = False

    def tell() -> None:
        nonlocal told
        if final is not None and not told:
            final(pairs.found)
        told = True

    if max_rounds <= 1:
        tell()
    al = alignment.align(prior, prior_std, pairs.found, k, use_prior=True)
    poses = al.poses
    seen = {(a, b) for a, b, _ in pairs.tried}
    rounds = 1
    for _ in range(max_rounds - 1):
        new: list[Job] = [(a, b, False) for a, b in matcher.overlapping(poses, usable, per_image)
                          if (a, b) not in seen]
        if not new:
            break
        seen.update((a, b) for a, b, _ in new)
        pairs.tried += new
        found = [got for got in matcher.match(new, poses) if not isinstance(got, str)]
        if not found:
            break
        pairs.found += found
        if rounds + 1 == max_rounds:
            tell()
        al = alignment.align(prior, prior_std, pairs.found, k, use_prior=True, x0=poses)
        poses = al.poses
        rounds += 1
    tell()
    return Aligned(poses, al, rounds)


# -- blending (§6.7) and the coverage map -------------------------------------------------------
@dataclass
class Blended:
    mosaic: Image
    coverage: Image
    canvas: blending.Canvas
    count: npt.NDArray[np.uint16]  # images per pixel of the canvas


def blend(survey: Survey, images: Prepared, poses: FloatArray, size: tuple[float, float],
          mm_per_px: float, workers: ThreadPoolExecutor | None = None,
          max_pixels: int = 60_000_000) -> Blended:
    """Every usable image projected at its pose and merged (its memory freed as the mosaic
    grows; warped by the ``workers``, added in order); the coverage map with the planned area
    (widened by an image's ``size``) drawn; ValueError when no image is usable, saying why
    they were set aside, or when the canvas would have more than ``max_pixels`` pixels."""
    k, usable = survey.k, images.usable
    fw, fh = size
    boxes = [blending.footprint(poses[i], k) for i in range(len(usable)) if usable[i]]
    plan = survey.plan()
    if plan:
        py, pz = np.array(plan).T
        boxes.append((py.min() - fw / 2, py.max() + fw / 2, pz.min() - fh / 2, pz.max() + fh / 2))
    if not boxes:
        raise ValueError(_nothing_usable(survey, images.skipped))
    canvas = blending.canvas_for(boxes, mm_per_px, max_pixels=max_pixels)
    blender = blending.Blender(canvas, k)
    add_in_order(blender, images.images, poses, workers)
    coverage = blending.coverage_image(blender.count, canvas,
                                       _plan_drawer(plan, canvas, fw, fh) if plan else None)
    return Blended(blender.mosaic(), coverage, canvas, blender.count)


def add_in_order(blender: blending.Blender, images: list[Image | None], poses: FloatArray,
                    workers: ThreadPoolExecutor | None, ahead: int = 8) -> None:
    """Warp the images (``ahead`` at a time in the workers) and add them to the blender in
    their order; each image's memory is freed once it is added."""
    order = [i for i, img in enumerate(images) if img is not None]

    def warp(i: int) -> blending.Warped | None:
        img = images[i]
        assert img is not None
        return blender.warp(img, poses[i])

    queued: deque[tuple[int, Future[blending.Warped | None]]] = deque()
    for i in order:
        if workers is None:
            warped = warp(i)
            if warped is not None:
                blender.accumulate(warped)
            images[i] = None
            continue
        queued.append((i, workers.submit(warp, i)))
        if len(queued) > ahead:
            _add_first(blender, images, queued)
    while queued:
        _add_first(blender, images, queued)


def _add_first(blender: blending.Blender, images: list[Image | None],
               queued: deque[tuple[int, Future[blending.Warped | None]]]) -> None:
    i, job = queued.popleft()
    warped = job.result()
    if warped is not None:
        blender.accumulate(warped)
    images[i] = None  # the memory goes as the mosaic grows


def _nothing_usable(survey: Survey, skipped: dict[int, str]) -> str:
    reasons: dict[str, int] = {}
    for why in skipped.values():
        reasons[why.split(" (")[0]] = reasons.get(why.split(" (")[0], 0) + 1
    said = ", ".join(f"{c} {r}" for r, c in sorted(reasons.items(), key=lambda x: -x[1]))
    return (f"{survey.folder}: no usable image of the wall among {len(survey.frames)} ({said}; "
            "'no texture': open water, the wall out of sight)")


def _plan_drawer(plan: list[tuple[float, float]], canvas: blending.Canvas, fw: float,
                 fh: float) -> Any:
    def draw(img: Image) -> None:
        import cv2

        py, pz = np.array(plan).T
        a = canvas.to_px(py.min() - fw / 2, pz.min() - fh / 2)
        b = canvas.to_px(py.max() + fw / 2, pz.max() + fh / 2)
        cv2.rectangle(img, (int(a[0]), int(a[1])), (int(b[0]), int(b[1])), (255, 255, 255), 2)
    return draw
