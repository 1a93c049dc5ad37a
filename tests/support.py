"""Shared helpers: the repository's paths, compiling from text, and running the real CLIs."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
MISSIONS = REPO / "missions"
SHARED = REPO.parent / "shared"
BIN = Path(sys.executable).parent


def cli(name: str, *args: str, timeout: float = 120, cwd: Path | None = None
        ) -> subprocess.CompletedProcess[str]:
    """Run one of the installed console scripts (mclc, mcl) as a real subprocess."""
    exe = BIN / name
    if not exe.exists():
        pytest.fail(f"{exe} is not installed: run 'make test' (it installs the project)")
    env = dict(os.environ, PYTHONDONTWRITEBYTECODE="1")
    return subprocess.run([str(exe), *args], capture_output=True, text=True, timeout=timeout,
                          cwd=cwd or REPO, env=env, stdin=subprocess.DEVNULL)


def write(tmp_path: Path, text: str, name: str = "m.mcl") -> Path:
    path = tmp_path / name
    path.write_text(text, encoding="utf-8")
    return path


# Generic blocks for testing templates, shipped with the package (mcl/tasks/generic.tasks).
GENERIC_TASKS = (REPO / "mcl" / "tasks" / "generic.tasks").read_text("utf-8")
