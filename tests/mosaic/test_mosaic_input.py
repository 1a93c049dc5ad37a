"""``mcl mosaic`` on a hostile images folder (issue 22, deliverables 5 and 6): an index that
names ``../../etc/passwd``, an absolute path or a symbolic link, an image of another size than
the camera's, a 20,000 x 20,000 PNG (389 KB of file, 2.4 GB decoded), a FIFO for an index, a
survey over the memory budget: each is refused in one line, exit 2, before one image is
decoded (mosaic/image_files.py). Real folders, real ``mcl mosaic`` subprocesses, under an
address-space limit that the old decoding overran."""

from __future__ import annotations

import json
import os
import resource
import struct
import subprocess
import zlib
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest

cv2 = pytest.importorskip("cv2")

from mission.exits import Exit
from tests.support import BIN, budget, subprocess_env
from vehicle.sensors.image_recorder import ImageRecorder
from vehicle.sensors.wall_texture import TextureSpec

SPEC = TextureSpec(seed=7, y_range=(-1.0, 4.0), z_range=(0.0, 3.5))
LIMIT = 3 << 29  # 1.5 GiB of address space: the mosaic of a small survey needs far less


def survey(folder: Path, images: int = 4) -> Path:
    """A vertical leg of ``images`` images of the wall, the navigation data exact."""
    rec = ImageRecorder(folder, seed=7, texture=SPEC)
    for i, z in enumerate(np.linspace(1.0, 1.6, images)):
        pose = (-1.5, 1.0, float(z), 0.0)
        nav = {"nav_x": -1.5, "nav_y": 1.0, "nav_z": float(z), "nav_psi": 0.0,
               "nav_std_x": 0.02, "nav_std_y": 0.02, "nav_std_z": 0.02, "nav_std_psi": 0.005,
               "wall_distance": 1.5, "wall_distance_std": 0.01, "wall_heading": 0.0,
               "wall_heading_std": 0.005}
        rec.record(i * 0.87, pose, nav)
    return folder


def grey_png(path: Path, width: int, height: int) -> None:
    """A ``width`` x ``height`` PNG of one grey, written a row at a time (never held whole)."""
    def chunk(kind: bytes, data: bytes) -> bytes:
        return struct.pack(">I", len(data)) + kind + data + struct.pack(
            ">I", zlib.crc32(kind + data) & 0xFFFFFFFF)

    packer = zlib.compressobj(9)
    row = bytes(width + 1)
    body = b"".join(packer.compress(row) for _ in range(height)) + packer.flush()
    path.write_bytes(b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", width, height,
                                                                       8, 0, 0, 0, 0))
                     + chunk(b"IDAT", body) + chunk(b"IEND", b""))


def rename_in_index(folder: Path, old: str, new: str) -> None:
    index = folder / "index.csv"
    index.write_text(index.read_text("utf-8").replace(f",{old},", f",{new},"), "utf-8")


def limited() -> None:
    resource.setrlimit(resource.RLIMIT_AS, (LIMIT, LIMIT))


