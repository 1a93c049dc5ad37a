"""Blending (mosaic/blending.py, mosaic/stages.py): images warped by several threads and
added in their order make the same mosaic, to the last bit, as one thread adding them."""

from __future__ import annotations

from concurrent.futures import ThreadPoolExecutor

import numpy as np
import pytest

pytest.importorskip("cv2")

from mosaic.blending import Blender, canvas_for, footprint
from mosaic.projection import Intrinsics
from mosaic.stages import add_in_order

K = Intrinsics(width=96, height=72, fx=103.0, fy=103.0, cx=47.5, cy=35.5)


def _survey(n: int) -> tuple[list[np.ndarray | None], np.ndarray]:
    rng = np.random.default_rng(3)
    poses = np.array([[0.05 * i, 0.2 * np.sin(i), 1.5 + 0.05 * rng.normal(),
                       0.02 * rng.normal()] for i in range(n)])
    images: list[np.ndarray | None] = [rng.integers(0, 256, (72, 96, 3), dtype=np.uint8)
                                       for _ in range(n)]
    images[5] = None  # set aside
    return images, poses


def test_threads_warp_and_the_sums_stay_the_same() -> None:
    images, poses = _survey(40)
    canvas = canvas_for([footprint(p, K) for p in poses], mm_per_px=6.0)
    one = Blender(canvas, K)
    for img, pose in zip(images, poses):
        if img is not None:
            one.add(img, pose)
    many = Blender(canvas, K)
    copies = list(images)
    with ThreadPoolExecutor(4) as workers:
        add_in_order(many, copies, poses, workers, ahead=3)
    assert np.array_equal(one.acc, many.acc) and np.array_equal(one.count, many.count)
    assert one.count.max() > 3  # the images overlap: the order of the sums matters
    assert all(img is None for img in copies)  # each image freed once added
    serial = Blender(canvas, K)
    add_in_order(serial, list(images), poses, None)
    assert np.array_equal(one.acc, serial.acc)
