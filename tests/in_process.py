"""``mcl`` run in this process, for the tests of what a command refuses before it does anything.

A refusal (a bad option, one line on standard error, exit 2) is the command's own code, the
same in a subprocess and here; a subprocess costs half a second of CPU to start Python and
import the command, which tests of many bad inputs paid once each. Each command keeps tests
that start it as a real process (tests/support.py's ``cli``), its console script included.
"""

from __future__ import annotations

import contextlib
import io
import subprocess
from pathlib import Path

from app import mcl
from tests.support import REPO


def mcl_in_process(*args: str, cwd: Path = REPO) -> subprocess.CompletedProcess[str]:
    """``mcl ARGS`` by its ``main`` in this process, in ``cwd``: its exit status, standard
    output and standard error, as :func:`subprocess.run` gives them for the console script."""
    out, err = io.StringIO(), io.StringIO()
    with contextlib.chdir(cwd), contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        try:
            code = mcl.main(list(args))
        except SystemExit as exc:  # argparse: an option it cannot parse
            code = exc.code if isinstance(exc.code, int) else 2
    return subprocess.CompletedProcess(["mcl", *args], code, out.getvalue(), err.getvalue())
