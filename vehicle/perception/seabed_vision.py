"""The stack's seabed vision: downward camera, the tracker the running behaviour needs, and the
run's figures against ground truth.

The running behaviours say which tracker they need (``Behaviour.tracker``): while FollowPipeline
runs ("pipeline"), each frame goes to Foresti's EKF (``pipeline_tracker``); while FollowCable
runs ("cable"), to Wirth's Condensation filter (``cable_tracker``); while SearchLine runs
("search"), to the feature extraction alone (a pair of edges of the width of the line last
followed). A follower wins over a search, the pipeline over the cable.
What the tracker sees goes to the behaviours as a :class:`behaviours.seabed.LineView` in
``Perception.line``. No behaviour of these on: no frames are rendered (the dam mission costs
nothing more).

Figures (:meth:`SeabedVision.summary`): the true cross-track error (RMS, max) and heading error
(RMS) while following, the share of frames in which the line was measured, the time it was out
of sight, in how many stretches, and how many of them ended with the line found again; and an
SVG plan (:meth:`SeabedVision.svg`) of the true line (buried stretches dotted), the line as the
tracker placed it, and the path the vehicle followed.
"""

from __future__ import annotations

import math
from collections.abc import Collection
from dataclasses import dataclass, field, replace
from typing import Any
from html import escape  # not xml.sax.saxutils: it imports urllib, http and ssl (14 ms)

import numpy as np

from behaviours.base import Perception
from behaviours.seabed import LineView

from vehicle.perception.cable_tracker import CableTracker
from vehicle.sensors.downward_camera import DownwardCamera
from vehicle.perception.pipeline_tracker import FeatureExtraction, PipelineTracker, PipeModel
from vehicle.world.robot import VehicleState, wrap_angle
from vehicle.world.seabed import LaidLine, Seabed, default_scene

TRACKERS = ("pipeline", "cable", "search")  # what the vision runs, first wanted first


@dataclass
class Figures:
    """Ground truth gathered while a follower runs."""

    kind: str = ""
    cross: list[float] = field(default_factory=list)  # m, per tick
    heading: list[float] = field(default_factory=list)  # rad, per tick
    frames: int = 0
    tracked: int = 0
    lost_stretches: list[tuple[float, float, bool]] = field(default_factory=list)
    lost_since: float | None = None
    path: list[tuple[float, float]] = field(default_factory=list)  # true, while following
    estimated: list[tuple[float, float]] = field(default_factory=list)  # the tracker's line
    searched: list[tuple[float, float]] = field(default_factory=list)  # true, while searching


