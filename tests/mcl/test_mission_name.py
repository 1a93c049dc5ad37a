"""One name for a mission across commands (issue 21: mclc said "(unnamed)" where mcl run said
dam_inspection): :attr:`mcl.api.Compiled.name`, used by mclc's report and mission.run."""

from __future__ import annotations

import subprocess
import sys

from diagnostics import Source
from mcl import tasklib
from mcl.api import compile_source
from tests.support import REPO

GENERIC = tasklib.load(["generic"])


def test_a_named_mission_is_called_by_its_name_and_an_unnamed_one_by_its_file() -> None:
    named = compile_source(Source("dir/x.mcl", "MISSION survey { A() }\n"), library=GENERIC)
    unnamed = compile_source(Source("dir/dam_inspection.mcl", "MISSION { A() }\n"),
                             library=GENERIC)
    assert (named.name, unnamed.name) == ("survey", "dam_inspection")


def test_mclc_names_the_dam_mission_as_mcl_run_does() -> None:
    done = subprocess.run([sys.executable, "-m", "app.mclc", "--no-verify",
                           "missions/dam_inspection.mcl"], cwd=REPO, capture_output=True,
                          text=True, timeout=300, check=False)
    assert "mission dam_inspection:" in done.stdout
