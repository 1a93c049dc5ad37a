"""mosaic/stages.py's align: ``final`` hears the pairs once, all of them, before the last
alignment that can use them (so that the alignment without the prior may run beside it)."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest

from mosaic import alignment, stages
from mosaic.projection import Intrinsics
from mosaic.registration import Pair

K = Intrinsics(320, 240, 280.0, 280.0, 159.5, 119.5)


def _pair(i: int, j: int) -> Pair:
    pts = np.zeros((4, 2))
    return Pair(i, j, np.eye(3), pts, pts, 4, j == i + 1)


class _Matcher:
    """Finds one new pair in each of the first ``rounds`` searches for overlaps."""

    def __init__(self, rounds: int) -> None:
        self.k, self.left = K, rounds

    def overlapping(self, poses: Any, usable: list[bool], per_image: int) -> list[tuple[int, int]]:
        self.left -= 1
        return [(0, 10 + self.left)] if self.left >= 0 else []

    def match(self, jobs: list[tuple[int, int, bool]], poses: Any) -> list[Pair | str]:
        return [_pair(a, b) for a, b, _ in jobs]


@pytest.mark.parametrize("new_rounds, max_rounds, expected", [
    (5, 3, ["align 1", "align 2", "told 3", "align 3"]),  # pairs keep coming: told before
    # the last alignment
    (1, 3, ["align 1", "align 2", "told 2"]),  # the search after the new pairs finds none
    (0, 3, ["align 1", "told 1"]),
    (3, 1, ["told 1", "align 1"]),  # one alignment only: told before it
])
def test_final_hears_every_pair_once_before_the_last_alignment(
        monkeypatch: pytest.MonkeyPatch, new_rounds: int, max_rounds: int,
        expected: list[str]) -> None:
    events: list[str] = []

    def align(prior: Any, std: Any, pairs: list[Pair], k: Any, **kw: Any) -> Any:
        events.append(f"align {len(pairs)}")
        return alignment.Alignment(np.asarray(prior), 0.0, 1, [])

    monkeypatch.setattr(alignment, "align", align)
    pairs = stages.Pairs([(0, 1, True)], [_pair(0, 1)], {})
    told: list[list[Pair]] = []

    def final(found: list[Pair]) -> None:
        told.append(list(found))
        events.append(f"told {len(found)}")

    matcher: Any = _Matcher(new_rounds)  # what align asks of a Matcher
    got = stages.align(matcher, np.zeros((20, 4)), np.ones((20, 4)), pairs,
                       [True] * 20, 3, max_rounds=max_rounds, final=final)
    assert events == expected
    assert told == [pairs.found]  # once, every pair
    assert got.rounds == sum(e.startswith("align") for e in events)