class SeabedVision:
    def __init__(self, seabed: Seabed | None = None, camera: DownwardCamera | None = None,
                 seed: int = 1) -> None:
        self.seabed = seabed or default_scene(seed)
        self.camera = camera or DownwardCamera()
        self.rng = np.random.default_rng([seed, 40])
        self.mode: str | None = None  # "pipeline", "cable", "search"
        self.target = "pipeline"  # the kind of line last followed (what a search looks for)
        self.next_frame = 0.0
        self.last_frame_t = 0.0
        self.pipe: PipelineTracker | None = None
        self.cable: CableTracker | None = None
        self.detections = 0
        self.last_z: Any = None  # the last detection (i1..i4), for the cable's start
        self.seen_at: float | None = None
        self.last_point: tuple[float, float] | None = None
        self.last_direction: float | None = None
        self.view: LineView | None = None
        self.figures = Figures()
        self.frame_ms: list[float] = []
        self._since = 0.0
        self.last_psi = 0.0
        self.cable_started = False

    def bury(self, at: float) -> None:
        """Every line under sand from mission time ``at`` on (``--inject burial@S``)."""
        self.seabed.bury(at)

    # -- every tick ----------------------------------------------------------------------------
    def perceive(self, t: float, truth: VehicleState, p: Perception,
                 wanted: Collection[str]) -> Perception:
        """``p`` with the line as the tracker ``wanted`` by the enabled behaviours sees it
        (the first of :data:`TRACKERS` among them; none: ``p`` as it is, nothing rendered)."""
        mode = next((kind for kind in TRACKERS if kind in wanted), None)
        if mode != self.mode:
            self._switch(mode, t, p)
        if mode is None:
            return p
        if t + 1e-9 >= self.next_frame:
            self.next_frame = t + 1.0 / self.camera.rate
            self._frame(t, truth, p)
        self._truth(t, truth, mode)
        view = self.view
        if view is not None and self.seen_at is not None:
            view = replace(view, unseen_for=t - self.seen_at)
        elif view is not None:
            view = replace(view, unseen_for=t - self._since)
        return replace(p, line=view)

    def _switch(self, mode: str | None, t: float, p: Perception) -> None:
        if self.mode in ("pipeline", "cable") and self.figures.lost_since is not None:
            self.figures.lost_stretches.append((self.figures.lost_since, t, False))
            self.figures.lost_since = None
        self.mode = mode
        self._since = t
        self.view = None
        self.next_frame = t
        self.last_frame_t = t
        self.last_psi = p.psi
        if mode in ("pipeline", "cable"):
            self.target = mode
            self.figures.kind = mode
            self.seen_at = None
        if mode == "pipeline":
            self.pipe = PipelineTracker.start(self._pipe_model(), self._height(p, "pipeline"),
                                              math.pi / 2 - self.camera.tilt)
        elif mode == "cable":
            self.cable = CableTracker(self.camera.width, self.camera.height,
                                      seed=int(self.rng.integers(1 << 30)))
            self._cable_start(p)
        elif mode == "search":
            self.detections = 0

    def _line_model(self, kind: str) -> LaidLine | None:
        return self.seabed.line(kind)

    def _diameter(self, kind: str) -> float:
        line = self._line_model(kind)
        return line.diameter if line is not None else 0.3

    def _pipe_model(self, kind: str = "pipeline") -> PipeModel:
        cam = self.camera
        return PipeModel(self._diameter(kind), cam.focal, cam.width, cam.height)

    def _height(self, p: Perception, kind: str) -> float:
        """The camera's height above the line's axis, from the DVL (2 m if no lock)."""
        altitude = p.altitude if p.altitude is not None else 2.0
        return max(0.3, altitude - self._diameter(kind) / 2)

    def _cable_start(self, p: Perception) -> None:
        """The particles around the detected cable, if the last frame showed one (the
        thesis's §6.1 proposes a detection first), else spread over Table 5.2's limits (and
        the next frames are searched for a detection)."""
        assert self.cable is not None
        z = self.last_z if self.target == "cable" else None
        self.cable_started = z is not None
        if z is None:
            self.cable.randomise()
            return
        h = self.camera.height - 1
        cx, cy = self.camera.centre
        top, bottom = 0.5 * (z[0] + z[1]), 0.5 * (z[2] + z[3])
        alpha = math.atan2(top - bottom, h)
        mid = 0.5 * (top + bottom) - cx
        w = 0.5 * ((z[1] - z[0]) + (z[3] - z[2])) * math.cos(alpha)
        beta = math.atan2(((z[3] - z[2]) - (z[1] - z[0])) / 2, h)
        self.cable.start_at(mid * math.cos(alpha) - (cy - h / 2) * math.sin(alpha), alpha, w,
                            beta)

    # -- one frame -----------------------------------------------------------------------------
    def _frame(self, t: float, truth: VehicleState, p: Perception) -> None:
        import time

        tau = t - self.last_frame_t
        self.last_frame_t = t
        self.last_psi, last_psi = p.psi, self.last_psi
        image = self.camera.render(self.seabed, (truth.x, truth.y, truth.z, truth.psi), t,
                                   self.rng)
        started = time.process_time()
        offset = angle = 0.0
        if self.mode == "pipeline" and self.pipe is not None:
            self.pipe.predict(tau, p.u, p.v, p.r, p.w)
            tracked = self.pipe.step(image)
            offset, angle = self.pipe.offset, self.pipe.angle
            seen = tracked or self.pipe.acquired
        elif self.mode == "cable" and self.cable is not None:
            if not self.cable_started and self._detect(image, p):
                self._cable_start(p)  # the detection seeds the particles (thesis §6.1)
            turn = wrap_angle(p.psi - last_psi)
            tracked = self.cable.step(image, turn, self.camera.tilt, self.camera.focal)
            height = self._height(p, "cable")
            offset, angle = self.cable.in_vehicle_terms(self.camera.focal, self.camera.tilt,
                                                        height)
            seen = True
        else:  # searching: found once the pair shows in 3 frames running
            self.detections = self.detections + 1 if self._detect(image, p) else 0
            tracked = seen = self.detections >= 3
        self.frame_ms.append(1000 * (time.process_time() - started))
        if tracked:
            self.seen_at = t
        if self.mode in ("pipeline", "cable"):
            self._count(t, tracked)
            if tracked:
                c, s = math.cos(p.psi), math.sin(p.psi)
                self.last_point = (p.x - offset * s, p.y + offset * c)
                self.last_direction = p.psi + angle
                self.figures.estimated.append(self.last_point)
        self.view = LineView(self.mode or "", tracked, offset if seen else 0.0,
                             angle if seen else 0.0, 0.0, self.last_point, self.last_direction)

    def _detect(self, image: Any, p: Perception) -> bool:
        """Foresti's feature extraction and grouping, without a prediction: a pair of edges of
        the width of the line last followed, with a surface between them."""
        model = self._pipe_model(self.target)
        features = FeatureExtraction(model.width, model.height)
        x0 = np.array([0.0, self._height(p, self.target), 0.0, math.pi / 2 - self.camera.tilt])
        z = model.g(x0)
        pairs = features.pairs(features.lines(image), image,
                               (float(z[1] - z[0]), float(z[3] - z[2])))
        found = bool(pairs) and pairs[0][1] > 0.35
        self.last_z = pairs[0][0] if found else None
        return found

    def _count(self, t: float, tracked: bool) -> None:
        f = self.figures
        f.frames += 1
        f.tracked += tracked
        if not tracked and f.lost_since is None:
            f.lost_since = t
        elif tracked and f.lost_since is not None:
            f.lost_stretches.append((f.lost_since, t, True))
            f.lost_since = None

    def _truth(self, t: float, truth: VehicleState, mode: str) -> None:
        if mode == "search":
            self.figures.searched.append((truth.x, truth.y))
            return
        line = self.seabed.line(mode)
        if line is None:
            return
        s, e, direction = (float(v) for v in line.frame(truth.x, truth.y))
        self.figures.path.append((truth.x, truth.y))
        if 0.0 <= s <= line.length:
            self.figures.cross.append(e)
            self.figures.heading.append(wrap_angle(truth.psi - direction))

    # -- the figures ---------------------------------------------------------------------------
    def finish(self, t: float) -> None:
        if self.figures.lost_since is not None:
            self.figures.lost_stretches.append((self.figures.lost_since, t, False))
            self.figures.lost_since = None

    def summary(self) -> dict[str, Any]:
        f = self.figures
        cross = np.array(f.cross) if f.cross else np.array([math.nan])
        head = np.degrees(np.array(f.heading)) if f.heading else np.array([math.nan])
        lost = [(a, b, ok) for a, b, ok in f.lost_stretches if b > a]
        long = [(a, b, ok) for a, b, ok in lost if b - a >= 1.0]  # not a missed frame or two
        return {
            "line": f.kind or "none",
            "frames": f.frames,
            "share_tracked": round(f.tracked / f.frames, 3) if f.frames else 0.0,
            "cross_track_rms_m": round(float(np.sqrt(np.mean(cross ** 2))), 3),
            "cross_track_max_m": round(float(np.max(np.abs(cross))), 3),
            "heading_rms_deg": round(float(np.sqrt(np.mean(head ** 2))), 2),
            "time_lost_s": round(sum(b - a for a, b, _ in lost), 1),
            "lost_stretches": len(long),
            "recovered": sum(1 for _, _, ok in long if ok),
            "frame_ms_median": round(float(np.median(self.frame_ms)), 2) if self.frame_ms
            else 0.0,
        }

    def report(self) -> list[str]:
        """The summary's lines for ``mcl run`` (nothing when no seabed behaviour ran)."""
        if not self.figures.frames and not self.figures.searched:
            return []
        s = self.summary()
        return [f"  {s['line']} tracking: {s['frames']} frames, "
                f"{100 * s['share_tracked']:.0f} % with the line measured; cross-track error "
                f"{s['cross_track_rms_m']} m RMS, {s['cross_track_max_m']} m max; heading "
                f"error {s['heading_rms_deg']} deg RMS",
                f"  line out of sight {s['time_lost_s']} s in all, {s['lost_stretches']} "
                f"stretches of 1 s or more, {s['recovered']} of them recovered; "
                f"{self.camera.width}x{self.camera.height} images, tracker "
                f"{s['frame_ms_median']} ms of CPU a frame (median)"]

    def svg(self, title: str) -> str:
        """Two panels: the plan (x, y) of the true line, the line as tracked and the followed
        path; and the same straightened along the line (distance along it up, the offset
        across it to the right, magnified), with its buried, part-buried and overgrown
        stretches shaded."""
        f = self.figures
        line = self.seabed.line(f.kind or self.target)
        lines = [line] if line is not None else []
        pts = [pt for ln in lines for pt in ln.polyline()] + f.path + f.searched
        if not pts:
            pts = [(0.0, 0.0)]
        xs, ys = [q[0] for q in pts], [q[1] for q in pts]
        x0, x1, y0, y1 = min(xs) - 2, max(xs) + 2, min(ys) - 2, max(ys) + 2
        height, pad = 900, 50
        scale = (height - 2 * pad) / max(y1 - y0, x1 - x0, 1e-6)
        plan_w = int(max(240, 2 * pad + (x1 - x0) * scale))
        strip_w = 520
        width = plan_w + strip_w

        def px(x: float, y: float) -> tuple[float, float]:  # y up the page, x to the right
            return pad + (x - x0) * scale, height - pad - (y - y0) * scale

        out = [f'<svg xmlns="http://www.w3.org/2000/svg" width="{width}" height="{height}" '
               'font-family="Helvetica" font-size="12">',
               f'<rect width="{width}" height="{height}" fill="white"/>',
               f'<text x="{pad}" y="20">{escape(title, quote=False)}: the '
               f'{escape(f.kind or self.target, quote=False)} '
               'in plan (left) and straightened along it (right)</text>']
        for ln in lines:
            ss = np.arange(0.0, ln.length + 0.25, 0.25)
            shown = ln.visible_share(ss) > 0
            for k in range(len(ss) - 1):
                (ax, ay), (bx, by) = px(*ln.point(float(ss[k]))), px(*ln.point(float(ss[k + 1])))
                style = ('stroke="#2ca02c" stroke-width="4"' if shown[k] else
                         'stroke="#2ca02c" stroke-width="2" stroke-dasharray="2,3"')
                out.append(f'<line x1="{ax:.1f}" y1="{ay:.1f}" x2="{bx:.1f}" y2="{by:.1f}" '
                           f'{style}/>')

        def polyline(points: list[tuple[float, float]], style: str) -> None:
            if points:
                text = " ".join(f"{a:.1f},{b:.1f}" for a, b in points)
                out.append(f'<polyline points="{text}" fill="none" {style}/>')

        polyline([px(*q) for q in f.path[::4]], 'stroke="#1f77b4" stroke-width="1.5"')
        polyline([px(*q) for q in f.searched[::4]],
                 'stroke="#9467bd" stroke-width="1" stroke-dasharray="4,2"')
        for q in f.estimated:
            cx, cy = px(*q)
            out.append(f'<circle cx="{cx:.1f}" cy="{cy:.1f}" r="1.5" fill="#ff7f0e"/>')
        if line is not None:
            self._strip(out, line, plan_w, strip_w, height, pad)
        out.append(f'<text x="{pad}" y="{height - 12}">green: true line (dotted, grey: '
                   'buried; light grey: part-buried; pale green: overgrown), orange: the line '
                   'as tracked, blue: the path followed, purple: the search</text>')
        out.append("</svg>")
        return "\n".join(out) + "\n"

    def _strip(self, out: list[str], line: LaidLine, left: float, width: float, height: float,
               pad: float) -> None:
        f = self.figures
        path = [(float(a), float(b)) for a, b, _ in (line.frame(x, y) for x, y in f.path[::2])]
        est = [(float(a), float(b)) for a, b, _ in (line.frame(x, y) for x, y in f.estimated)]
        s_hi = line.length
        half = max([0.5] + [abs(e) * 1.1 for s, e in path + est if 0 <= s <= s_hi])
        x_mid, x_half = left + width / 2, width / 2 - pad
        s_scale = (height - 2 * pad) / max(s_hi, 1e-6)

        def sx(s: float, e: float) -> tuple[float, float]:
            return x_mid + e / half * x_half, height - pad - s * s_scale

        def band(a: float, b: float, colour: str) -> None:
            (_, ya), (_, yb) = sx(a, 0.0), sx(b, 0.0)
            out.append(f'<rect x="{left + pad / 2:.1f}" y="{yb:.1f}" width="{width - pad:.1f}" '
                       f'height="{ya - yb:.1f}" fill="{colour}"/>')

        for a, b in line.growth:
            band(a, b, "#e5f5e0")
        for a, b, _ in line.partly_buried:
            band(a, b, "#eeeeee")
        for a, b in line.buried:
            band(a, b, "#cccccc")
        (tx, ty0), (_, ty1) = sx(0.0, 0.0), sx(s_hi, 0.0)
        out.append(f'<line x1="{tx:.1f}" y1="{ty0:.1f}" x2="{tx:.1f}" y2="{ty1:.1f}" '
                   'stroke="#2ca02c" stroke-width="2"/>')
        inside = [sx(s, e) for s, e in path if 0 <= s <= s_hi]
        if inside:
            text = " ".join(f"{a:.1f},{b:.1f}" for a, b in inside)
            out.append(f'<polyline points="{text}" fill="none" stroke="#1f77b4" '
                       'stroke-width="1.5"/>')
        for s, e in est:
            if 0 <= s <= s_hi:
                cx, cy = sx(s, e)
                out.append(f'<circle cx="{cx:.1f}" cy="{cy:.1f}" r="1.5" fill="#ff7f0e"/>')
        for e in (-half, 0.0, half):
            x, _ = sx(0.0, e)
            out.append(f'<text x="{x:.1f}" y="{height - pad + 16}" text-anchor="middle">'
                       f'{e:+.2f} m</text>')
        for s in range(0, int(s_hi) + 1, 10):
            _, y = sx(float(s), 0.0)
            out.append(f'<text x="{left + pad / 2 - 4:.1f}" y="{y + 4:.1f}" text-anchor="end">'
                       f'{s} m</text>')
