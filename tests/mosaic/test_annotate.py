"""The mosaic and coverage map carry the wall's coordinates, a grid and a scale bar
(mosaic/annotate.py; issue 25: "no scale bar, grid or wall coordinates, so a crack cannot be
located from the picture"). Tested on the written PNG: the grid lines' pixels where the
metres say, the scale bar's length, labels that do not overlap."""

from __future__ import annotations

from itertools import combinations
from pathlib import Path

import cv2
import numpy as np
import pytest

from mosaic.annotate import LEFT, TOP, annotate, grid_step, lines
from mosaic.blending import Canvas


def overlap(a: tuple[int, int, int, int], b: tuple[int, int, int, int]) -> bool:
    return a[0] < b[2] and b[0] < a[2] and a[1] < b[3] and b[1] < a[3]


@pytest.mark.parametrize("mm_per_px", [4.0, 8.0, 20.0])
def test_the_grid_lines_lie_where_the_metres_say(tmp_path: Path, mm_per_px: float) -> None:
    canvas = Canvas(y0=-0.37, z0=0.81, mm_per_px=mm_per_px, rows=int(3600 / mm_per_px),
                    cols=int(16000 / mm_per_px))
    picture = np.full((canvas.rows, canvas.cols, 3), 40, np.uint8)
    framed, frame = annotate(picture, canvas)
    path = tmp_path / "m.png"
    cv2.imwrite(str(path), framed)
    read = cv2.imread(str(path))
    assert read.shape[0] > canvas.rows and read.shape[1] > canvas.cols
    # the picture itself where the frame says, untouched off the grid
    assert (frame.left, frame.top) == (LEFT, TOP)
    s = mm_per_px / 1000
    step = frame.step_m
    assert step * (1 / s) >= 60 and step in (0.2, 0.5, 1.0, 2.0)
    ys = lines(canvas.y0, canvas.y0 + canvas.cols * s, step)
    assert [float(k) for k in frame.y_lines] == ys and len(ys) >= 3
    middle = TOP + canvas.rows // 2
    for y, column in frame.y_lines.items():
        # metres -> column: y = y0 + (c + 0.5) s, c counted from the picture's left edge
        assert column == LEFT + round((float(y) - canvas.y0) / s - 0.5)
        assert read[middle, column].mean() > 100  # the grid line, light over the dark wall
        assert read[middle, column + 3].mean() == 40  # beside it, the picture as it was
        assert read[TOP + canvas.rows + 3, column].max() == 0  # its tick under the picture
    for z, row in frame.z_lines.items():
        assert row == TOP + round((float(z) - canvas.z0) / s - 0.5)
        assert read[row, LEFT + 5].mean() > 100 and read[row, LEFT - 3].max() == 0
    # depths 0.81 m to 4.41 m: the grid at every step between, none outside
    assert [float(k) for k in frame.z_lines] == lines(0.81, 4.41, step)
    assert "4" in frame.z_lines and not {"0", "5"} & frame.z_lines.keys()
    # the scale bar is one grid step long
    row, first, last = frame.scale_bar
    black = np.flatnonzero(read[row, :, :].max(axis=1) == 0)
    assert black[0] == first == LEFT and last - first + 1 == round(step / s)
    assert black[black < LEFT + round(step / s) + 4][-1] == last
    # no two labels overlap, and all lie inside the picture
    for a, b in combinations(frame.labels, 2):
        assert not overlap(a, b), (a, b)
    assert all(0 <= x0 and x1 <= read.shape[1] and 0 <= y0 and y1 <= read.shape[0]
               for x0, y0, x1, y1 in frame.labels)


def test_the_grid_step_leaves_room_for_labels() -> None:
    assert grid_step(250.0) == 0.5 and grid_step(50.0) == 2.0 and grid_step(1000.0) == 0.1
    assert lines(-0.37, 2.2, 1.0) == [0.0, 1.0, 2.0]
