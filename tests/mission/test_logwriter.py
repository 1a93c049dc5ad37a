"""A run log that cannot be written stops the run safely (issue 22, deliverable 4): a log
whose header cannot be written (``--log /dev/full``, ``--log /proc/version``) refuses the run
before the start, one line and exit 2; a disk that fills up during the run, or the log's folder
removed, aborts the mission through its net, everything is switched off and confirmed, and the
end record the log cannot take is printed on standard error (its stand-in) with the status the
process exits with (4, ``how: "log failed"``); ``--log /dev/null`` writes nothing beside it.
"""

from __future__ import annotations

import errno
import json
import os
import resource
import shutil
import signal
import subprocess
import time
from pathlib import Path
from typing import Any

import pytest

from mission.logwriter import LogWriter
from petri.execution.player import Record
from petri.execution.runlog import RunLog

from tests.dam_runs import SHORT_SURVEY
from tests.support import BIN, MISSIONS, REPO, budget, stop, subprocess_env, write

DAM = str(MISSIONS / "dam_inspection.mcl")
SLOW = ("MISSION { StartLogs(enable); StartCamera(enable); Wait(60 s); "
        "StartCamera(disable); StartLogs(disable) }")


def mcl_run(tmp_path: Path, *args: str, limit_bytes: int | None = None
            ) -> subprocess.Popen[str]:
    def limited() -> None:  # a disk that fills up: writes past the limit fail with EFBIG
        if limit_bytes is not None:
            signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
            resource.setrlimit(resource.RLIMIT_FSIZE, (limit_bytes, limit_bytes))

    return subprocess.Popen([str(BIN / "mcl"), "run", *args], cwd=REPO, text=True,
                            env=subprocess_env(MCL_STATE_DIR=str(tmp_path / "state")),
                            stdin=subprocess.DEVNULL, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, preexec_fn=limited)


def stand_in(err: str) -> dict[str, Any]:
    """The end record ``mcl run`` printed on standard error."""
    line = next((x for x in err.splitlines() if "its end record: " in x), None)
    assert line is not None, err
    record: dict[str, Any] = json.loads(line.split("its end record: ", 1)[1])
    return record


@pytest.mark.parametrize("target", ["/dev/full", "/proc/version"])
def test_a_log_whose_header_cannot_be_written_refuses_the_run(tmp_path: Path,
                                                             target: str) -> None:
    if not Path(target).exists():
        pytest.skip(f"no {target} here")
    proc = mcl_run(tmp_path, DAM, "--no-images", "--log", target)
    out, err = proc.communicate(timeout=budget(30))
    assert proc.returncode == 2, err
    assert "Traceback" not in err and out == "", (out, err)
    first = err.splitlines()[0]
    assert first.startswith(f"{target}: error: cannot write the run log (") and \
        first.endswith("): the mission never started"), err


def test_a_disk_that_fills_up_aborts_the_run_and_says_its_end(tmp_path: Path) -> None:
    log = tmp_path / "run.jsonl"
    proc = mcl_run(tmp_path, DAM, "--no-images", "--log", str(log), limit_bytes=8000)
    out, err = proc.communicate(timeout=budget(60))
    assert proc.returncode == 4, err
    assert "Traceback" not in err, err
    end = stand_in(err)
    assert end["how"] == "log failed" and end["exit"] == 4, end
    assert "the run log could not be written (File too large)" in end["why"], end
    assert end["switched_off"] and end["confirmed"].startswith("confirmed"), end
    assert "incomplete" in out and "ended STOPPED" in out, out
    assert log.stat().st_size <= 8000


def test_the_log_folder_removed_mid_run_aborts_the_run(tmp_path: Path) -> None:
    folder = tmp_path / "runs"
    log = folder / "run.jsonl"
    mission = write(tmp_path, SLOW)
    proc = mcl_run(tmp_path, str(mission), "--realtime", "--log", str(log))
    try:
        deadline = time.monotonic() + budget(10)
        while time.monotonic() < deadline and not (
                log.exists() and "StartCamera" in log.read_text("utf-8")):
            time.sleep(0.05)
        shutil.rmtree(folder)
        out, err = proc.communicate(timeout=budget(10))
    finally:
        stop(proc)
    assert proc.returncode == 4, err
    end = stand_in(err)
    assert end["how"] == "log failed" and "was removed or replaced during the run" in \
        end["why"], end
    assert end["switched_off"] == ["StartCamera", "StartLogs"], end
    assert end["confirmed"].startswith("confirmed"), end
    assert end["t"] < 30, end  # stopped at once, not at the mission's end


def test_a_log_on_a_device_writes_nothing_beside_it(tmp_path: Path) -> None:
    beside = [Path("/dev/null.svg"), Path("/dev/null.images")]
    before = [p.exists() for p in beside]
    proc = mcl_run(tmp_path, DAM, *SHORT_SURVEY, "--log", "/dev/null")  # camera on, 200 s
    out, err = proc.communicate(timeout=budget(60))
    made = [p for p, was in zip(beside, before, strict=True) if p.exists() and not was]
    for p in made:  # a failing run must not leave them behind
        shutil.rmtree(p) if p.is_dir() else p.unlink()
    assert proc.returncode == 0, err
    assert made == [], made
    assert "trajectory plot: not written (the run log is not a file)" in out, out


# -- the writer itself ----------------------------------------------------------------------
def test_a_failed_write_is_kept_and_asks_to_stop(tmp_path: Path) -> None:
    class Full(RunLog):
        def __call__(self, record: Record) -> None:
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))

    with Full(tmp_path / "run.jsonl", {"mission": "m"}) as log:
        writer = LogWriter(log)
        assert writer.stop() is None
        writer(Record(1.0, "note", {"note": "x"}))
        assert writer.stop() == ("the run log could not be written (No space left on "
                                 "device): the run was stopped")
        writer.end(2.0, "log failed", "why", exit=4)
    assert writer.unwritten == {"t": 2.0, "kind": "end", "how": "log failed", "why": "why",
                                "exit": 4}


def test_a_log_removed_is_noticed_at_the_next_record(tmp_path: Path) -> None:
    with RunLog(tmp_path / "run.jsonl", {"mission": "m"}) as log:
        writer = LogWriter(log)
        writer(Record(1.0, "note", {"note": "x"}))
        assert writer.failure == ""
        (tmp_path / "run.jsonl").unlink()
        writer(Record(2.0, "note", {"note": "y"}))
        assert "was removed or replaced" in writer.failure
        writer.end(3.0, "ok")
    assert writer.unwritten is not None and writer.unwritten["how"] == "ok"
