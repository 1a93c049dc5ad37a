"""The exit statuses of every command, in one table (docs/EXIT.md says what each means for
each command).

One number, one meaning, whichever command returns it: ``mclc``, ``mcl check``, ``mcl run``,
``mcl replay``, ``mcl vehicle``, ``mcl monitor``, ``mcl mosaic`` and ``python -m
app.pnml_report`` all take their statuses from :class:`Exit`. The table lives here, beside
:func:`mission.run_mission`, because a run's log records the status its run ends with (the end
record's ``exit``); the commands in ``app/`` import it from here.
"""

from __future__ import annotations

from enum import IntEnum

SIGNAL_BASE = 128  # a command stopped by signal N exits 128 + N (130 SIGINT, 143 SIGTERM)


class Exit(IntEnum):
    """What a command's exit status says, the same for every command."""

    OK = 0  # done, and all is well: verified, the mission ended ok, the log conforms
    FAILED = 1  # done, and the answer is no: a property fails, the mission ended fail, the
    #             mission is not verified, the log does not conform, the vehicle was lost
    INVALID = 2  # invalid input: an option, a file, a mission the vehicle cannot run
    INTERNAL = 3  # an internal error: a bug in mcl
    UNDECIDED = 4  # no verdict: a property could not be decided, the mission was stopped
    #                before its end (the time limit, stuck, a loop that spun at one instant),
    #                --timeout ran out first
    VEHICLE = 5  # the vehicle or its adapter failed: the run was stopped by its error
    NO_VEHICLE = 6  # no vehicle answered while connecting: the mission never started,
    #                 nothing was sent


# mclc's statuses from best to worst: with several files, it exits with the worst
SEVERITY = [Exit.OK, Exit.UNDECIDED, Exit.FAILED, Exit.INVALID, Exit.INTERNAL]


def signalled(signum: int) -> int:
    """The exit status of a command stopped by signal ``signum``: 128 + N."""
    return SIGNAL_BASE + int(signum)


RUN_STATUS = {  # how the runner ended a run (petri.execution.runner.Outcome) -> its exit
    "ok": Exit.OK, "fail": Exit.FAILED, "timeout": Exit.UNDECIDED, "stuck": Exit.UNDECIDED,
    "stopped": Exit.UNDECIDED, "error": Exit.VEHICLE, "zeno": Exit.UNDECIDED,
}


def run_exit(status: str, signum: int | None = None) -> int:
    """The exit status of a run that ended with ``status``; a run stopped by a signal exits
    128 + N."""
    if status == "stopped" and signum is not None:
        return signalled(signum)
    return RUN_STATUS.get(status, Exit.FAILED)
