"""The mosaic and the coverage map as pictures an engineer can measure on: the wall's
coordinates in metres on two axes (along the wall ``y`` under the picture, depth ``z`` on its
left), a grid at round metres over the picture, and a scale bar.

The picture's pixels are the canvas's (mosaic/blending.py: column c at y = y0 + (c + 0.5) s,
row r at z = z0 + (r + 0.5) s), framed by margins: pixel (r, c) of the canvas is pixel
(r + top, c + left) of the written PNG. A grid line at y metres is the column nearest
``left + (y - y0) / s - 0.5`` (a line at z metres likewise a row); each has a tick in the
margin and its label there. The grid's step is the smallest of 0.1, 0.2, 0.5, 1, 2, 5, 10 m
that leaves :data:`MIN_GAP` pixels between lines, so that labels never overlap.
:func:`annotate` returns the picture and its :class:`Frame` (the JSON figures carry it).
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field
from typing import Any

import numpy as np

from mosaic.blending import Canvas, Image

STEPS = (0.1, 0.2, 0.5, 1.0, 2.0, 5.0, 10.0, 20.0, 50.0)  # m, the grid's possible steps
MIN_GAP = 60  # px between two grid lines at least: room for a label ("-12.5 m")
LEFT, TOP, RIGHT, BOTTOM = 76, 14, 24, 64  # px of margin around the picture
FONT_SCALE = 0.42
MARGIN = (255, 255, 255)  # B G R of the margins
INK = (0, 0, 0)  # of the ticks, labels and scale bar
GRID = (255, 255, 255)  # of the grid over the picture (drawn 1 px, half blended)

Box = tuple[int, int, int, int]  # x0, y0, x1, y1 (px) of a label


@dataclass
class Frame:
    """Where the canvas lies in the written picture and what is drawn on it."""

    left: int
    top: int
    px_per_m: float
    step_m: float
    y_lines: dict[str, int] = field(default_factory=dict)  # "2.0" m -> the grid line's column
    z_lines: dict[str, int] = field(default_factory=dict)  # "1.5" m -> the grid line's row
    scale_bar: tuple[int, int, int] = (0, 0, 0)  # row, first and last column (px)
    labels: list[Box] = field(default_factory=list)

    def json(self) -> dict[str, Any]:
        return asdict(self)


def grid_step(px_per_m: float) -> float:
    """The grid's step (m): the smallest of :data:`STEPS` at least MIN_GAP px apart."""
    for step in STEPS:
        if step * px_per_m >= MIN_GAP:
            return step
    return STEPS[-1]


def lines(lo: float, hi: float, step: float) -> list[float]:
    """The multiples of ``step`` within [lo, hi] (m)."""
    first = math.ceil(lo / step - 1e-9)
    return [round(k * step, 6) for k in range(first, math.floor(hi / step + 1e-9) + 1)]


def annotate(img: Image, canvas: Canvas, title: str = "") -> tuple[Image, Frame]:
    """``img`` (the canvas's rows and columns) framed with axes in metres, a grid and a scale
    bar; and its :class:`Frame`."""
    import cv2

    rows, cols = img.shape[:2]
    s = canvas.s
    step = grid_step(1.0 / s)
    out = np.full((TOP + rows + BOTTOM, LEFT + cols + RIGHT, 3), MARGIN, np.uint8)
    out[TOP:TOP + rows, LEFT:LEFT + cols] = img
    frame = Frame(LEFT, TOP, round(1.0 / s, 6), step)
    view = out[TOP:TOP + rows, LEFT:LEFT + cols]

    def text(label: str, x: int, y: int, anchor: str) -> None:
        (w, h), base = cv2.getTextSize(label, cv2.FONT_HERSHEY_SIMPLEX, FONT_SCALE, 1)
        x0 = {"middle": x - w // 2, "end": x - w, "start": x}[anchor]
        cv2.putText(out, label, (x0, y), cv2.FONT_HERSHEY_SIMPLEX, FONT_SCALE, INK, 1,
                    cv2.LINE_AA)
        frame.labels.append((x0, y - h, x0 + w, y + base))

    for y in lines(canvas.y0, canvas.y0 + cols * s, step):
        c = round((y - canvas.y0) / s - 0.5)
        if not 0 <= c < cols:
            continue
        view[:, c] = (view[:, c].astype(np.uint16) + GRID) // 2
        out[TOP + rows:TOP + rows + 6, LEFT + c] = INK
        frame.y_lines[f"{y:g}"] = LEFT + c
        text(f"{y:g} m", LEFT + c, TOP + rows + 20, "middle")
    for z in lines(canvas.z0, canvas.z0 + rows * s, step):
        r = round((z - canvas.z0) / s - 0.5)
        if not 0 <= r < rows:
            continue
        view[r, :] = (view[r, :].astype(np.uint16) + GRID) // 2
        out[TOP + r, LEFT - 6:LEFT] = INK
        frame.z_lines[f"{z:g}"] = TOP + r
        text(f"{z:g} m", LEFT - 9, TOP + r + 5, "end")
    # the scale bar: one grid step, at the bottom left, under the axis labels
    bar_row, length = TOP + rows + 46, round(step / s)
    cv2.rectangle(out, (LEFT, bar_row - 2), (LEFT + length - 1, bar_row + 2), INK, -1)
    frame.scale_bar = (bar_row, LEFT, LEFT + length - 1)
    text(f"{step:g} m", LEFT + length + 8, bar_row + 5, "start")
    caption = "y along the wall (m), z depth (m); grid every " + f"{step:g} m"
    text(caption if not title else f"{title}: {caption}", LEFT + length + 70, bar_row + 5,
         "start")
    return out, frame
