"""``mclc`` keeps the report of a call whose verdict came from the cache, and prints it again
for a call with the same inputs without compiling anything (app/kept_reports.py); any change
of an input is checked again."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

from tests.support import MISSIONS, REPO, budget, subprocess_env

pytestmark = pytest.mark.slow  # whole processes, three calls each

DAM = MISSIONS / "dam_inspection.mcl"
# a call of mclc's main in a fresh Python: its output, and whether the compiler was loaded
CALL = ("import io, json, sys, contextlib\n"
        "from app.mclc import main\n"
        "out, err = io.StringIO(), io.StringIO()\n"
        "with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):\n"
        "    status = main({argv!r})\n"
        "print(json.dumps([int(status), out.getvalue(), err.getvalue(),\n"
        "                  'mcl.api' in sys.modules]))\n")


def mclc(tmp_path: Path, *argv: str) -> tuple[int, str, str, bool]:
    """(exit status, standard output, standard error, whether it compiled) of one call."""
    proc = subprocess.run([sys.executable, "-c", CALL.format(argv=list(argv))], cwd=REPO,
                          env=subprocess_env(MCL_CACHE_DIR=str(tmp_path / "cache")),
                          capture_output=True, text=True, timeout=budget(30))
    assert proc.returncode == 0, proc.stderr
    status, out, err, compiled = json.loads(proc.stdout.splitlines()[-1])
    return int(status), str(out), str(err), bool(compiled)


def test_the_third_call_prints_the_seconds_report_without_compiling(tmp_path: Path) -> None:
    mission = tmp_path / "dam.mcl"
    mission.write_text(DAM.read_text("utf-8"), "utf-8")
    first = mclc(tmp_path, str(mission))  # verified
    second = mclc(tmp_path, str(mission))  # its verdict from the cache: kept
    third = mclc(tmp_path, str(mission))  # replayed
    assert first[3] and second[3] and not third[3]
    assert third[:3] == second[:3] and third[0] == 0
    assert "the verdict of an earlier call" in third[1]
    assert first[1] != second[1]  # the first verified; the second said its verdict was kept
    as_json = [mclc(tmp_path, "--json", str(mission)) for _ in range(3)]
    assert not as_json[2][3] and as_json[2][:3] == as_json[1][:3]
    assert '"cached": true' in as_json[2][1]


def test_an_edited_input_is_checked_again(tmp_path: Path) -> None:
    mission = tmp_path / "dam.mcl"
    mission.write_text(DAM.read_text("utf-8"), "utf-8")
    params = tmp_path / "p.params"
    params.write_text("d = 2 m\n", "utf-8")
    for _ in range(2):
        kept = mclc(tmp_path, str(mission), "--params", str(params))
    assert not mclc(tmp_path, str(mission), "--params", str(params))[3]  # replayed
    params.write_text("d = 3 m\n", "utf-8")
    assert mclc(tmp_path, str(mission), "--params", str(params))[3]  # a parameter changed
    mission.write_text(DAM.read_text("utf-8").replace("MISSION", "// edited\nMISSION", 1),
                       "utf-8")
    edited = mclc(tmp_path, str(mission), "--params", str(params))
    assert edited[3] and edited[0] == kept[0] == 0
    assert mclc(tmp_path, str(mission), "--params", str(params), "--method", "explicit")[3]


def test_a_call_that_writes_files_or_names_libraries_is_never_kept(tmp_path: Path) -> None:
    mission = tmp_path / "dam.mcl"
    mission.write_text(DAM.read_text("utf-8"), "utf-8")
    dot = str(tmp_path / "net.dot")
    calls = [mclc(tmp_path, str(mission), "--dot", dot) for _ in range(3)]
    assert all(c[3] and c[0] == 0 for c in calls)  # compiled every time
    (tmp_path / "lib.tasks").write_text((REPO / "mcl" / "tasks" / "ictineu.tasks")
                                        .read_text("utf-8"), "utf-8")
    uses = tmp_path / "uses.mcl"
    uses.write_text('USES "lib.tasks";\n' + DAM.read_text("utf-8"), "utf-8")
    calls = [mclc(tmp_path, str(uses)) for _ in range(3)]
    assert all(c[3] and c[0] == 0 for c in calls), calls[0][2]
