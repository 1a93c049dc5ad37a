"""The camera that sees the wall (paper 002 §6.1): a pinhole camera rendering the dam wall.

The wall is a texture generated from a seed — concrete with formwork joints, stains, algae and
cracks — kept as a ground-truth image at :data:`TEXTURE_MM_PER_PX` mm per pixel over a wall
patch in the wall frame (y along the wall, z depth down, metres). Each image is rendered from
the vehicle's true pose: rays through every pixel of a pinhole camera (no roll or pitch: the
Ictineu is passively stable), cut with the wall surface x = wall_curvature * y**2, sampled
from the texture; then the conditions of §6.7 as far as they matter for registration: the
vehicle's lamp (a spot off the optical axis with cos^4 fall-off), light lost over the range
(lamp to wall and back), backscatter and the water's colour, a mild blur, and sensor noise.

Chosen here (the paper gives no camera figures): 320 x 240 pixels (small, to be fast), square
pixels, focal length 343.1 px (50 deg horizontal, 38.6 deg vertical field of view: the 50 x 38
deg of vehicle.sensors.instruments.Camera), principal point at the centre, no lens distortion (§6.1
removes it before anything else); texture at 4 mm/pixel (the camera sees 4.4 mm per pixel at
1.5 m), over y -3..19 m and z -0.5..6.5 m (beyond it the texture is mirrored); attenuation
0.25 /m (green water of a reservoir; red 0.45 /m, blue 0.3 /m).

:class:`ImageRecorder` writes each image as a PNG with the navigation data of the instant in
``index.csv`` and the camera's figures in ``camera.json`` (docs/MOSAIC.md).
"""

from __future__ import annotations

import csv
import json
import math
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt

FloatArray = npt.NDArray[np.float64]
Image = npt.NDArray[np.uint8]

WIDTH, HEIGHT = 320, 240  # pixels
HFOV = math.radians(50.0)
FOCAL = 0.5 * WIDTH / math.tan(0.5 * HFOV)  # px, square pixels
TEXTURE_MM_PER_PX = 4.0
TEXTURE_Y = (-3.0, 19.0)  # m along the wall
TEXTURE_Z = (-0.5, 6.5)  # m depth
VISIBILITY = 4.0  # m, as vehicle.sensors.instruments.Camera
ATTENUATION = (0.30, 0.25, 0.45)  # 1/m, B G R
WATER = (95.0, 110.0, 60.0)  # B G R of the backscatter seen at long range


@dataclass(frozen=True)
class Intrinsics:
    """Pinhole camera K (§6.1, Eq. 33): focal lengths and principal point in pixels."""

    width: int = WIDTH
    height: int = HEIGHT
    fx: float = FOCAL
    fy: float = FOCAL
    cx: float = 0.5 * (WIDTH - 1)
    cy: float = 0.5 * (HEIGHT - 1)

    def rays(self) -> tuple[FloatArray, FloatArray]:
        """Per pixel, the ray's body-frame slopes a = (u - cx)/fx (starboard), b = (v - cy)/fy
        (down), for a ray (1, a, b) along the optical axis (forward)."""
        u, v = np.meshgrid(np.arange(self.width, dtype=np.float64),
                           np.arange(self.height, dtype=np.float64))
        return (u - self.cx) / self.fx, (v - self.cy) / self.fy


# --- the wall ---------------------------------------------------------------------------------
@dataclass(frozen=True)
class TextureSpec:
    seed: int = 1
    mm_per_px: float = TEXTURE_MM_PER_PX
    y_range: tuple[float, float] = TEXTURE_Y
    z_range: tuple[float, float] = TEXTURE_Z

    @property
    def shape(self) -> tuple[int, int]:
        """(rows, columns): rows along z (down), columns along y."""
        s = self.mm_per_px / 1000.0
        return (int(round((self.z_range[1] - self.z_range[0]) / s)),
                int(round((self.y_range[1] - self.y_range[0]) / s)))

    def to_pixel(self, y: npt.ArrayLike, z: npt.ArrayLike) -> tuple[FloatArray, FloatArray]:
        """Wall (y, z) in m -> texture (column, row), pixel centres at integers."""
        s = self.mm_per_px / 1000.0
        col = (np.asarray(y, dtype=float) - self.y_range[0]) / s - 0.5
        row = (np.asarray(z, dtype=float) - self.z_range[0]) / s - 0.5
        return col, row


