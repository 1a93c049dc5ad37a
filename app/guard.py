"""How ``mcl run`` and ``mcl replay`` end on what they did not expect: invalid input is one
line, Ctrl-C is a signal, a bug of ours is said with a hint (a traceback with ``--debug``);
their exit statuses: docs/EXIT.md. A closed standard output is the dispatcher's
(``app/mcl.py``)."""

from __future__ import annotations

import signal
import sys
import traceback
from collections.abc import Callable

from diagnostics import MclError
from mission.exits import Exit, signalled


def guarded(command: str, debug: bool, body: Callable[[], int]) -> int:
    """``body()``'s exit status, or the status of what stopped it."""
    try:
        return body()
    except KeyboardInterrupt:  # Ctrl-C before the mission started (or after it ended)
        print(f"mcl {command}: interrupted", file=sys.stderr)
        return signalled(signal.SIGINT)
    except MclError as exc:  # OutputError among them: its format() is its one line and hint
        print(exc.format(), file=sys.stderr)
        return Exit.INVALID
    except BrokenPipeError:
        raise
    except Exception as exc:  # a bug of ours: say so plainly
        if debug:
            traceback.print_exc()
        print(f"mcl {command}: internal error: {type(exc).__name__}: {exc}\n"
              "  hint: this is a bug in mcl; rerun with --debug and report it", file=sys.stderr)
        return Exit.INTERNAL
