"""The whole pipeline of paper 002 §6 on a run's images, and what it writes.

:func:`build` reads the images folder, corrects the illumination, sets damaged images aside,
registers consecutive and overlapping non-consecutive pairs, aligns all images globally with
the navigation data as a prior, blends the mosaic, draws the coverage map and — for a
simulated run, whose ``camera.json`` names the wall texture — measures all of it against the
ground truth. :func:`write` puts ``PREFIX.mosaic.png``, ``PREFIX.coverage.png`` and
``PREFIX.mosaic.json`` (the figures) beside the run log.
"""

from __future__ import annotations

import json
import os
import threading
import time
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt

from mosaic import accuracy, alignment, blending, illumination, registration
from mosaic.images import Survey, read
from mosaic.projection import FloatArray, homography

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


def _flat_field(raw: list[Image | None], k: Any,
                sample: int = 150) -> illumination.FloatImage:
    """The flat field from up to ``sample`` undamaged images spread over the survey."""
    good = [img for img in raw if img is not None]
    step = max(1, len(good) // sample)
    if not good:
        return np.ones((k.height, k.width, 3), np.float32)
    return illumination.flat_field(good[::step])


def build(path: str | Path, mm_per_px: float = blending.MM_PER_PX, measure: bool = True,
          compare_without_prior: bool = True, per_image: int = 3) -> Result:
    """The mosaic of a run's images folder (or of the run log beside it)."""
    t0, cpu0 = time.perf_counter(), time.process_time()
    survey = read(path)
    frames, k = survey.frames, survey.k
    n = len(frames)
    if n == 0:
        raise ValueError(f"{survey.folder}: the run took no images")
    skipped: dict[int, str] = {}
    workers = ThreadPoolExecutor(max(1, min(4, os.cpu_count() or 1)))  # OpenCV frees the GIL
    raw: list[Image | None] = list(workers.map(survey.load, frames))  # read once
    for i, f in enumerate(frames):  # damaged images set aside at once
        why = illumination.damaged(raw[i])
        if why is not None:
            skipped[f.index] = why
            raw[i] = None
    field_ = _flat_field(raw, k)
    local = threading.local()

    def prepare(i: int) -> tuple[str | None, Image | None, registration.Features | None]:
        img = raw[i]
        if img is None:
            return None, None, None
        corrected = illumination.correct(img, field_)
        why = illumination.textureless(corrected)
        if why is not None:
            return why, None, None
        if not hasattr(local, "detector"):
            local.detector = registration.Detector()
        feat = local.detector.detect(illumination.grey_u8(corrected))
        return None, np.asarray(np.clip(corrected, 0, 255), dtype=np.uint8), feat

    feats: list[registration.Features | None] = []
    for i, (why, kept, feat) in enumerate(workers.map(prepare, range(n))):
        if why is not None:
            skipped[frames[i].index] = why
        raw[i] = kept  # the corrected image, kept for blending
        feats.append(feat)
    t_features = time.perf_counter()
    usable = [ft is not None for ft in feats]
    prior = np.array([f.prior for f in frames], dtype=float)
    prior_std = np.array([f.prior_std for f in frames], dtype=float)
    # registration: consecutive usable images, then overlapping ones from other passages
    hw = [homography(p, k) for p in prior]
    ca, cb = k.slopes(np.array([[k.cx, k.cy]]))
    from mosaic.projection import wall_points

    centres = wall_points(prior, ca[0], cb[0])
    d = float(np.median(prior[:, 2]))
    fw, fh = d * k.width / k.fx, d * k.height / k.fy
    order = [i for i in range(n) if usable[i]]
    tried = [(a, b, True) for a, b in zip(order, order[1:])]
    tried += [(a, b, False) for a, b in registration.candidates(centres, (fw, fh), usable,
                                                                per_image=per_image)]
    shape = (k.height, k.width)

    def register(job: tuple[int, int, bool]) -> registration.Pair | str:
        a, b, consecutive = job
        fa, fb = feats[a], feats[b]
        assert fa is not None and fb is not None
        if not hasattr(local, "detector"):
            local.detector = registration.Detector()
        guess = np.linalg.inv(hw[a]) @ hw[b]
        got: registration.Pair | str = local.detector.match(fa, fb, shape, a, b, consecutive,
                                                            guess)
        return got

    pairs: list[registration.Pair] = []
    failed: dict[str, int] = {}
    for got in workers.map(register, tried):
        if isinstance(got, str):
            key = got.split(" ", 1)[-1] if got[0].isdigit() else got
            failed[key] = failed.get(key, 0) + 1
        else:
            pairs.append(got)
    t_register = time.perf_counter()
    al = alignment.align(prior, prior_std, pairs, k, use_prior=True)
    poses = al.poses
    # §6.6: look for overlaps again from the aligned poses, register the new ones, align
    # again; until no new pair (at most 3 rounds)
    seen_pairs = {(a, b) for a, b, _ in tried}
    rounds = 1
    for _ in range(2):
        centres = wall_points(poses, ca[0], cb[0])
        new = [(a, b, False) for a, b in registration.candidates(centres, (fw, fh), usable,
                                                                 per_image=per_image)
               if (a, b) not in seen_pairs]
        if not new:
            break
        seen_pairs.update((a, b) for a, b, _ in new)
        tried += new
        hw = [homography(p, k) for p in poses]
        found = [got for got in workers.map(register, new) if not isinstance(got, str)]
        if not found:
            break
        pairs += found
        al = alignment.align(prior, prior_std, pairs, k, use_prior=True, x0=poses)
        poses = al.poses
        rounds += 1
    workers.shutdown()
    t_align = time.perf_counter()
    # blending
    registered = np.zeros(n, bool)
    for p in pairs:
        registered[p.i] = registered[p.j] = True
    boxes = [blending.footprint(poses[i], k) for i in range(n) if usable[i]]
    plan = survey.plan()
    if plan:
        py, pz = np.array(plan).T
        boxes.append((py.min() - fw / 2, py.max() + fw / 2, pz.min() - fh / 2, pz.max() + fh / 2))
    if not boxes:
        reasons: dict[str, int] = {}
        for why in skipped.values():
            reasons[why.split(" (")[0]] = reasons.get(why.split(" (")[0], 0) + 1
        said = ", ".join(f"{c} {r}" for r, c in sorted(reasons.items(), key=lambda x: -x[1]))
        raise ValueError(f"{survey.folder}: no usable image of the wall among {n} ({said}; "
                         "'no texture': open water, the wall out of sight)")
    canvas = blending.canvas_for(boxes, mm_per_px)
    blender = blending.Blender(canvas, k)
    for i in range(n):
        if not usable[i]:
            continue
        img = raw[i]
        assert img is not None
        blender.add(img, poses[i])
        raw[i] = None  # the memory goes as the mosaic grows
    mosaic = blender.mosaic()
    coverage = blending.coverage_image(blender.count, canvas,
                                       _plan_drawer(plan, canvas, fw, fh) if plan else None)
    t_blend = time.perf_counter()
    elapsed = t_blend - t0
    figures: dict[str, Any] = {
        "images": n, "used": int(sum(usable)), "set_aside": len(skipped),
        "registered_images": int(registered.sum()),
        "pairs_tried": len(tried), "pairs_registered": len(pairs),
        "consecutive_pairs": sum(1 for p in pairs if p.consecutive),
        "non_consecutive_pairs": sum(1 for p in pairs if not p.consecutive),
        "pairs_failed": failed, "pairs_rejected_by_alignment": len(al.rejected),
        "alignment_rounds": rounds,
        "mm_per_px": mm_per_px, "size_px": [canvas.cols, canvas.rows],
        "wall_area_m2": [round(canvas.y0, 3), round(canvas.z0, 3),
                         round(canvas.y0 + canvas.cols * canvas.s, 3),
                         round(canvas.z0 + canvas.rows * canvas.s, 3)],
        "area_seen_m2": round(float((blender.count > 0).sum()) * canvas.s**2, 2),
        "area_seen_twice_m2": round(float((blender.count > 1).sum()) * canvas.s**2, 2),
        "images_per_cell": _per_cell(blender.count),
        "seconds": {"features": round(t_features - t0, 2),
                    "registration": round(t_register - t_features, 2),
                    "alignment": round(t_align - t_register, 2),
                    "blending": round(t_blend - t_align, 2), "total": round(elapsed, 2),
                    "cpu": round(time.process_time() - cpu0, 2)},
        "images_per_second": round(n / elapsed, 1),
    }
    result = Result(survey, mosaic, coverage, canvas, poses, skipped, figures)
    truth = np.array([f.truth for f in frames], dtype=float) if all(
        f.truth is not None for f in frames) else None
    if measure and truth is not None:
        _measure(result, truth, pairs, prior, prior_std, blender.count, compare_without_prior)
    return result


def _per_cell(count: npt.NDArray[np.uint16]) -> dict[str, float]:
    seen = count[count > 0]
    if seen.size == 0:
        return {"median": 0.0, "p10": 0.0, "max": 0.0}
    return {"median": float(np.median(seen)), "p10": float(np.percentile(seen, 10)),
            "max": float(seen.max())}


def _measure(result: Result, truth: FloatArray, pairs: list[registration.Pair],
             prior: FloatArray, prior_std: FloatArray, count: npt.NDArray[np.uint16],
             compare_without_prior: bool) -> None:
    k, fig = result.survey.k, result.figures
    used = np.array([f.index not in result.skipped for f in result.survey.frames])
    reg = accuracy.registration_errors(pairs, truth, k)
    fig["registration_error_px"] = {
        "median": round(float(np.median(reg)), 3) if reg.size else None,
        "rms": round(float(np.sqrt(np.mean(reg**2))), 3) if reg.size else None,
        "max": round(float(reg.max()), 3) if reg.size else None}
    fig["alignment_error_mm"] = accuracy.stats_mm(
        accuracy.position_errors(result.poses, truth, k)[used])
    fig["navigation_error_mm"] = accuracy.stats_mm(
        accuracy.position_errors(prior, truth, k)[used])
    if compare_without_prior and pairs:
        anchor = int(np.flatnonzero(used)[0])
        alone = alignment.align(prior, prior_std, pairs, k, use_prior=False, anchor=anchor)
        fig["alignment_error_without_prior_mm"] = accuracy.stats_mm(
            accuracy.position_errors(alone.poses, truth, k)[used])
    gt = accuracy.truth_on_canvas(result.survey.meta, result.canvas)
    if gt is not None:
        cp = accuracy.control_points(result.mosaic, gt, count, result.canvas)
        fig["control_points"] = len(cp)
        fig["mosaic_error_mm"] = accuracy.stats_mm(np.hypot(cp[:, 2], cp[:, 3]))


def _plan_drawer(plan: list[tuple[float, float]], canvas: blending.Canvas, fw: float,
                 fh: float) -> Any:
    def draw(img: Image) -> None:
        import cv2

        py, pz = np.array(plan).T
        a = canvas.to_px(py.min() - fw / 2, pz.min() - fh / 2)
        b = canvas.to_px(py.max() + fw / 2, pz.max() + fh / 2)
        cv2.rectangle(img, (int(a[0]), int(a[1])), (int(b[0]), int(b[1])), (255, 255, 255), 2)
    return draw


def write(result: Result, prefix: Path) -> dict[str, Path]:
    """Write PREFIX.mosaic.png, PREFIX.coverage.png and PREFIX.mosaic.json."""
    import cv2

    paths = {"mosaic": prefix.with_name(prefix.name + ".mosaic.png"),
             "coverage": prefix.with_name(prefix.name + ".coverage.png"),
             "figures": prefix.with_name(prefix.name + ".mosaic.json")}
    cv2.imwrite(str(paths["mosaic"]), result.mosaic)
    cv2.imwrite(str(paths["coverage"]), result.coverage)
    doc = dict(result.figures)
    doc["set_aside"] = {str(k): v for k, v in sorted(result.skipped.items())}
    doc["frame"] = ("wall frame: y along the wall (columns, left to right), z depth (rows, "
                    "down), m; pixel (r, c) centred at y0 + (c + 0.5) s, z0 + (r + 0.5) s")
    paths["figures"].write_text(json.dumps(doc, indent=1) + "\n", encoding="utf-8")
    return paths


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