def _noise(rng: np.random.Generator, shape: tuple[int, int], cell: float) -> FloatArray:
    """Smooth value noise of about `cell` pixels' feature size, zero mean, unit-ish spread."""
    import cv2

    h, w = shape
    gh, gw = max(2, int(h / cell) + 2), max(2, int(w / cell) + 2)
    grid = rng.standard_normal((gh, gw)).astype(np.float32)
    big = cv2.resize(grid, (int(gw * cell), int(gh * cell)), interpolation=cv2.INTER_CUBIC)
    return np.asarray(big[:h, :w], dtype=np.float64)


def make_texture(spec: TextureSpec) -> Image:
    """The wall's ground-truth colour image (B, G, R), deterministic for ``spec.seed``.

    Fine detail (grain, aggregate, air voids, joints, cracks) is made at full resolution;
    the slowly varying colour (patchiness, rust streaks, algae) at an eighth of it, then
    enlarged once.
    """
    import cv2

    rng = np.random.default_rng([spec.seed, 2002])
    h, w = spec.shape
    px_per_m = 1000.0 / spec.mm_per_px
    # concrete: grain at a few mm, aggregate at a few cm, air voids
    grey: Any = rng.standard_normal((h, w), dtype=np.float32)
    grey = cv2.GaussianBlur(grey, (0, 0), 0.8)
    grey *= 14.0
    grey += 9.0 * _noise(rng, (h, w), 0.02 * px_per_m)
    grey += 7.0 * _noise(rng, (h, w), 0.08 * px_per_m)
    grey += 140.0
    grey[_noise(rng, (h, w), 0.012 * px_per_m) > 2.1] -= 45.0
    # formwork joints: lift joints every 1.5 m in depth, panel joints every 3 m along the wall
    for z in np.arange(math.ceil(spec.z_range[0] / 1.5) * 1.5, spec.z_range[1], 1.5):
        r = int((z - spec.z_range[0]) * px_per_m)
        grey[max(r - 2, 0):r + 2, :] -= 50.0
    for y in np.arange(math.ceil(spec.y_range[0] / 3.0) * 3.0, spec.y_range[1], 3.0):
        c = int((y - spec.y_range[0]) * px_per_m)
        grey[:, max(c - 1, 0):c + 2] -= 50.0
    # cracks: thin dark random walks
    cracks = np.zeros((h, w), np.uint8)
    area = (spec.y_range[1] - spec.y_range[0]) * (spec.z_range[1] - spec.z_range[0])
    for _ in range(int(area / 5.0)):
        x, y0 = rng.uniform(0, w), rng.uniform(0, h)
        heading = rng.uniform(0, 2 * math.pi)
        pts = [(x, y0)]
        for _ in range(int(rng.integers(30, 120))):
            heading += rng.normal(0.0, 0.35)
            step = rng.uniform(3.0, 8.0)
            x, y0 = x + step * math.cos(heading), y0 + step * math.sin(heading)
            pts.append((x, y0))
        cv2.polylines(cracks, [np.array(pts, np.int32)], False, 255,
                      int(rng.integers(1, 3)), cv2.LINE_AA)
    grey = cv2.scaleAdd(cracks.astype(np.float32), -70.0 / 255.0, grey)
    grey = cv2.GaussianBlur(grey, (0, 0), 0.5)
    # slowly varying colour, at 1/8 resolution: patchiness, rust streaks down from the lift
    # joints, algae (denser with depth)
    lh, lw = h // 8 + 1, w // 8 + 1
    lpx = px_per_m / 8.0
    patch = 12.0 * _noise(rng, (lh, lw), 0.8 * lpx)
    streak = cv2.resize(rng.standard_normal((max(2, lh // 8), max(2, lw // 3))).astype(np.float32),
                        (lw, lh), interpolation=cv2.INTER_CUBIC)
    stain = np.clip(streak - 1.0, 0.0, None) * np.clip(_noise(rng, (lh, lw), 1.0 * lpx), 0, None)
    depth = np.linspace(spec.z_range[0], spec.z_range[1], lh, dtype=np.float32)[:, None]
    algae = _noise(rng, (lh, lw), 0.35 * lpx) + 0.6 * _noise(rng, (lh, lw), 0.06 * lpx)
    algae = np.clip(algae + 0.25 * depth - 1.2, 0.0, 1.2)
    low: Any = np.stack([patch - 22.0 * stain - 40.0 * algae, patch - 14.0 * stain - 5.0 * algae,
                    patch - 2.0 * stain - 45.0 * algae], axis=-1).astype(np.float32)
    low = cv2.resize(low, (w, h), interpolation=cv2.INTER_LINEAR)
    low += grey[:, :, None]
    np.minimum(low, 255.0, out=low)
    np.maximum(low, 0.0, out=low)
    return np.asarray(low, dtype=np.uint8)


class WallTexture:
    """The ground-truth wall image, made on first use (about a second)."""

    def __init__(self, spec: TextureSpec | None = None) -> None:
        self.spec = spec or TextureSpec()
        self._image: Image | None = None

    @property
    def image(self) -> Image:
        if self._image is None:
            self._image = make_texture(self.spec)
        return self._image

    def sample(self, y: FloatArray, z: FloatArray) -> Image:
        """The texture at wall points (m), bilinear, mirrored beyond its edges."""
        import cv2

        col, row = self.spec.to_pixel(y, z)
        out = cv2.remap(self.image, col.astype(np.float32), row.astype(np.float32),
                        cv2.INTER_LINEAR, borderMode=cv2.BORDER_REFLECT_101)
        return np.asarray(out, dtype=np.uint8)

    def crop(self, y0: float, z0: float, mm_per_px: float, shape: tuple[int, int]) -> Image:
        """The texture resampled on a grid: pixel (r, c) centred at (y0 + (c + 0.5) s,
        z0 + (r + 0.5) s), s = mm_per_px / 1000 (the mosaic's grid)."""
        import cv2

        s = mm_per_px / 1000.0
        rows, cols = shape
        ys = y0 + (np.arange(cols) + 0.5) * s
        zs = z0 + (np.arange(rows) + 0.5) * s
        col, row = self.spec.to_pixel(ys, zs)
        ratio = mm_per_px / self.spec.mm_per_px
        src: Any = self.image
        if ratio > 1.5:  # shrink first, so that the resampling does not alias
            src = cv2.resize(src, None, fx=1.0 / ratio, fy=1.0 / ratio,
                             interpolation=cv2.INTER_AREA)
            col, row = (col + 0.5) / ratio - 0.5, (row + 0.5) / ratio - 0.5
        mc = np.broadcast_to(col[None, :], shape).astype(np.float32)
        mr = np.broadcast_to(row[:, None], shape).astype(np.float32)
        out = cv2.remap(src, mc, mr, cv2.INTER_LINEAR, borderMode=cv2.BORDER_REFLECT_101)
        return np.asarray(out, dtype=np.uint8)


# --- the camera -------------------------------------------------------------------------------
def wall_hits(pose: tuple[float, float, float, float], a: FloatArray, b: FloatArray,
              wall_curvature: float = 0.0) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Where the rays of slopes (a, b) from a camera at pose (x, y, z, yaw) meet the wall
    x = c y**2: wall y, wall z and the range (m); NaN where a ray misses it."""
    x0, y0, z0, psi = pose
    c, s = math.cos(psi), math.sin(psi)
    dx, dy, dz = c - s * a, s + c * a, b
    if wall_curvature == 0.0:
        with np.errstate(divide="ignore", invalid="ignore"):
            t = np.where(dx > 1e-9, -x0 / dx, np.nan)
    else:  # c (y0 + t dy)^2 = x0 + t dx: the smallest positive root
        qa = wall_curvature * dy * dy
        qb = 2.0 * wall_curvature * y0 * dy - dx
        qc = wall_curvature * y0 * y0 - x0
        disc = qb * qb - 4.0 * qa * qc
        with np.errstate(divide="ignore", invalid="ignore"):
            root = np.sqrt(np.where(disc >= 0, disc, np.nan))
            t1 = np.where(np.abs(qa) > 1e-12, (-qb - root) / (2 * qa), -qc / qb)
            t2 = np.where(np.abs(qa) > 1e-12, (-qb + root) / (2 * qa), np.nan)
            t = np.where(t1 > 0, t1, np.where(t2 > 0, t2, np.nan))
    t = np.where(t > 0, t, np.nan)
    norm = np.sqrt(dx * dx + dy * dy + dz * dz)
    return y0 + t * dy, z0 + t * dz, t * norm


@dataclass
class Lighting:
    """The vehicle's lamp and the water: see the module's docstring."""

    spot: tuple[float, float] = (0.35, -0.25)  # lamp's aim on the image, in half-widths
    spot_width: float = 0.75  # Gaussian sigma of the spot, in image widths
    gain: float = 1.15  # the brightness of a wall at the reference range, spot's centre
    reference_range: float = 1.5  # m
    attenuation: tuple[float, float, float] = ATTENUATION
    water: tuple[float, float, float] = WATER
    blur: float = 0.7  # px, Gaussian sigma (optics and motion)
    noise: float = 2.5  # DN, sensor noise sigma


class WallCamera:
    """Renders what the camera sees of the wall from a pose (x, y, z, yaw)."""

    def __init__(self, texture: WallTexture, wall_curvature: float = 0.0,
                 intrinsics: Intrinsics | None = None, lighting: Lighting | None = None,
                 visibility: float = VISIBILITY) -> None:
        self.texture, self.wall_curvature = texture, wall_curvature
        self.k = intrinsics or Intrinsics()
        self.light = lighting or Lighting()
        self.visibility = visibility
        self.a, self.b = self.k.rays()
        w = self.k.width
        sx = self.k.cx + self.light.spot[0] * 0.5 * w
        sy = self.k.cy + self.light.spot[1] * 0.5 * w
        u, v = np.meshgrid(np.arange(w), np.arange(self.k.height))
        spot = np.exp(-((u - sx) ** 2 + (v - sy) ** 2) / (2 * (self.light.spot_width * w) ** 2))
        cos4 = 1.0 / (1.0 + self.a**2 + self.b**2) ** 2
        self.pattern = (spot * cos4)[:, :, None]  # the lamp's pattern on the image (0..1)
        self._k = np.asarray(self.light.attenuation, np.float32)[None, None, :]
        r0 = self.light.reference_range
        self._lamp_at_reference = (self.light.gain * self.pattern * r0 * r0 * np.exp(
            2.0 * self._k * r0)).astype(np.float32)
        self._back = (np.asarray(self.light.water, np.float32)[None, None, :]
                      * (0.35 + 0.65 * self.pattern)).astype(np.float32)

    def render(self, pose: tuple[float, float, float, float],
               rng: np.random.Generator) -> Image:
        """The B, G, R image (HEIGHT x WIDTH, uint8) seen from the pose."""
        import cv2

        y, z, rng_m = wall_hits(pose, self.a, self.b, self.wall_curvature)
        seen = np.isfinite(rng_m) & (rng_m <= self.visibility)
        wall = self.texture.sample(np.where(seen, y, 0.0), np.where(seen, z, 0.0))
        r = np.where(seen, rng_m, self.visibility).astype(np.float32)[:, :, None]
        lost = np.exp(-self._k * r)  # the share of light left after r metres of water
        transmit = lost * lost  # lamp to wall and back, relative to the reference range
        transmit *= self._lamp_at_reference / (r * r)  # and the lamp's light spreads
        transmit[~seen] = 0.0
        img: Any = wall.astype(np.float32) * transmit
        lost -= 1.0
        lost *= -self._back  # backscatter: the water's colour where the light was lost
        img += lost
        img = cv2.GaussianBlur(img, (0, 0), self.light.blur)
        noise = rng.standard_normal(img.shape, dtype=np.float32)
        noise *= self.light.noise
        img += noise
        return np.asarray(np.clip(img + 0.5, 0, 255), dtype=np.uint8)

    def centre(self, pose: tuple[float, float, float, float]) -> tuple[float, float] | None:
        """Wall (y, z) at the image's centre, None if the axis misses the wall."""
        y, z, r = wall_hits(pose, np.array([0.0]), np.array([0.0]), self.wall_curvature)
        return None if not np.isfinite(r[0]) else (float(y[0]), float(z[0]))


# --- the record of a run ----------------------------------------------------------------------
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
        import cv2

        cam = self.camera()
        assert self._rng is not None
        img = cam.render(pose, self._rng)
        cv2.imwrite(str(self.folder / name), img, [cv2.IMWRITE_PNG_COMPRESSION, 1,  # fast
                                                    cv2.IMWRITE_PNG_STRATEGY,
                                                    cv2.IMWRITE_PNG_STRATEGY_HUFFMAN_ONLY])
        row: dict[str, Any] = {"index": index, "t": round(t, 3), "file": name,
                               "x": pose[0], "y": pose[1], "z": pose[2], "psi": pose[3]}
        row.update(nav)
        with (self.folder / "index.csv").open("a", newline="", encoding="utf-8") as f:
            csv.writer(f).writerow([_cell(row.get(k)) for k in INDEX_FIELDS])

    def from_stack(self, stack: Any, image: Any) -> Path | None:
        """Record a :class:`vehicle.sensors.instruments.CameraImage` taken by the stack's camera, with the
        navigator's and the wall tracker's estimates at that instant."""
        if image.pose is None:
            return None
        survey = stack.behaviours.get("WallInspection")
        if survey is not None and survey.active and getattr(survey, "path", None):
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
