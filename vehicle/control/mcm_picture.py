"""The top view of a paper 003 run: both vehicles' tracks, the fixes and the mine (SVG).

Drawn in the earth frame {E} (x north up, y east to the right), from what the stacks kept:
the ASV's track (blue), the UUV's true track (orange) and its navigator's estimate (orange,
dashed), every fix the ASV sent, placed where eq. 3 puts the UUV with its true depth at the
ping (green: heard and fused; purple: heard and refused by the EKF's gate; red ring: never
heard, lost on the link, dropped or after the UUV's end), the mine (black), the camera's
visibility around it (grey ring) and the clutter on the bottom (grey dots).
"""

from __future__ import annotations

import math
from html import escape

from vehicle.control.asv_stack import AsvStack
from vehicle.control.uuv_stack import UuvStack
from vehicle.sensors.multibeam import SonarFix, fix_position
from vehicle.world.survey import axis_ticks


def depth_at(uuv: UuvStack, t: float) -> float:
    """The UUV's true depth (m) at time t (the nearest tick of its track)."""
    if not uuv.track:
        return 0.0
    return min(uuv.track, key=lambda p: abs(p[0] - t))[3]


def fix_point(asv: AsvStack, uuv: UuvStack, fix: SonarFix) -> tuple[float, float]:
    """Where a fix puts the UUV in {E} (eq. 3 with its true depth at the ping)."""
    ox, oy = asv.origin or (0.0, 0.0)
    x, y = fix_position(fix, depth_at(uuv, fix.ping))
    return ox + x, oy + y


def top_view(asv: AsvStack, uuv: UuvStack, title: str) -> str:
    """The SVG of the run's top view (see the module)."""
    scene = asv.world.scene
    heard = {round(f.ping, 3): fused for _, f, fused in uuv.heard_fixes}
    fixes = [(fix_point(asv, uuv, f), heard.get(round(f.ping, 3))) for _, f in asv.sent_fixes]
    ox, oy = asv.origin or (0.0, 0.0)
    released = uuv.world.released_at if uuv.world.released_at is not None else math.inf
    estimate = [(ox + x, oy + y) for t, x, y in uuv.estimates if t >= released]
    free = [(p[1], p[2]) for p in uuv.track if p[0] >= released]  # once in the water
    points = ([(p[1], p[2]) for p in asv.track + uuv.track] + [p for p, _ in fixes]
              + [scene.target[:2]] + list(scene.clutter))
    xs, ys = [p[0] for p in points], [p[1] for p in points]
    x0, x1, y0, y1 = min(xs) - 2, max(xs) + 2, min(ys) - 2, max(ys) + 2
    width, pad = 760, 50
    scale = (width - 2 * pad) / max(y1 - y0, 1e-6)
    height = int(2 * pad + (x1 - x0) * scale)

    def px(x: float, y: float) -> str:  # north up, east right
        return f"{pad + (y - y0) * scale:.1f},{pad + (x1 - x) * scale:.1f}"

    def at(x: float, y: float) -> str:
        return f'cx="{pad + (y - y0) * scale:.1f}" cy="{pad + (x1 - x) * scale:.1f}"'

    tx, ty, _ = scene.target
    out = [f'<svg xmlns="http://www.w3.org/2000/svg" width="{width}" height="{height + 60}" '
           'font-family="Helvetica" font-size="12">',
           f'<rect width="{width}" height="{height + 60}" fill="white"/>',
           f'<text x="{pad}" y="20">{escape(title)}</text>',
           f'<circle {at(tx, ty)} r="{scene.visibility * scale:.1f}" fill="#eee" '
           'stroke="#bbb"/>']
    out += [f'<circle {at(x, y)} r="2.5" fill="#999"/>' for x, y in scene.clutter]
    for name, track, colour, dash in (
            ("asv", [(p[1], p[2]) for p in asv.track], "#1f77b4", ""),
            ("uuv", free, "#ff7f0e", ""),
            ("estimate", estimate, "#ff7f0e", ' stroke-dasharray="4,3"')):
        if track:
            line = " ".join(px(x, y) for x, y in track[::5] + track[-1:])
            out.append(f'<polyline points="{line}" fill="none" stroke="{colour}" '
                       f'stroke-width="{0.9 if name == "estimate" else 1.8}"{dash}/>')
    for (x, y), fused in fixes:
        if fused is None:
            out.append(f'<circle {at(x, y)} r="4" fill="none" stroke="#d62728" '
                       'stroke-width="1.5"/>')
        else:
            out.append(f'<circle {at(x, y)} r="3" fill="{"#2ca02c" if fused else "#9467bd"}"/>')
    s = 6.0
    cx, cy = pad + (ty - y0) * scale, pad + (x1 - tx) * scale
    out.append(f'<polygon points="{cx:.1f},{cy - s:.1f} {cx + s:.1f},{cy:.1f} '
               f'{cx:.1f},{cy + s:.1f} {cx - s:.1f},{cy:.1f}" fill="black"/>')
    for v in axis_ticks(y0, y1, scale, 60.0):
        out.append(f'<text x="{pad + (v - y0) * scale:.1f}" y="{height - pad + 18}" '
                   f'text-anchor="middle">y {v:g} m</text>')
    for v in axis_ticks(x0, x1, scale, 30.0):
        out.append(f'<text x="{pad - 6}" y="{pad + (x1 - v) * scale + 4:.1f}" '
                   f'text-anchor="end">x {v:g} m</text>')
    lost = sum(1 for _, fused in fixes if fused is None)
    out.append(f'<text x="{pad}" y="{height + 10}">blue: the ASV; orange: the UUV once '
               'released (dashed: its estimate); black: the mine; grey ring: the visibility '
               f'({scene.visibility:g} m)</text>')
    out.append(f'<text x="{pad}" y="{height + 28}">fixes where they put the UUV: green fused, '
               f'purple refused by the gate, red ring not heard ({lost} of {len(fixes)}); grey dots: '
               'clutter</text>')
    landed = uuv.track[-1] if uuv.track else None
    if landed is not None:
        miss = math.hypot(landed[1] - tx, landed[2] - ty)
        out.append(f'<text x="{pad}" y="{height + 46}">the UUV ended {miss:.2f} m from the '
                   f'mine, {landed[3]:.1f} m deep</text>')
    out.append("</svg>")
    return "\n".join(out) + "\n"
