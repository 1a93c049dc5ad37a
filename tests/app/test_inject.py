"""``mcl run --inject FAULT@SECONDS`` and ``--vehicle`` as a new user types them: one-line
errors that say what is wrong (exit 2), a "did you mean", and a warning for a fault set after
the mission must have ended (issue 21)."""

from __future__ import annotations

from pathlib import Path

import pytest

from mission.exits import Exit
from tests.in_process import mcl_in_process
from tests.support import MISSIONS, cli

DAM = str(MISSIONS / "dam_inspection.mcl")


@pytest.mark.parametrize("fault, says", [
    ("leak@-4", "-4 s is before the mission starts"),
    ("leak@1e400", "is not a finite number of seconds"),
    ("leak@nan", "is not a finite number of seconds"),
    ("leak@soon", "'soon' is not a number of seconds"),
    ("lek@40", "did you mean leak@40?"),
    ("leak", "expected FAULT@SECONDS"),
])
def test_a_bad_fault_is_one_line_and_exit_2(fault: str, says: str, tmp_path: Path) -> None:
    # in process (tests/in_process.py): the tests below start mcl run for real
    result = mcl_in_process("run", DAM, "--inject", fault, "--log", str(tmp_path / "r.jsonl"))
    assert result.returncode == Exit.INVALID, result.stderr
    assert says in result.stderr
    assert "Traceback" not in result.stderr
    assert len(result.stderr.strip().splitlines()) == 1, result.stderr
    assert not (tmp_path / "r.jsonl").exists()  # refused before anything ran


@pytest.mark.slow
def test_a_misspelt_kind_of_vehicle_gets_the_closest(tmp_path: Path) -> None:
    result = cli("mcl", "run", DAM, "--vehicle", "zenho", "--log", str(tmp_path / "r.jsonl"))
    assert result.returncode == Exit.INVALID
    assert "did you mean zenoh:ENDPOINT?" in result.stderr
    far = cli("mcl", "run", DAM, "--vehicle", "submarine", "--log", str(tmp_path / "r.jsonl"))
    assert far.returncode == Exit.INVALID
    assert "did you mean" not in far.stderr and "unknown kind of vehicle" in far.stderr


# The dam mission on 3 m of the wall (make demo's short survey): the warning is the same as for
# the whole wall, and the run that must end OK after it takes 3 s instead of 20.
SHORT_SURVEY = ["--param", "path=[(0, 1), (0, 4), (0.75, 4), (0.75, 1), (1.5, 1), (1.5, 4), "
                "(2.25, 4), (2.25, 1), (3, 1), (3, 4)]",
                "--param", "recoveryPos=(-5, 1.5, 0.5, 0 deg)"]


@pytest.mark.slow
def test_a_fault_after_the_proved_end_is_warned_of(tmp_path: Path) -> None:
    late = cli("mcl", "run", DAM, *SHORT_SURVEY, "--inject", "leak@99999", "--no-images",
               "--quiet", "--log", str(tmp_path / "late.jsonl"))
    assert late.returncode == Exit.OK, late.stderr
    assert "warning: --inject leak@99999: the mission ends by" in late.stderr
    assert "so the leak never happens" in late.stderr
    early = cli("mcl", "run", DAM, "--inject", "leak@40", "--no-images", "--quiet",
                "--max-time", "30", "--log", str(tmp_path / "early.jsonl"))
    assert "warning: --inject leak@40: after --max-time 30" in early.stderr
