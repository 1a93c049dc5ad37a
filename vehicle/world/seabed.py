"""The seabed scene: sand from a seed, and a pipeline and a cable laid on it along known curves.

Each line (:class:`LaidLine`) runs from ``origin`` along ``heading`` for ``length`` m and
meanders sideways, ``c(s) = amplitude * sin(2 pi s / wavelength)`` at distance s along the
main direction. Stretches of it are partly buried (only the top shows: the visible width
narrows), overgrown (marine growth: dark blotches on and beside it), or buried under sand
entirely (a gap: the line is lost from view). A burial from a time on (``--inject burial@S``)
covers every line from then on. Everything the downward camera renders and every ground-truth
figure (cross-track and heading error) comes from here.

The default scene (:func:`default_scene`) lies in the simulated reservoir of ``robot.py``
(floor at 12 m, the dam wall at x = 0): the pipeline (0.5 m diameter, as the ~1 m pipe of paper
000 scaled to the Ictineu's camera) from (-10, -4) heading +y for 60 m, the cable (0.12 m, as in
paper 004) from (-17, -4) heading +y for 45 m. Chosen here, not in the papers.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

FloatArray = npt.NDArray[np.float64]

TEXEL = 0.02  # m, the sand texture's sample spacing
TILE = 256  # texels: the texture repeats every 5.12 m


@dataclass(frozen=True)
class LaidLine:
    """A pipeline or a cable on the floor. Stretches are (s_from, s_to) in m along ``heading``;
    ``partly_buried`` gives the share of the diameter under sand there."""

    kind: str  # "pipeline" or "cable"
    origin: tuple[float, float]
    heading: float  # rad, world frame (0: +x, pi/2: +y)
    length: float
    diameter: float
    amplitude: float = 1.5
    wavelength: float = 40.0
    albedo: float = 0.85  # the pipe's coating; a cable is dark
    buried: tuple[tuple[float, float], ...] = ()
    partly_buried: tuple[tuple[float, float, float], ...] = ()  # (from, to, share 0..1)
    growth: tuple[tuple[float, float], ...] = ()

    # -- geometry ---------------------------------------------------------------------------
    @property
    def u(self) -> tuple[float, float]:
        return (math.cos(self.heading), math.sin(self.heading))

    @property
    def n(self) -> tuple[float, float]:
        """The main direction turned to starboard (z down: +90 deg)."""
        return (-math.sin(self.heading), math.cos(self.heading))

    def meander(self, s: FloatArray | float) -> FloatArray | float:
        return self.amplitude * np.sin(2 * np.pi * np.asarray(s) / self.wavelength)

    def slope(self, s: FloatArray | float) -> FloatArray | float:
        k = 2 * np.pi / self.wavelength
        return self.amplitude * k * np.cos(k * np.asarray(s))

    def frame(self, x: FloatArray | float, y: FloatArray | float
              ) -> tuple[FloatArray, FloatArray, FloatArray]:
        """(s along, signed distance from the line (+ starboard of it), its local direction)."""
        ux, uy = self.u
        nx, ny = self.n
        dx, dy = np.asarray(x) - self.origin[0], np.asarray(y) - self.origin[1]
        s = dx * ux + dy * uy
        lateral = dx * nx + dy * ny
        slope = np.asarray(self.slope(s))
        e = (lateral - np.asarray(self.meander(s))) * np.cos(np.arctan(slope))
        return s, e, self.heading + np.arctan(slope)

    def frame_near(self, x: FloatArray, y: FloatArray, s0: float
                   ) -> tuple[FloatArray, FloatArray]:
        """:meth:`frame`'s (s, signed distance) for points within a few metres of s0, with the
        meander expanded to second order about s0 (the renderer's fast path)."""
        ux, uy = self.u
        nx, ny = self.n
        dx, dy = x - self.origin[0], y - self.origin[1]
        s = dx * ux + dy * uy
        k = 2 * math.pi / self.wavelength
        a, b = math.sin(k * s0), math.cos(k * s0)
        ds = s - s0
        c = self.amplitude * (a + k * b * ds - 0.5 * k * k * a * ds * ds)
        slope = self.amplitude * k * (b - k * a * ds)
        e = (dx * nx + dy * ny - c) / np.sqrt(1.0 + slope * slope)
        return s, e

    def point(self, s: float) -> tuple[float, float]:
        c = float(self.meander(s))
        return (self.origin[0] + s * self.u[0] + c * self.n[0],
                self.origin[1] + s * self.u[1] + c * self.n[1])

    def direction(self, s: float) -> float:
        return self.heading + math.atan(float(self.slope(s)))

    def polyline(self, step: float = 0.5) -> list[tuple[float, float]]:
        return [self.point(s) for s in np.arange(0.0, self.length + step / 2, step)]

    # -- what shows --------------------------------------------------------------------------
    def visible_share(self, s: FloatArray) -> FloatArray:
        """Share (0..1) of the diameter above the sand at s; 0 off the line's ends."""
        share = np.where((s >= 0) & (s <= self.length), 1.0, 0.0)
        for a, b in self.buried:
            share = np.where((s >= a) & (s <= b), 0.0, share)
        for a, b, part in self.partly_buried:
            share = np.where((s >= a) & (s <= b), np.minimum(share, 1.0 - part), share)
        return share

    def overgrown(self, s: FloatArray) -> npt.NDArray[np.bool_]:
        g = np.zeros_like(s, dtype=bool)
        for a, b in self.growth:
            g |= (s >= a) & (s <= b)
        return g


@dataclass
class Seabed:
    """The floor of the reservoir with the lines on it; ``buried_from``: a mission time from
    which every line is under sand (a long burial, the failure path)."""

    floor_depth: float = 12.0
    seed: int = 1
    lines: tuple[LaidLine, ...] = ()
    buried_from: float | None = None

    @property
    def texture(self) -> FloatArray:
        return sand_texture(self.seed)

    @property
    def growth_texture(self) -> FloatArray:
        return growth_texture(self.seed)

    def bury(self, at: float) -> None:
        self.buried_from = at if self.buried_from is None else min(self.buried_from, at)

    def line(self, kind: str) -> LaidLine | None:
        for line in self.lines:
            if line.kind == kind:
                return line
        return None

    def nearest(self, x: float, y: float) -> LaidLine | None:
        """The line closest to (x, y) (to its ends beyond them)."""
        best, best_d = None, math.inf
        for line in self.lines:
            s, e, _ = (float(v) for v in line.frame(x, y))
            if 0.0 <= s <= line.length:
                d = abs(e)
            else:
                d = math.dist((x, y), line.point(min(max(s, 0.0), line.length)))
            if d < best_d:
                best, best_d = line, d
        return best

    def sand(self, x: FloatArray, y: FloatArray) -> FloatArray:
        i = (x * (1 / TEXEL)).astype(np.int32) & (TILE - 1)  # TILE: a power of 2
        j = (y * (1 / TEXEL)).astype(np.int32) & (TILE - 1)
        return np.asarray(self.texture[i, j], dtype=np.float64)

    def growth(self, x: FloatArray, y: FloatArray) -> FloatArray:
        i = (x * (0.5 / TEXEL)).astype(np.int32) & (TILE - 1)
        j = (y * (0.5 / TEXEL)).astype(np.int32) & (TILE - 1)
        return np.asarray(self.growth_texture[i, j], dtype=np.float64)


def periodic_noise(rng: np.random.Generator, sigma: float) -> FloatArray:
    """White noise blurred by a Gaussian of ``sigma`` texels on the torus (so that the tile
    repeats without seams), scaled to unit standard deviation."""
    white = rng.normal(0.0, 1.0, (TILE, TILE))
    k = np.fft.fftfreq(TILE)
    gain = np.exp(-2 * (np.pi * sigma) ** 2 * (k[:, None] ** 2 + k[None, :] ** 2))
    out = np.real(np.fft.ifft2(np.fft.fft2(white) * gain))
    return np.asarray(out / out.std(), dtype=np.float64)


@functools.lru_cache(maxsize=8)
def growth_texture(seed: int) -> FloatArray:
    """Where marine growth is dense (0 none .. 1.5), blotches of about 6 cm."""
    out = np.clip(periodic_noise(np.random.default_rng([seed, 7]), 3.0) - 0.2, 0.0, 1.5)
    out.setflags(write=False)
    return out


@functools.lru_cache(maxsize=8)
def sand_texture(seed: int) -> FloatArray:
    """Albedo of sand (about 0.45-0.65): blurred noise at two scales and faint ripples."""
    rng = np.random.default_rng([seed, 5])
    fine = periodic_noise(rng, 1.0)
    coarse = periodic_noise(rng, 8.0)
    i = np.arange(TILE)[:, None]
    ripples = np.sin(2 * np.pi * (i * 4 + np.arange(TILE)[None, :]) / TILE * 6)
    out = np.clip(0.55 + 0.04 * fine + 0.05 * coarse + 0.02 * ripples, 0.2, 0.9)
    out.setflags(write=False)  # shared by every scene of this seed
    return out


def default_scene(seed: int = 1, floor_depth: float = 12.0) -> Seabed:
    pipeline = LaidLine("pipeline", (-10.0, -4.0), math.pi / 2, 60.0, 0.5, amplitude=1.5,
                        wavelength=40.0, albedo=0.9,
                        partly_buried=((12.0, 16.0, 0.8),), growth=((20.0, 26.0),),
                        buried=((30.0, 33.0),))
    cable = LaidLine("cable", (-17.0, -4.0), math.pi / 2, 45.0, 0.12, amplitude=1.0,
                     wavelength=30.0, albedo=0.18,
                     partly_buried=((8.0, 11.0, 0.7),), growth=((14.0, 18.0),),
                     buried=((22.0, 24.0),))
    return Seabed(floor_depth, seed, (pipeline, cable))
