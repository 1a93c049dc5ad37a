"""The camera's worker process (vehicle/sensors/image_worker.py): the images it writes are
those the main process would write, bit for bit; it is stopped on every exit — closed, its
parent killed, ``mcl run`` stopped by a signal — and a failure reaches the main process as an
OSError."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from multiprocessing import shared_memory
from pathlib import Path

import numpy as np
import pytest

cv2 = pytest.importorskip("cv2")

from mosaic import build
from vehicle.sensors.image_recorder import ImageRecorder
from vehicle.sensors.image_worker import WorkerError
from vehicle.sensors.image_writer import ImageWriter
from vehicle.sensors.wall_texture import TextureSpec

from tests.support import BIN, MISSIONS, REPO

SPEC = TextureSpec(seed=7, y_range=(-1.0, 4.0), z_range=(0.0, 3.5))
NAV = {"nav_x": -1.5, "nav_y": 1.0, "nav_z": 1.5, "nav_psi": 0.0, "nav_std_x": 0.02,
       "nav_std_y": 0.02, "nav_std_z": 0.02, "nav_std_psi": 0.005}
WAIT = 60.0  # s: only a hang fails a test here


def _record(folder: Path, background: bool) -> ImageRecorder:
    rec = ImageRecorder(folder, seed=7, texture=SPEC, background=background)
    rng = np.random.default_rng(1)
    for i in range(5):
        rec.record(0.87 * i, (-1.5 + rng.normal(0, 0.02), 1.0 + 0.1 * i, 1.5, 0.01 * i), NAV)
        if i == 2:
            rec.set_plan([(1.0, 1.5), (1.4, 1.5)])
    rec.flush()
    return rec


def _gone(pid: int) -> bool:
    """Whether the process has ended (a zombie waiting for its parent counts as ended)."""
    try:
        state = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
    except (FileNotFoundError, ProcessLookupError):
        return True
    return state in ("Z", "X")


def _wait_gone(pids: list[int]) -> list[int]:
    deadline = time.monotonic() + WAIT
    while time.monotonic() < deadline and not all(_gone(p) for p in pids):
        time.sleep(0.1)
    return [p for p in pids if not _gone(p)]


def _children(pid: int) -> list[int]:
    out = []
    for stat in Path("/proc").glob("[0-9]*/stat"):
        try:
            fields = stat.read_text().rsplit(")", 1)[1].split()
        except OSError:
            continue
        if int(fields[1]) == pid:
            out.append(int(stat.parent.name))
    return out


def test_the_worker_writes_the_images_the_main_process_would(tmp_path: Path) -> None:
    here = _record(tmp_path / "here.images", background=False)
    there = _record(tmp_path / "there.images", background=True)
    assert there.sink is not None and there.sink.process.is_alive()  # type: ignore[union-attr]
    process = there.sink.process  # type: ignore[union-attr]
    there.close()
    assert not process.is_alive() and process.exitcode == 0
    names = sorted(p.name for p in (tmp_path / "here.images").iterdir())
    assert names == ["00000.png", "00001.png", "00002.png", "00003.png", "00004.png",
                     "camera.json", "index.csv"]
    for name in names:  # the same bytes: one generator, in the order the images were taken
        assert (tmp_path / "there.images" / name).read_bytes() == \
            (tmp_path / "here.images" / name).read_bytes(), name
    here.close()


@pytest.mark.skipif(not hasattr(os, "getpriority"), reason="no process priorities here")
def test_the_worker_yields_the_cores_to_the_simulation(tmp_path: Path) -> None:
    """The worker runs NICE steps below the process that started it: the simulation's one
    thread keeps its core and the worker takes what the simulation leaves (then catches up)."""
    from vehicle.sensors.image_worker import NICE

    there = _record(tmp_path / "there.images", background=True)
    process = there.sink.process  # type: ignore[union-attr]
    assert process.pid is not None and process.is_alive()
    ours = os.getpriority(os.PRIO_PROCESS, 0)
    assert NICE > 0
    assert os.getpriority(os.PRIO_PROCESS, process.pid) == min(19, ours + NICE)
    there.close()


def test_the_wall_texture_the_worker_made_is_handed_to_the_main_process(tmp_path: Path) -> None:
    """The mosaic measures against the texture the worker made (not made a second time): the
    copy in shared memory is the texture of the run's spec, pixel for pixel, and is gone with
    the worker; the in-process writer hands its own."""
    from vehicle.sensors.wall_texture import make_texture

    truth = make_texture(SPEC)
    there = _record(tmp_path / "there.images", background=True)
    here = _record(tmp_path / "here.images", background=False)
    for rec in (there, here):
        tex = rec.wall_texture()
        assert tex is not None and tex.spec == SPEC
        assert tex.image.shape == truth.shape and np.array_equal(tex.image, truth)
    there.close()
    here.close()
    assert there.wall_texture() is None and here.wall_texture() is None


def test_images_lit_in_threads_are_those_lit_one_after_another(tmp_path: Path) -> None:
    """The worker's writer draws each image's noise in order and lights, exposes and encodes
    the images in threads, more of them in flight than it lets wait: the files, index.csv's
    lines in order, and the pixels handed on are those of a writer that does one at a time."""
    handed: dict[int, np.ndarray] = {}
    one = ImageWriter(tmp_path / "one.images", seed=7, texture=SPEC)
    many = ImageWriter(tmp_path / "many.images", seed=7, texture=SPEC, threads=2,
                       on_image=lambda i, img: handed.__setitem__(i, img.copy()))
    rng = np.random.default_rng(2)
    for i in range(12):
        pose = (-1.5 + rng.normal(0, 0.05), 0.5 + 0.15 * i, 1.0 + 0.1 * (i % 4), 0.02 * i)
        kept = one.write(i, f"{i:05d}.png", 0.87 * i, pose, NAV)
        assert many.write(i, f"{i:05d}.png", 0.87 * i, pose, NAV) is None  # in a thread
        assert kept is not None
        handed[100 + i] = kept
    many.flush()
    for w in (one, many):
        w.close()
    names = sorted(p.name for p in (tmp_path / "one.images").iterdir())
    assert len(names) == 14
    for name in names:
        assert (tmp_path / "many.images" / name).read_bytes() == \
            (tmp_path / "one.images" / name).read_bytes(), name
    assert all(np.array_equal(handed[i], handed[100 + i]) for i in range(12))


def test_a_worker_that_died_is_an_os_error_at_the_next_flush(tmp_path: Path) -> None:
    rec = ImageRecorder(tmp_path / "run.images", seed=7, texture=SPEC, background=True)
    worker = rec.start()
    os.kill(worker.process.pid, signal.SIGKILL)  # type: ignore[union-attr, arg-type]
    worker.process.join(WAIT)  # type: ignore[union-attr]
    with pytest.raises(OSError, match="camera's worker"):
        rec.record(0.0, (-1.5, 1.0, 1.5, 0.0), NAV)
        rec.flush()
    rec.close()


def test_a_write_that_fails_in_the_worker_reaches_the_flush(tmp_path: Path) -> None:
    blocker = tmp_path / "run.images"
    blocker.write_text("a file where the folder should be")
    rec = ImageRecorder(blocker, seed=7, texture=SPEC, background=True)
    rec.record(0.0, (-1.5, 1.0, 1.5, 0.0), NAV)
    with pytest.raises(WorkerError, match="writing the images failed"):
        rec.flush()
    rec.close()


ORPHAN = """
import sys, time
from pathlib import Path
from vehicle.sensors.image_recorder import ImageRecorder
rec = ImageRecorder(Path(sys.argv[1]), background=True)
print(rec.start().process.pid, flush=True)
time.sleep(600)
"""


def test_the_worker_ends_when_its_parent_is_killed(tmp_path: Path) -> None:
    env = dict(os.environ, PYTHONPATH=str(REPO))
    parent = subprocess.Popen([sys.executable, "-c", ORPHAN, str(tmp_path / "run.images")],
                              cwd=REPO, env=env, stdout=subprocess.PIPE, text=True,
                              stderr=subprocess.DEVNULL)  # its resource tracker's warning
    try:
        assert parent.stdout is not None
        worker = int(parent.stdout.readline())
        assert not _gone(worker)
        parent.kill()  # SIGKILL: no atexit, no close
        parent.wait(WAIT)
        assert _wait_gone([worker]) == [], "the orphaned worker is still running"
    finally:
        if parent.poll() is None:
            parent.kill()
            parent.wait()


@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM])
def test_mcl_run_stopped_by_a_signal_leaves_no_worker(tmp_path: Path, sig: int) -> None:
    log = tmp_path / "run.jsonl"
    env = dict(os.environ, PYTHONPATH=str(REPO))
    proc = subprocess.Popen([str(BIN / "mcl"), "run", str(MISSIONS / "dam_inspection.mcl"),
                             "--quiet", "--log", str(log)], cwd=REPO, env=env,
                            stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL,
                            stderr=subprocess.PIPE, text=True)
    try:
        deadline = time.monotonic() + WAIT
        workers: list[int] = []
        while time.monotonic() < deadline and not (workers and log.exists()
                                                   and '"running"' in log.read_text()):
            assert proc.poll() is None, proc.communicate()[1]
            workers = _children(proc.pid)
            time.sleep(0.05)
        assert workers, "no camera worker was started"
        proc.send_signal(sig)
        _, err = proc.communicate(timeout=WAIT)
        assert proc.returncode == 128 + sig, err  # docs/EXIT.md: stopped by signal N
        assert "Traceback" not in err, err
        assert _wait_gone(workers) == [], "a worker outlived mcl run"
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()


def _shared_blocks() -> set[str]:
    return {p.name for p in Path("/dev/shm").glob("psm_*")} if Path("/dev/shm").is_dir() \
        else set()


def test_the_pixels_wait_in_shared_memory_for_the_mosaic(tmp_path: Path,
                                                         monkeypatch: pytest.MonkeyPatch) -> None:
    made: list[str] = []  # the blocks this recorder makes (other tests' runs make theirs)

    class Recorded(shared_memory.SharedMemory):
        def __init__(self, name: str | None = None, create: bool = False, size: int = 0):
            super().__init__(name, create, size)
            if create:
                made.append(self.name)

    monkeypatch.setattr(shared_memory, "SharedMemory", Recorded)  # as shared_frames calls it
    rec = _record(tmp_path / "run.images", background=True)
    for i in range(5):
        kept = rec.frame(i)
        assert kept is not None and not kept.flags.writeable
        assert np.array_equal(kept, cv2.imread(str(tmp_path / "run.images" / f"{i:05d}.png")))
    assert rec.frame(5) is None  # never taken
    from_files = build.build(tmp_path / "run.images", mm_per_px=8.0, measure=False)
    for png in (tmp_path / "run.images").glob("*.png"):  # the mosaic from memory reads no
        cv2.imwrite(str(png), np.zeros((240, 320, 3), np.uint8))  # PNG: black ones left
    from_memory = build.build(tmp_path / "run.images", mm_per_px=8.0, measure=False,
                              memory=rec.frame)
    assert from_memory.figures["used"] == 5 and not from_memory.skipped
    assert np.array_equal(from_memory.mosaic, from_files.mosaic)
    rec.close()
    assert rec.frame(0) is None
    assert made, "no shared memory was made"
    assert _shared_blocks() & set(made) == set(), "the shared memory outlived the recorder"