def mosaic(folder: Path, *extra: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run([str(BIN / "mcl"), "mosaic", str(folder), "--no-truth", "--out",
                           str(folder.parent / "out"), *extra], capture_output=True, text=True,
                          timeout=budget(60), env=subprocess_env(), preexec_fn=limited,
                          stdin=subprocess.DEVNULL)


def dot_dot(folder: Path) -> str:
    rename_in_index(folder, "00001.png", "../../etc/passwd")
    return "bad index line (image '../../etc/passwd' is not a file name in the images folder)"


def absolute(folder: Path) -> str:
    rename_in_index(folder, "00001.png", "/etc/passwd")
    return "bad index line (image '/etc/passwd' is not a file name in the images folder)"


def link_out(folder: Path) -> str:
    (folder / "00001.png").unlink()
    (folder / "00001.png").symlink_to("/etc/passwd")
    return "bad index line (image '00001.png' is a symbolic link)"


def link_in(folder: Path) -> str:
    (folder / "00001.png").unlink()
    (folder / "00001.png").symlink_to(folder / "00002.png")
    return "bad index line (image '00001.png' is a symbolic link)"


def mismatched(folder: Path) -> str:
    cv2.imwrite(str(folder / "00002.png"), np.full((480, 640, 3), 90, np.uint8))
    return "bad index line (image '00002.png' is 640 x 480 pixels, not the camera's 320 x 240)"


def huge(folder: Path) -> str:
    grey_png(folder / "00001.png", 20_000, 20_000)
    assert (folder / "00001.png").stat().st_size < 500_000  # a few hundred KB of file
    return "bad index line (image '00001.png' is 20000 x 20000 pixels, not the camera's"


def huge_camera(folder: Path) -> str:
    huge(folder)
    meta = folder / "camera.json"
    meta.write_text(meta.read_text("utf-8").replace('"width": 320', '"width": 20000')
                    .replace('"height": 240', '"height": 20000'), "utf-8")
    return "unreadable camera description (a camera of 20000 x 20000 pixels: at most"


def not_a_png(folder: Path) -> str:
    (folder / "00003.png").write_bytes(b"GIF89a" + bytes(100))
    return "bad index line (image '00003.png' is not a PNG file)"


def a_folder(folder: Path) -> str:
    (folder / "00003.png").unlink()
    (folder / "00003.png").mkdir()
    return "bad index line (image '00003.png' is not a regular file)"


def fifo_index(folder: Path) -> str:
    (folder / "index.csv").unlink()
    os.mkfifo(folder / "index.csv")
    return "unreadable index (not a regular file)"


def camera(folder: Path, **intrinsics: object) -> None:
    """Rewrite camera.json's intrinsics with these values (text: written as given)."""
    meta = folder / "camera.json"
    data = json.loads(meta.read_text("utf-8"))
    data["intrinsics"].update({k: "@" + k for k in intrinsics})
    text = json.dumps(data, indent=1)
    for key, value in intrinsics.items():
        text = text.replace(f'"@{key}"', str(value))
    meta.write_text(text, "utf-8")


def focal_zero(folder: Path) -> str:  # was exit 3: ZeroDivisionError in the projection
    camera(folder, fx=0)
    return "unreadable camera description (focal lengths fx = 0, fy = "


def focal_nan(folder: Path) -> str:
    camera(folder, fy="NaN")
    return "fy = nan: each must be a positive number of pixels)"


def centre_off(folder: Path) -> str:
    camera(folder, cx="1e300")
    return "unreadable camera description (principal point (1e+300, "


def width_negative(folder: Path) -> str:
    camera(folder, width=-5)
    return "unreadable camera description (a camera of -5 x 240 pixels: an image is at least"


def width_huge(folder: Path) -> str:  # the number is not quoted whole
    camera(folder, width="1" + "0" * 400)
    return "unreadable camera description (a camera of so many pixels: at most"


HOSTILE: dict[str, Callable[[Path], str]] = {
    "a focal length of 0": focal_zero, "a focal length NaN": focal_nan,
    "a principal point off the image": centre_off, "a negative width": width_negative,
    "a width of 401 digits": width_huge,
    "../../etc/passwd": dot_dot, "an absolute path": absolute,
    "a symbolic link out": link_out, "a symbolic link in": link_in,
    "a mismatched image": mismatched, "a 20000 x 20000 PNG": huge,
    "a 20000 x 20000 camera": huge_camera, "not a PNG": not_a_png,
    "a folder for an image": a_folder, "a FIFO for the index": fifo_index,
}


@pytest.mark.parametrize("case", sorted(HOSTILE))
def test_a_hostile_images_folder_is_refused_in_one_line(tmp_path: Path, case: str) -> None:
    folder = survey(tmp_path / "run.images")
    says = HOSTILE[case](folder)
    proc = mosaic(folder)
    assert proc.returncode == Exit.INVALID, proc.stderr
    assert "Traceback" not in proc.stderr, proc.stderr
    first = proc.stderr.splitlines()[0]
    assert first.startswith(f"{folder}") and says in first, first
    assert len([x for x in proc.stderr.splitlines() if "error" in x]) == 1, proc.stderr
    assert not (tmp_path / "out.mosaic.png").exists()


def test_a_survey_over_the_memory_budget_is_refused_and_within_it_is_made(
        tmp_path: Path) -> None:
    folder = survey(tmp_path / "run.images")  # 4 images of 320 x 240: 1.8 MB held
    proc = mosaic(folder, "--max-memory", "1MiB")
    assert proc.returncode == Exit.INVALID, proc.stderr
    assert ("4 images of 320 x 240 pixels need about 2 MiB, more than the mosaic's memory "
            "budget of 1 MiB (--max-memory)") in proc.stderr.splitlines()[0], proc.stderr
    proc = mosaic(folder)  # the default budget, under the address-space limit
    assert proc.returncode == Exit.OK, proc.stderr
    assert cv2.imread(str(tmp_path / "out.mosaic.png")) is not None


def test_a_canvas_over_the_budget_is_refused_before_it_is_allocated(tmp_path: Path) -> None:
    folder = survey(tmp_path / "run.images")
    proc = mosaic(folder, "--max-memory", "3MiB", "--scale", "0.5")
    assert proc.returncode == Exit.INVALID, proc.stderr
    assert "mosaic at 0.5 mm/pixel is too large" in proc.stderr, proc.stderr


def test_an_image_replaced_after_the_check_is_not_followed(tmp_path: Path) -> None:
    from mosaic.images import read

    folder = survey(tmp_path / "run.images")
    checked = read(folder)
    (folder / "00001.png").unlink()
    (folder / "00001.png").symlink_to(folder / "00002.png")
    assert checked.load(checked.frames[1]) is None  # set aside as damaged, never followed
    assert checked.load(checked.frames[2]) is not None
