"""The run's image recorder when its images cannot be kept (issue 22, deliverable 4): a full
disk printed libpng's "Write Error" once per image (1,312 lines) and a removed folder lost
every image after it in silence; now the first image that cannot be written is named, once,
and no image is rendered after it."""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest

pytest.importorskip("cv2")

from vehicle.sensors.image_recorder import ImageRecorder
from vehicle.sensors.wall_texture import TextureSpec

SPEC = TextureSpec(seed=7, y_range=(-1.0, 4.0), z_range=(0.0, 3.5))
POSE = (-1.5, 1.0, 1.2, 0.0)


def recorder(folder: Path) -> ImageRecorder:
    return ImageRecorder(folder, seed=7, texture=SPEC)


def test_images_are_kept_while_the_folder_is_there(tmp_path: Path) -> None:
    rec = recorder(tmp_path / "run.images")
    for i in range(2):
        rec.record(float(i), POSE, {})
    assert sorted(p.name for p in rec.folder.glob("*.png")) == ["00000.png", "00001.png"]
    assert rec.failure == ""


def test_the_first_image_that_cannot_be_kept_is_named_once(tmp_path: Path,
                                                           monkeypatch: pytest.MonkeyPatch,
                                                           ) -> None:
    rec = recorder(tmp_path / "run.images")
    rec.record(0.0, POSE, {})
    shutil.rmtree(rec.folder)  # the output folder removed mid-run
    with pytest.raises(OSError, match=r"image 00001\.png could not be written in .*run\.images"):
        rec.record(1.0, POSE, {})
    assert rec.failure.startswith("only the first 1 images kept; image 00001.png")
    rendered: list[object] = []
    monkeypatch.setattr(rec.camera(), "render", lambda *a: rendered.append(a))
    for i in range(2, 5):  # silent: nothing rendered, nothing raised, the count goes on
        rec.record(float(i), POSE, {})
    assert rendered == [] and rec.count == 5 and not rec.folder.exists()


def test_a_background_recorder_raises_the_first_failure_at_flush(tmp_path: Path) -> None:
    rec = ImageRecorder(tmp_path / "run.images", seed=7, texture=SPEC, background=True)
    try:
        rec.record(0.0, POSE, {})
        rec.flush()
        shutil.rmtree(rec.folder)
        for i in range(1, 4):
            rec.record(float(i), POSE, {})
        with pytest.raises(OSError, match=r"only the first 1 images kept; image 00001\.png"):
            rec.flush()
    finally:
        rec.close(wait=False)  # its worker process stopped: tests after it count children
