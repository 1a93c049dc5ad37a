"""``mclc`` starts as a linter does (issue 27): it loads only what the call needs (no
importlib.metadata but for --version, no numpy but for the explicit route), and asks OpenBLAS,
which it never uses, for a single thread."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

from app.blas import one_blas_thread
from tests.support import MISSIONS, REPO, budget, subprocess_env

DAM = str(MISSIONS / "dam_inspection.mcl")
HEAVY = ("numpy", "numpy.ma", "importlib.metadata", "scipy", "networkx")


def python(code: str, tmp_path: Path, **env: str) -> list[str]:
    """The lines a fresh Python prints running ``code`` in the repository."""
    environment = subprocess_env(MCL_CACHE_DIR=str(tmp_path / "cache"), **env)
    environment.pop("OPENBLAS_NUM_THREADS", None)
    environment.update(env)
    proc = subprocess.run([sys.executable, "-c", code], cwd=REPO, env=environment,
                          capture_output=True, text=True, timeout=budget(10))
    assert proc.returncode == 0, proc.stderr
    return proc.stdout.splitlines()


RUN = ("import io, os, sys, contextlib\n"
       "from app.mclc import main\n"
       "with contextlib.redirect_stdout(io.StringIO()):\n"
       "    status = main({argv!r})\n"
       "print(status)\n"
       f"print(sorted(m for m in {HEAVY!r} if m in sys.modules))\n"
       "print(os.environ.get('OPENBLAS_NUM_THREADS'))\n")


def test_compiling_loads_neither_numpy_nor_the_package_metadata(tmp_path: Path) -> None:
    status, loaded, _ = python(RUN.format(argv=[DAM, "--no-verify"]), tmp_path)
    assert (status, loaded) == ("0", "[]")


def test_the_explicit_route_loads_numpy_with_one_blas_thread(tmp_path: Path) -> None:
    large = str(MISSIONS / "every_construct.mcl")  # 26,426 markings: numpy's searches
    status, loaded, threads = python(RUN.format(argv=[large]), tmp_path)
    assert (status, loaded, threads) == ("0", "['numpy']", "1")
    _, _, chosen = python(RUN.format(argv=[large]), tmp_path, OPENBLAS_NUM_THREADS="3")
    assert chosen == "3"  # the user's choice stands


def test_a_small_mission_edited_and_verified_loads_no_numpy(tmp_path: Path) -> None:
    """The dam mission changed since its last verdict (none in the cache): the quick verdict
    (petri/verification/all_hold.py) decides it, as the explicit route would, without numpy."""
    edited = tmp_path / "dam.mcl"
    edited.write_text(Path(DAM).read_text("utf-8").replace("= 1.5 m;", "= 1.6 m;", 1), "utf-8")
    assert edited.read_text("utf-8") != Path(DAM).read_text("utf-8")
    status, loaded, _ = python(RUN.format(argv=[str(edited)]), tmp_path)  # an empty cache
    assert (status, loaded) == ("0", "[]")


def test_the_version_is_looked_up_only_for_version(tmp_path: Path) -> None:
    code = ("import sys\nimport app.mclc, app.mcl\n"
            "print('importlib.metadata' in sys.modules)\n"
            "app.mclc.main(['--version'])\n")
    environment = subprocess_env()
    proc = subprocess.run([sys.executable, "-c", code], cwd=REPO, env=environment,
                          capture_output=True, text=True, timeout=budget(10))
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.splitlines()[0] == "False"
    assert proc.stdout.splitlines()[1].startswith("mclc ")


def test_once_numpy_is_loaded_the_thread_setting_is_left_alone(
        monkeypatch: pytest.MonkeyPatch) -> None:
    import numpy  # noqa: F401  (loaded, as in a test process or a program using mclc's main)

    monkeypatch.delenv("OPENBLAS_NUM_THREADS", raising=False)
    one_blas_thread()
    assert "OPENBLAS_NUM_THREADS" not in os.environ
