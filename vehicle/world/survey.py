"""What a run achieved, measured against the simulation's ground truth, and its plot.

Path length, the wall area the camera imaged and the share of it seen in at least two images,
the navigator's error, the wall tracker's error during the survey — the figures of paper 002
§7 (a 191 m path covering 40 m² of wall in about 29 min, images overlapping by more than 50 %)
— and an SVG of the path on the wall plane with the USBL fixes, like the paper's Figure 11.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any
from html import escape  # not xml.sax.saxutils: it imports urllib, http and ssl (14 ms)

import numpy as np

from vehicle.world.robot import Environment, VehicleState, wrap_angle
from vehicle.sensors.readings import CameraImage, UsblFix

CELL = 0.05  # m, the grid on which imaged wall area is counted


@dataclass
class Survey:
    env: Environment
    truth: list[tuple[float, float, float, float]] = field(default_factory=list)  # t, x, y, z
    estimate: list[tuple[float, float, float]] = field(default_factory=list)  # x, y, z
    headings: list[tuple[float, float]] = field(default_factory=list)  # true, estimated yaw
    wall: list[tuple[float, float, float, float, float]] = field(
        default_factory=list)  # t, tracked and true distance (m), tracked and true heading (rad)
    nav_errors: list[float] = field(default_factory=list)  # horizontal, m
    wall_dist_errors: list[float] = field(default_factory=list)  # during the survey, m
    wall_head_errors: list[float] = field(default_factory=list)  # during the survey, rad
    fixes: list[tuple[float, float, float, float, bool]] = field(default_factory=list)  # t x y z ok
    footprints: list[tuple[float, float, float, float]] = field(default_factory=list)
    images: int = 0
    path_length: float = 0.0
    _every: int = 0

    def record(self, t: float, s: VehicleState, navigator: Any, tracker: Any,
               surveying: bool) -> None:
        self._every += 1
        if self._every % 4 == 1:  # 5 samples a second: the plot, and the path length
            if self.truth:
                _, x0, y0, z0 = self.truth[-1]
                self.path_length += math.dist((x0, y0, z0), (s.x, s.y, s.z))
            self.truth.append((t, s.x, s.y, s.z))
            ex, ey, ez = (float(navigator.x[i]) for i in range(3))
            self.estimate.append((ex, ey, ez))
            self.headings.append((s.psi, float(navigator.x[3])))
        ex, ey = float(navigator.x[0]), float(navigator.x[1])
        self.nav_errors.append(math.hypot(ex - s.x, ey - s.y))
        if surveying and tracker is not None:
            true_d = self.env.distance_to_wall(s.x, s.y)
            nx, ny = self.env.wall_normal(self.env.wall_foot(s.x, s.y))
            true_h = wrap_angle(s.psi - math.atan2(ny, nx))
            d, h = tracker.distance_to_wall().value, tracker.relative_heading().value
            self.wall_dist_errors.append(d - true_d)
            self.wall_head_errors.append(wrap_angle(h - true_h))
            if self._every % 4 == 1:  # the tracker against the truth, 5 a second
                self.wall.append((t, d, true_d, h, true_h))

    def usbl(self, fix: UsblFix, accepted: bool) -> None:
        x, y, z = (float(v) for v in fix.position)
        self.fixes.append((float(fix.t), x, y, z, accepted))

    def image(self, image: CameraImage) -> None:
        self.images += 1
        if image.footprint is not None:
            f = image.footprint
            self.footprints.append((f.y_min, f.y_max, f.z_min, f.z_max))

    def coverage(self) -> tuple[float, float]:
        """Wall area imaged at least once and at least twice (m²)."""
        if not self.footprints:
            return 0.0, 0.0
        a = np.array(self.footprints)
        y0, z0 = a[:, 0].min(), a[:, 2].min()
        ny = int(math.ceil((a[:, 1].max() - y0) / CELL)) + 1
        nz = int(math.ceil((a[:, 3].max() - z0) / CELL)) + 1
        grid = np.zeros((ny, nz), np.int32)
        for ymin, ymax, zmin, zmax in self.footprints:
            i0, i1 = int((ymin - y0) / CELL), int((ymax - y0) / CELL)
            j0, j1 = int((zmin - z0) / CELL), int((zmax - z0) / CELL)
            grid[i0:i1, j0:j1] += 1
        cell = CELL * CELL
        return float((grid >= 1).sum() * cell), float((grid >= 2).sum() * cell)

    def summary(self) -> dict[str, float]:
        once, twice = self.coverage()

        def rms(values: list[float]) -> float:
            return float(np.sqrt(np.mean(np.square(values)))) if values else float("nan")

        return {
            "path_length_m": round(self.path_length, 1),
            "images": self.images,
            "wall_area_imaged_m2": round(once, 1),
            "wall_area_seen_twice_m2": round(twice, 1),
            "share_seen_twice": round(twice / once, 3) if once else 0.0,
            "navigator_rms_m": round(rms(self.nav_errors), 3),
            "wall_distance_rms_m": round(rms(self.wall_dist_errors), 3),
            "wall_heading_rms_deg": round(math.degrees(rms(self.wall_head_errors)), 2),
            "usbl_fixes": len(self.fixes),
            "usbl_rejected": sum(1 for f in self.fixes if not f[4]),
        }

    def svg(self, title: str) -> str:
        """The path on the wall plane (y along the wall, depth down) with the USBL fixes."""
        pts = [(y, z) for _, _, y, z in self.truth] + [(y, z) for _, _, y, z, _ in self.fixes]
        if not pts:
            pts = [(0.0, 0.0)]
        ys, zs = [p[0] for p in pts], [p[1] for p in pts]
        y0, y1 = min(ys) - 1, max(ys) + 1
        z0, z1 = min(min(zs), 0.0) - 0.5, max(zs) + 1
        width, height, pad = 900, max(240, int(900 * (z1 - z0) / max(y1 - y0, 1e-6))), 50
        sx, sz = (width - 2 * pad) / (y1 - y0), (height - 2 * pad) / (z1 - z0)

        def px(y: float, z: float) -> str:
            return f"{pad + (y - y0) * sx:.1f},{pad + (z - z0) * sz:.1f}"

        out = [f'<svg xmlns="http://www.w3.org/2000/svg" width="{width}" height="{height}" '
               f'font-family="Helvetica" font-size="12">',
               f'<rect width="{width}" height="{height}" fill="white"/>',
               f'<text x="{pad}" y="20">{escape(title, quote=False)}: path on the wall plane '
               '(y along the wall, depth down); dots: USBL fixes (red: rejected)</text>']
        for ymin, ymax, zmin, zmax in self.footprints[::5]:
            out.append(f'<rect x="{pad + (ymin - y0) * sx:.1f}" y="{pad + (zmin - z0) * sz:.1f}" '
                       f'width="{(ymax - ymin) * sx:.1f}" height="{(zmax - zmin) * sz:.1f}" '
                       'fill="#9ecae1" fill-opacity="0.08" stroke="none"/>')
        for _, _, y, z, ok in self.fixes:
            colour = "#444" if ok else "#d62728"
            out.append(f'<circle cx="{pad + (y - y0) * sx:.1f}" cy="{pad + (z - z0) * sz:.1f}" '
                       f'r="1.6" fill="{colour}"/>')
        truth = " ".join(px(y, z) for _, _, y, z in self.truth)
        est = " ".join(px(y, z) for _, y, z in self.estimate)
        out.append(f'<polyline points="{truth}" fill="none" stroke="#1f77b4" stroke-width="1.5"/>')
        out.append(f'<polyline points="{est}" fill="none" stroke="#ff7f0e" stroke-width="0.8" '
                   'stroke-dasharray="3,2"/>')
        out.append(f'<line x1="{pad}" y1="{pad + (0 - z0) * sz:.1f}" x2="{width - pad}" '
                   f'y2="{pad + (0 - z0) * sz:.1f}" stroke="#888" stroke-dasharray="6,3"/>')
        out.append(f'<text x="{width - pad - 220}" y="{height - 12}">blue: true path, orange: '
                   'navigator</text>')
        # the axes' labels: only within the plot (a label past its corner ran into the other
        # axis's: "10 m" over "-3 m"), spaced so that neighbours never touch
        for v in axis_ticks(y0, y1, sx, 50.0):
            out.append(f'<text x="{pad + (v - y0) * sx:.1f}" y="{height - pad + 18}" '
                       f'text-anchor="middle">{v:g} m</text>')
        for v in axis_ticks(z0, z1, sz, 20.0):
            out.append(f'<text x="{pad - 8}" y="{pad + (v - z0) * sz + 4:.1f}" '
                       f'text-anchor="end">{v:g} m</text>')
        out.append("</svg>")
        return "\n".join(out) + "\n"


def axis_ticks(lo: float, hi: float, px_per_m: float, gap: float) -> list[float]:
    """The labelled values of an axis from ``lo`` to ``hi`` (m): multiples of the smallest of
    1, 2, 5, 10, 20, 50 m at least ``gap`` pixels apart, within [lo, hi]."""
    step = next((v for v in (1.0, 2.0, 5.0, 10.0, 20.0, 50.0) if v * px_per_m >= gap), 100.0)
    first, last = math.ceil(lo / step - 1e-9), math.floor(hi / step + 1e-9)
    return [k * step for k in range(first, last + 1)]
