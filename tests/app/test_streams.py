"""A command started without its standard output (``>&-``) or writing into a full one
(``>/dev/full``) ends with no traceback and a clear exit (issue 22, deliverable 4): ``mclc``
and ``mcl check`` give their verdict's status with stdout closed, one line and exit 2 into a
full stdout; ``mcl run`` runs its mission to the end all the same, and its end record says
what became of standard output, with the status the process exits with.
"""

from __future__ import annotations

import json
import os
import subprocess
from pathlib import Path
from typing import Any

import pytest

from app.streams import StdoutLost, lost, lost_line, open_standard_streams, watched_stdout

from tests.dam_runs import SHORT_SURVEY
from tests.support import BIN, MISSIONS, REPO, budget, subprocess_env

DAM = str(MISSIONS / "dam_inspection.mcl")  # mcl run: its short survey (tests/dam_runs.py)
FULL = "/dev/full"


def run(args: list[str], tmp_path: Path, stdout: str) -> tuple[int, str]:
    """One console script (``args[0]``) with standard output ``"closed"`` or a path; its
    exit status and its standard error."""
    err_path = tmp_path / "err.txt"
    with open(err_path, "wb") as err:
        if stdout == "closed":
            proc = subprocess.run([str(BIN / args[0]), *args[1:]], cwd=REPO,
                                  env=subprocess_env(MCL_STATE_DIR=str(tmp_path / "state")),
                                  stdin=subprocess.DEVNULL, stderr=err,
                                  preexec_fn=lambda: os.close(1), timeout=budget(30))
        else:
            with open(stdout, "wb") as out:
                proc = subprocess.run([str(BIN / args[0]), *args[1:]], cwd=REPO,
                                      env=subprocess_env(MCL_STATE_DIR=str(tmp_path / "state")),
                                      stdin=subprocess.DEVNULL, stdout=out, stderr=err,
                                      timeout=budget(30))
    return proc.returncode, err_path.read_text("utf-8", "replace")


def end_record(log: Path) -> dict[str, Any]:
    last: dict[str, Any] = json.loads(log.read_text("utf-8").splitlines()[-1])
    assert last["kind"] == "end", last
    return last


needs_full = pytest.mark.skipif(not Path(FULL).exists(), reason="no /dev/full here")


@pytest.mark.parametrize("command", [["mclc"], ["mcl", "check"]])
def test_a_closed_stdout_gives_the_verdict_without_a_traceback(tmp_path: Path,
                                                               command: list[str]) -> None:
    args = [*command, DAM]
    told, _ = run(args, tmp_path, str(tmp_path / "out.txt"))
    code, err = run(args, tmp_path, "closed")
    assert "Traceback" not in err and "AttributeError" not in err, err
    assert code == told, err  # the verdict, as with stdout open


@needs_full
@pytest.mark.parametrize("command", [["mclc", DAM], ["mcl", "check", DAM]])
def test_a_full_stdout_is_one_line_and_exit_2(tmp_path: Path, command: list[str]) -> None:
    code, err = run(command, tmp_path, FULL)
    assert code == 2, err
    assert "Traceback" not in err, err
    lines = err.strip().splitlines()
    assert len(lines) == 1 and "standard output could not be written (No space left on " \
        "device)" in lines[0], err


@needs_full
def test_replay_into_a_full_stdout_is_one_line_and_exit_2(tmp_path: Path) -> None:
    log = tmp_path / "run.jsonl"
    code, err = run(["mcl", "run", DAM, *SHORT_SURVEY, "--no-images", "--quiet", "--log",
                     str(log)], tmp_path, str(tmp_path / "out.txt"))
    assert code == 0, err
    code, err = run(["mcl", "replay", str(log), DAM], tmp_path, FULL)
    assert code == 2 and "Traceback" not in err, err
    assert err.strip().splitlines() == [
        "mcl replay: error: standard output could not be written (No space left on device): "
        "the output is incomplete"], err


def test_a_run_with_stdout_closed_ends_as_its_end_record_says(tmp_path: Path) -> None:
    # the case: AttributeError on the first line of the timeline, exit 3, the end
    # record saying exit 5 and an error
    log = tmp_path / "run.jsonl"
    code, err = run(["mcl", "run", DAM, *SHORT_SURVEY, "--no-images", "--log", str(log)],
                    tmp_path, "closed")
    assert "Traceback" not in err and "internal error" not in err, err
    last = end_record(log)
    assert last["how"] == "ok" and last["exit"] == code == 0, (last, err)
    assert "standard output was closed (nothing was printed)" in last["why"], last


@needs_full
def test_a_run_into_a_full_stdout_ends_as_its_end_record_says(tmp_path: Path) -> None:
    log = tmp_path / "run.jsonl"
    code, err = run(["mcl", "run", DAM, *SHORT_SURVEY, "--no-images", "--log", str(log)],
                    tmp_path, FULL)
    assert "Traceback" not in err, err
    last = end_record(log)
    assert last["how"] == "ok" and last["exit"] == code == 0, (last, err)
    assert "standard output could not be written during the run (No space left on device" \
        in last["why"], last


# -- the pieces ---------------------------------------------------------------------------
def test_a_failed_write_is_stdout_lost_with_its_reason(capsys: pytest.CaptureFixture[str]
                                                       ) -> None:
    class Full:
        def write(self, text: str) -> int:
            raise OSError(28, "No space left on device")

        def flush(self) -> None:
            pass

    import sys

    real = sys.stdout
    sys.stdout = Full()
    try:
        with pytest.raises(StdoutLost) as caught, watched_stdout():
            print("x")
    finally:
        sys.stdout = real
    assert caught.value.errno == 28
    assert lost_line("mclc", caught.value) == ("mclc: error: standard output could not be "
                                               "written (No space left on device): the "
                                               "output is incomplete")
    assert lost_line("mclc", lost(BrokenPipeError(32, "Broken pipe"))) is None  # | head -1


def test_no_stream_is_reopened_when_all_are_open() -> None:
    assert open_standard_streams() == frozenset()
