"""mission/limits.py: the mission time limit, given or derived from the mission's timeouts
(the bound + 10 % + 60 s; 7200 s when they do not bound it), and a bad limit refused."""

from __future__ import annotations

from pathlib import Path

import pytest

from diagnostics import MclError
from mcl.api import Compiled, compile_file
from mission.limits import MARGIN, SLACK, UNBOUNDED, max_time, mission_bound
from tests.support import write


def compiled(tmp_path: Path, text: str) -> Compiled:
    return compile_file(str(write(tmp_path, text)), require_values=True)


def test_a_sequence_of_waits_is_bounded_by_their_sum(tmp_path: Path) -> None:
    m = compiled(tmp_path, "MISSION { Wait(100 s); Wait(2 min) }")
    assert mission_bound(m) == 220.0
    limit, why = max_time(m, None)
    assert limit == pytest.approx(220.0 * (1 + MARGIN) + SLACK) == 302.0
    assert why == "default: its timeouts bound it to 220 s, + 10 % + 60 s"


def test_a_loop_is_not_bounded(tmp_path: Path) -> None:
    m = compiled(tmp_path, "MISSION { WHILE { Wait(1 s) } DO { Wait(1 s) } }")
    assert mission_bound(m) is None
    assert max_time(m, None) == (UNBOUNDED, "default: the mission's timeouts do not bound it, "
                                            "so 7200 s")


def test_a_given_limit_wins_and_a_bad_one_is_refused(tmp_path: Path) -> None:
    m = compiled(tmp_path, "MISSION { Wait(100 s) }")
    assert max_time(m, 30.0) == (30.0, "--max-time")
    for bad in (0.0, -5.0, float("inf"), float("nan")):
        with pytest.raises(MclError, match="must be a positive number of seconds"):
            max_time(m, bad)
