"""The mosaic measured against the simulation's ground truth (what the paper could not do).

* pairwise registration error: for each registered pair, the mean distance (pixels) between
  where the estimated and the true homography send the pair's points;
* global alignment error: each image's position (the wall point at its centre) against the
  truth, in mm;
* mosaic error at control points: patches of the mosaic on a grid, located in the ground-truth
  texture resampled on the mosaic's grid by phase correlation; the offset in mm.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import numpy.typing as npt

from mosaic.blending import Canvas
from mosaic.projection import FloatArray, Intrinsics, apply, homography, wall_points
from mosaic.registration import Pair
from vehicle.sensors.wall_texture import TextureSpec, WallTexture

Image = npt.NDArray[np.uint8]


def true_pair_homography(ti: FloatArray, tj: FloatArray, k: Intrinsics) -> FloatArray:
    """Pixels of j -> pixels of i from the true poses."""
    return np.asarray(np.linalg.inv(homography(ti, k)) @ homography(tj, k))


def registration_errors(pairs: Sequence[Pair], truth: FloatArray, k: Intrinsics) -> FloatArray:
    """Per pair, the mean pixel distance between the estimated and the true motion."""
    hw = {i: homography(truth[i], k) for i in {i for p in pairs for i in (p.i, p.j)}}
    inverse = {i: np.linalg.inv(hw[i]) for i in {p.i for p in pairs}}  # each image's, once
    out = []
    for p in pairs:
        h = inverse[p.i] @ hw[p.j]  # true_pair_homography's
        out.append(float(np.mean(np.hypot(*(apply(p.h, p.pj) - apply(h, p.pj)).T))))
    return np.array(out)


def position_errors(poses: FloatArray, truth: FloatArray, k: Intrinsics) -> FloatArray:
    """Per image, the distance (m) between estimated and true wall points at its centre."""
    a, b = k.slopes(np.array([[k.cx, k.cy]]))
    est = wall_points(poses, a[0], b[0])
    tru = wall_points(truth, a[0], b[0])
    return np.asarray(np.hypot(*(est - tru).T))


def control_points(mosaic: Image, truth: Image, count: npt.NDArray[np.uint16], canvas: Canvas,
                   spacing: float = 0.5, patch: int = 64,
                   min_response: float = 0.05) -> FloatArray:
    """Offsets (m) of the mosaic against the truth at control points on a ``spacing`` grid
    inside the area every pixel of whose patch some image saw; rows (y, z, dy, dz)."""
    import cv2

    gm = cv2.cvtColor(mosaic, cv2.COLOR_BGR2GRAY).astype(np.float32)
    gt = cv2.cvtColor(truth, cv2.COLOR_BGR2GRAY).astype(np.float32)
    win = cv2.createHanningWindow((patch, patch), cv2.CV_32F)
    step = max(int(round(spacing / canvas.s)), patch)
    half = patch // 2
    out = []
    for r in range(half, canvas.rows - half, step):
        for c in range(half, canvas.cols - half, step):
            if count[r - half:r + half, c - half:c + half].min() == 0:
                continue
            a = gm[r - half:r + half, c - half:c + half]
            b = gt[r - half:r + half, c - half:c + half]
            a = (a - a.mean()) / (a.std() + 1e-6)
            b = (b - b.mean()) / (b.std() + 1e-6)
            (dx, dy), resp = cv2.phaseCorrelate(b, a, win)
            if resp < min_response:
                continue
            y = canvas.y0 + (c + 0.5) * canvas.s
            z = canvas.z0 + (r + 0.5) * canvas.s
            out.append((y, z, dx * canvas.s, dy * canvas.s))
    return np.array(out).reshape(-1, 4)


def truth_texture(meta: dict[str, object]) -> WallTexture | None:
    """The run's wall texture, made (about a second of CPU; a thread may make it while the
    mosaic is built), None if the run has no texture spec."""
    spec = meta.get("texture")
    if not isinstance(spec, dict):
        return None
    tex = WallTexture(TextureSpec(seed=int(spec["seed"]), mm_per_px=float(spec["mm_per_px"]),
                                  y_range=(float(spec["y_range"][0]), float(spec["y_range"][1])),
                                  z_range=(float(spec["z_range"][0]), float(spec["z_range"][1]))))
    _ = tex.image  # made now, in the caller's thread
    return tex


def truth_on_canvas(meta: dict[str, object], canvas: Canvas,
                    texture: WallTexture | None = None) -> Image | None:
    """The ground-truth texture on the mosaic's grid (None if the run has no texture spec);
    ``texture``: the run's, if already made."""
    tex = texture or truth_texture(meta)
    return None if tex is None else tex.crop(canvas.y0, canvas.z0, canvas.mm_per_px,
                                             (canvas.rows, canvas.cols))


def stats_mm(values_m: FloatArray) -> dict[str, float]:
    v = np.asarray(values_m, dtype=float) * 1000.0
    if v.size == 0:
        return {"rms": float("nan"), "median": float("nan"), "max": float("nan")}
    return {"rms": round(float(np.sqrt(np.mean(v * v))), 1),
            "median": round(float(np.median(v)), 1), "max": round(float(v.max()), 1)}
