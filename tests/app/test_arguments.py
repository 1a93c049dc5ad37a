"""Argument errors are one line (app/arguments.Parser), for mclc and every mcl subcommand.

argparse printed its usage above its error: eight lines for ``mcl run --max-time x`` (issue
22). Every command's refusal is now ``PROG: error: MESSAGE`` and, when the message names no
argument (one missing, one not known), one ``  hint:`` line; exit 2, as every bad input.
"""

from __future__ import annotations

import contextlib
import io
from collections.abc import Callable

import pytest

import app.pnml_report
from app import arguments, mcl, mclc
from tests.support import cli

Main = Callable[[list[str]], int]
COMMANDS: dict[str, tuple[Main, list[str]]] = {
    "mclc": (mclc.main, []),
    "mcl": (mcl.main, []),
    "mcl run": (mcl.main, ["run"]),
    "mcl vehicle": (mcl.main, ["vehicle"]),
    "mcl monitor": (mcl.main, ["monitor"]),
    "mcl mosaic": (mcl.main, ["mosaic"]),
    "mcl replay": (mcl.main, ["replay"]),
    "mcl check": (mcl.main, ["check"]),  # mclc's options, its refusals named mcl check
    "python -m app.pnml_report": (app.pnml_report.main, []),
}
MISTAKES = {  # what a new user types wrongly, and what the line must say
    "an unknown option": (["x.mcl", "--no-such-option"], "--no-such-option"),
    "an option without its value": (["x.mcl", "--debug", "--seed"], ""),
    "nothing": ([], ""),
}


def refusal(main: Main, argv: list[str]) -> tuple[int, list[str]]:
    err = io.StringIO()
    with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
        try:
            code = main(argv)
        except SystemExit as exc:
            code = exc.code if isinstance(exc.code, int) else 1
    return code, err.getvalue().splitlines()


def assert_one_line(prog: str, code: int, lines: list[str], names: str = "") -> None:
    assert code == 2, (prog, code, lines)
    assert lines and lines[0].startswith(f"{prog}: error: "), (prog, lines)
    assert names in lines[0], (prog, lines)
    assert len(lines) <= 2 and all(line.startswith("  hint: ") for line in lines[1:]), lines
    assert not any(line.startswith("usage:") for line in lines), lines


@pytest.mark.parametrize("prog", sorted(COMMANDS))
@pytest.mark.parametrize("mistake", sorted(MISTAKES))
def test_every_command_refuses_its_arguments_in_one_line(prog: str, mistake: str) -> None:
    main, first = COMMANDS[prog]
    argv, names = MISTAKES[mistake]
    if prog == "mcl" and argv:  # mcl itself takes a subcommand, not a file
        argv = ["no-such-command", *argv[1:]]
        names = "no-such-command"
    if prog == "mcl replay" and argv:  # it takes two files: a missing one is said first
        argv = ["run.jsonl", *argv]
    if prog in ("mcl vehicle", "mcl monitor") and mistake == "nothing":
        pytest.skip(f"{prog} needs no argument: it would start serving or watching")
    code, lines = refusal(main, first + argv)
    assert_one_line(prog, code, lines, names)


def test_a_bad_value_names_the_option_with_no_hint() -> None:
    code, lines = refusal(mcl.main, ["run", "m.mcl", "--max-time", "x"])
    assert_one_line("mcl run", code, lines)
    assert lines == ["mcl run: error: argument --max-time: 'x' is not a positive number of "
                     "seconds"]


def test_a_missing_argument_gets_a_hint_naming_help() -> None:
    code, lines = refusal(mcl.main, ["replay"])
    assert lines == ["mcl replay: error: the following arguments are required: RUN.jsonl, "
                     "MISSION.mcl", "  hint: 'mcl replay --help' lists what it takes"]
    assert code == 2


def test_help_is_still_the_whole_usage() -> None:
    out = io.StringIO()
    with contextlib.redirect_stdout(out), pytest.raises(SystemExit) as caught:
        arguments.Parser(prog="p", description="what p does").parse_args(["--help"])
    assert caught.value.code == 0
    assert out.getvalue().startswith("usage: p [-h]") and "what p does" in out.getvalue()


def test_the_installed_commands_say_it_in_one_line() -> None:
    for argv, prog in ((["mclc", "--max-markings", "0", "m.mcl"], "mclc"),
                       (["mcl", "run", "--seed", "-1", "m.mcl"], "mcl run")):
        proc = cli(*argv)
        assert_one_line(prog, proc.returncode, proc.stderr.splitlines(), proc.stderr[:0])
