"""The files of a run's images folder, checked before anything is decoded, and the memory the
mosaic may use.

A folder is hostile input like any other: ``index.csv`` may name ``../../etc/passwd``, an
absolute path or a symbolic link, and a PNG of a few hundred kilobytes may decode to
gigabytes (20,000 x 20,000 pixels of one grey compress to 389 KB). So, before one image is
decoded:

* ``camera.json`` and ``index.csv`` are read with a size limit (:data:`MAX_TEXT_BYTES`);
* the camera's image size is at most :data:`MAX_IMAGE_PIXELS`;
* each image is named by a plain file name in the folder (no folder part, no ``..``, not
  absolute), and is a regular file there, not a link, of at most :data:`MAX_IMAGE_BYTES`;
* its PNG header (the first 24 bytes: signature and IHDR) gives the size the camera says;
* what the pipeline then holds, :func:`survey_bytes` (every image twice, as read and
  corrected, and the canvas), fits the memory budget (``mcl mosaic --max-memory``,
  default :data:`MAX_BYTES`).
"""

from __future__ import annotations

import math
import os
import stat
import struct
from pathlib import Path, PurePosixPath, PureWindowsPath

MAX_BYTES = 2 << 30  # the mosaic's memory budget by default: 2 GiB
MAX_TEXT_BYTES = 64 << 20  # camera.json, index.csv (the dam mission's index: 0.5 MB)
MAX_IMAGE_PIXELS = 4096 * 4096  # one image (the simulated camera's: 320 x 240)
MAX_IMAGE_BYTES = 64 << 20  # one PNG file
# The pipeline holds every image as read (B G R bytes) and, once corrected, again; the canvas
# holds per pixel a weighted B G R and a weight (4 float32), a count (uint16), the mosaic and
# the coverage map (B G R bytes each).
IMAGE_BYTES_PER_PIXEL = 3 + 3
CANVAS_BYTES_PER_PIXEL = 16 + 2 + 3 + 3
PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"


def read_text(path: Path, limit: int = MAX_TEXT_BYTES) -> str:
    """The text of ``path``, refused (ValueError) past ``limit`` bytes or if it is not a
    regular file (a FIFO would hang the read, a device never end it)."""
    fd = os.open(path, os.O_RDONLY | getattr(os, "O_NONBLOCK", 0))  # a FIFO: no wait
    with os.fdopen(fd, "rb") as stream:
        if not stat.S_ISREG(os.fstat(stream.fileno()).st_mode):
            raise ValueError("not a regular file")
        data = stream.read(limit + 1)
    if len(data) > limit:
        raise ValueError(f"larger than {limit:,} bytes")
    return data.decode("utf-8")


def image_path(folder: Path, name: str) -> Path:
    """The image ``name`` of ``folder``; ValueError unless it is a plain file name there
    that is a regular file, not a link, of at most :data:`MAX_IMAGE_BYTES`."""
    if (not name or name in (".", "..") or len(PurePosixPath(name).parts) != 1
            or len(PureWindowsPath(name).parts) != 1 or "\0" in name):
        raise ValueError(f"image {name!r} is not a file name in the images folder")
    path = folder / name
    try:
        info = path.lstat()
    except OSError:
        raise ValueError(f"image {name!r} is missing") from None
    if stat.S_ISLNK(info.st_mode):
        raise ValueError(f"image {name!r} is a symbolic link")
    if not stat.S_ISREG(info.st_mode):
        raise ValueError(f"image {name!r} is not a regular file")
    if info.st_size > MAX_IMAGE_BYTES:
        raise ValueError(f"image {name!r} has {info.st_size:,} bytes, more than "
                         f"{MAX_IMAGE_BYTES:,}")
    return path


def png_size(path: Path) -> tuple[int, int]:
    """(width, height) from the PNG header of ``path``, read without decoding; ValueError if
    it is not a PNG."""
    with path.open("rb") as stream:
        head = stream.read(24)
    if len(head) < 24 or head[:8] != PNG_SIGNATURE or head[12:16] != b"IHDR":
        raise ValueError(f"image {path.name!r} is not a PNG file")
    width, height = struct.unpack(">II", head[16:24])
    return int(width), int(height)


def check_camera(width: int, height: int) -> None:
    """ValueError unless the camera's images have a size within :data:`MAX_IMAGE_PIXELS`."""
    size = f"{width} x {height}" if max(abs(width), abs(height)) < 10**9 else "so many"
    if width < 1 or height < 1:
        raise ValueError(f"a camera of {size} pixels: an image is at least 1 x 1")
    if width * height > MAX_IMAGE_PIXELS:
        raise ValueError(f"a camera of {size} pixels: at most "
                         f"{MAX_IMAGE_PIXELS:,} pixels an image")


def check_optics(width: int, height: int, focal: tuple[float, float],
                 centre: tuple[float, float]) -> None:
    """ValueError unless the camera's focal lengths (pixels) are positive and finite and its
    principal point lies within its ``width`` x ``height`` image: a focal length of 0 would
    divide every pixel's ray by zero, a point off the image project nowhere on the wall."""
    if not all(math.isfinite(f) and f > 0 for f in focal):
        raise ValueError(f"focal lengths fx = {focal[0]:.6g}, fy = {focal[1]:.6g}: each must "
                         "be a positive number of pixels")
    cx, cy = centre
    if not (0 <= cx <= width and 0 <= cy <= height):  # also False for a NaN
        raise ValueError(f"principal point ({cx:.6g}, {cy:.6g}) off the {width} x {height} "
                         "image")


def check_image(folder: Path, name: str, width: int, height: int) -> Path:
    """The path of image ``name``, checked (:func:`image_path`) and of the camera's size."""
    path = image_path(folder, name)
    size = png_size(path)
    if size != (width, height):
        raise ValueError(f"image {name!r} is {size[0]} x {size[1]} pixels, not the camera's "
                         f"{width} x {height}")
    return path


def read_image(folder: Path, name: str, width: int, height: int) -> bytes | None:
    """The bytes of image ``name`` of ``folder``, opened without following a link, if it
    is a regular file of at most :data:`MAX_IMAGE_BYTES` whose PNG header says ``width`` x
    ``height``; None otherwise (the file changed since it was checked)."""
    try:
        fd = os.open(folder / image_path(folder, name).name,
                     os.O_RDONLY | getattr(os, "O_NOFOLLOW", 0) | getattr(os, "O_NONBLOCK", 0))
    except (OSError, ValueError):
        return None
    with os.fdopen(fd, "rb") as stream:
        if not stat.S_ISREG(os.fstat(stream.fileno()).st_mode):
            return None
        data = stream.read(MAX_IMAGE_BYTES + 1)
    if not 24 <= len(data) <= MAX_IMAGE_BYTES or data[:8] != PNG_SIGNATURE or data[12:16] != b"IHDR" \
            or struct.unpack(">II", data[16:24]) != (width, height):
        return None
    return data


def survey_bytes(images: int, width: int, height: int) -> int:
    """Bytes the pipeline holds for ``images`` images of ``width`` x ``height``."""
    return images * width * height * IMAGE_BYTES_PER_PIXEL


def canvas_pixels(max_bytes: int, images_bytes: int) -> int:
    """The most pixels a canvas may have beside images of ``images_bytes`` within
    ``max_bytes``."""
    return max(0, (max_bytes - images_bytes) // CANVAS_BYTES_PER_PIXEL)
