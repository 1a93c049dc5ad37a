"""The trajectory plot's labels (vehicle/world/survey.py; issue 25: the full mission's plot
drew "10 m" over "-3 m"): read off the written SVG, the axis labels' boxes never intersect
and each label stands where its metres are."""

from __future__ import annotations

import re
import xml.etree.ElementTree as ET
from itertools import combinations

import pytest

from vehicle.world.robot import Environment
from vehicle.world.survey import Survey, axis_ticks

SVG = "{http://www.w3.org/2000/svg}"
CHAR = 0.6 * 12  # px: an upper bound of a Helvetica character's width at font-size 12


def boxes(svg: str) -> list[tuple[str, tuple[float, float, float, float]]]:
    """Each text's box (x0, y0, x1, y1), from its position, anchor and length."""
    out = []
    for text in ET.fromstring(svg).iter(f"{SVG}text"):
        s, x, y = text.text or "", float(text.get("x", 0)), float(text.get("y", 0))
        w = CHAR * len(s)
        x0 = {"start": x, "middle": x - w / 2, "end": x - w}[text.get("text-anchor", "start")]
        out.append((s, (x0, y - 10, x0 + w, y + 3)))
    return out


@pytest.mark.parametrize("span", [(-2.4, 15.6, 0.5, 9.3), (0.0, 15.0, 1.0, 4.0),
                                  (-30.0, 60.0, 0.2, 25.0), (3.0, 4.0, 1.0, 1.5)])
def test_the_axis_labels_never_overlap(span: tuple[float, float, float, float]) -> None:
    y_lo, y_hi, z_lo, z_hi = span
    survey = Survey(Environment())
    steps = 50
    for k in range(steps + 1):  # a diagonal path over the whole span
        f = k / steps
        survey.truth.append((k, -1.5, y_lo + f * (y_hi - y_lo), z_lo + f * (z_hi - z_lo)))
        survey.estimate.append((-1.5, y_lo + f * (y_hi - y_lo), z_lo + f * (z_hi - z_lo)))
    svg = survey.svg("full mission")
    found = boxes(svg)
    for (s1, a), (s2, b) in combinations(found, 2):
        assert not (a[0] < b[2] and b[0] < a[2] and a[1] < b[3] and b[1] < a[3]), (s1, s2)
    labels = [(s, b) for s, b in found if re.fullmatch(r"-?[\d.]+ m", s)]
    assert len(labels) >= 4
    # the along-wall labels: x linear in metres (one scale), all within the plotted span
    bottom = max(b[3] for _, b in labels)
    xs = [(float(s[:-2]), (b[0] + b[2]) / 2) for s, b in labels if b[3] == bottom]
    assert len(xs) >= 2
    (v0, x0), (v1, x1) = xs[0], xs[-1]
    for v, x in xs:
        assert x == pytest.approx(x0 + (v - v0) * (x1 - x0) / (v1 - v0), abs=0.2)
        assert y_lo - 1 <= v <= y_hi + 1


def test_ticks_lie_within_the_span_and_apart() -> None:
    assert axis_ticks(-3.4, 16.6, 41.0, 50.0) == [-2.0, 0.0, 2.0, 4.0, 6.0, 8.0, 10.0, 12.0,
                                                  14.0, 16.0]
    assert axis_ticks(-0.5, 10.3, 50.0, 20.0) == [float(v) for v in range(0, 11)]
    assert axis_ticks(0.2, 0.9, 100.0, 20.0) == []
