"""app/blas.py: the commands ask OpenBLAS for one thread before numpy loads (real processes;
the threads counted are the process's own, in /proc). mclc's own use: tests/app/test_mclc.py."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

from tests.support import REPO, budget, subprocess_env

ASKED = "import os, sys\nfrom app.blas import one_blas_thread\none_blas_thread()\n"
THREADS = ("import numpy, scipy.sparse.linalg\n"
           "print(len(os.listdir('/proc/self/task')), os.environ.get('OPENBLAS_NUM_THREADS'))\n")


def python(code: str) -> str:
    """What a fresh Python prints running ``code``, with no thread count chosen."""
    environment = subprocess_env()
    environment.pop("OPENBLAS_NUM_THREADS", None)
    proc = subprocess.run([sys.executable, "-c", code], cwd=REPO, env=environment,
                          capture_output=True, text=True, timeout=budget(20))
    assert proc.returncode == 0, proc.stderr
    return proc.stdout.strip()


@pytest.mark.skipif(not Path("/proc/self/task").is_dir(), reason="counts threads in /proc")
def test_numpy_and_scipy_load_with_no_thread_of_their_own() -> None:
    assert python(ASKED + THREADS) == "1 1"  # the main thread alone, and the choice told


def test_mcl_asks_before_its_command_runs(tmp_path: Path) -> None:
    """``mcl`` itself (any subcommand): the processes a run starts, the camera's worker
    among them, inherit the choice."""
    mission = tmp_path / "m.mcl"
    mission.write_text("MISSION m\n  TASK Hover 1\nEND\n")
    code = ("import os, sys\nfrom app.mcl import main\n"
            f"main(['fmt', '--check', {str(mission)!r}])\n"
            "print(os.environ.get('OPENBLAS_NUM_THREADS'))\n")
    assert python(code).splitlines()[-1] == "1"
