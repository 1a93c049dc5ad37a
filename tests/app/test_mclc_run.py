"""``mclc``'s console script (app.mclc.run): what main() prints and returns, then the process
ends at once, without freeing its objects (issue 27: about 10 ms of every call)."""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

import pytest

from tests.support import MISSIONS, REPO, budget, subprocess_env

pytestmark = pytest.mark.slow  # whole processes

DAM = str(MISSIONS / "dam_inspection.mcl")
# the command line as the console script is given it; an exit handler that ends by printing
CALL = ("import atexit, sys\n"
        "sys.argv = ['mclc', *{argv!r}]\n"
        "atexit.register(lambda: print('exit handler', file=sys.stderr))\n"
        "from app.mclc import {entry}\n"
        "{call}\n")


def call(entry: str, argv: list[str], tmp_path: Path) -> subprocess.CompletedProcess[str]:
    """A fresh Python running ``main`` (as ``sys.exit(main())``) or ``run`` on ``argv``."""
    code = CALL.format(argv=argv, entry=entry,
                       call="run()" if entry == "run" else "sys.exit(main())")
    return subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          cwd=REPO, env=subprocess_env(MCL_CACHE_DIR=str(tmp_path / "cache")),
                          timeout=budget(60), stdin=subprocess.DEVNULL)


def timeless(text: str) -> str:
    """The output with the seconds a verification took (which differ from run to run) put
    aside."""
    return re.sub(r'"seconds": [0-9.e-]+|\d+\.\d+ s\b', "(seconds)", text)


@pytest.mark.parametrize("argv", [[DAM], [DAM, "--json"], ["missing.mcl"],
                                  [DAM, "--deadline", "1s"]])
def test_the_script_prints_and_exits_as_main_does(argv: list[str], tmp_path: Path) -> None:
    by_main = call("main", argv, tmp_path / "main")
    by_run = call("run", argv, tmp_path / "run")
    assert by_main.stderr.endswith("exit handler\n")  # main's process frees and exits
    assert (by_run.returncode, timeless(by_run.stdout), by_run.stderr) == (
        by_main.returncode, timeless(by_main.stdout),
        by_main.stderr.removesuffix("exit handler\n"))
    assert by_run.stdout or by_run.stderr  # something was said, and all of it arrived


def test_a_call_with_output_files_writes_them_whole(tmp_path: Path) -> None:
    net = tmp_path / "dam.pnml"
    done = call("run", [DAM, "--no-verify", "--pnml", str(net)], tmp_path)
    assert done.returncode == 0, done.stderr
    assert net.read_text("utf-8").rstrip().endswith("</pnml>")


def test_the_call_runs_with_the_collector_seldom_called(tmp_path: Path) -> None:
    code = ("import gc, app.mclc\n"
            "app.mclc.main = lambda: print(gc.get_threshold()) or 3\n"
            "app.mclc.run()\n")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          cwd=REPO, env=subprocess_env(MCL_CACHE_DIR=str(tmp_path)),
                          timeout=budget(60))
    assert (done.returncode, done.stdout) == (3, "(200000, 30, 30)\n")
