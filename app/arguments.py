"""The types of the options several commands take, each range-checked, so that a bad value
is exit 2 and one line, never a traceback nor a value that means nothing (``--seed -1``,
``--speed 1e308``)."""

from __future__ import annotations

import argparse
import os
import re
import sys
from typing import Any, NoReturn

from mission.exits import Exit

MAX_SEED = 2**64 - 1  # the simulated vehicle's random generators take any seed in 0..2**64-1
MAX_SPEED = 1000.0  # mcl vehicle --speed, times wall time: past it no vehicle keeps its clock


class Formatter(argparse.HelpFormatter):
    """argparse's help formatter, the terminal's width found as shutil finds it but without
    importing shutil (with bz2 and lzma, 5 ms of every command's start: argparse makes a
    formatter for each option it adds)."""

    def __init__(self, prog: str, indent_increment: int = 2, max_help_position: int = 24,
                 width: int | None = None) -> None:
        super().__init__(prog, indent_increment, max_help_position,
                         terminal_width() - 2 if width is None else width)


def terminal_width() -> int:
    """The terminal's columns as ``shutil.get_terminal_size().columns`` gives them: $COLUMNS,
    else the size of the terminal of standard output, else 80."""
    try:
        columns = int(os.environ.get("COLUMNS", "0"))
    except ValueError:
        columns = 0
    if columns <= 0:
        try:
            columns = os.get_terminal_size(sys.__stdout__.fileno()).columns  # type: ignore[union-attr]
        except (AttributeError, ValueError, OSError):
            columns = 0
    return columns or 80


class Parser(argparse.ArgumentParser):
    """The command line of every command (mclc, each mcl subcommand, app.pnml_report): an
    ArgumentParser whose refusal is one line, ``PROG: error: MESSAGE``, exit 2 (invalid input), like every
    other refusal, instead of argparse's usage (eight lines for ``mcl run``) above it. A
    message that names no argument (one missing, one not known) gets a one-line hint."""

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        kwargs.setdefault("formatter_class", Formatter)
        super().__init__(*args, **kwargs)

    def error(self, message: str) -> NoReturn:
        line = f"{self.prog}: error: {' '.join(message.split())}\n"
        if not message.startswith("argument "):
            line += f"  hint: '{self.prog} --help' lists what it takes\n"
        self.exit(Exit.INVALID, line)


def seed(text: str) -> int:
    """``--seed``: an integer from 0 to 2**64 - 1."""
    try:
        value = int(text)
    except ValueError:
        value = -1
    if not 0 <= value <= MAX_SEED:
        raise argparse.ArgumentTypeError(f"{text[:30]!r} is not a seed: an integer from 0 "
                                         f"to {MAX_SEED}")
    return value


MEMORY_UNITS = {"": 1, "b": 1, "k": 1 << 10, "kib": 1 << 10, "kb": 1000, "m": 1 << 20,
                "mib": 1 << 20, "mb": 1000**2, "g": 1 << 30, "gib": 1 << 30, "gb": 1000**3,
                "t": 1 << 40, "tib": 1 << 40, "tb": 1000**4}


def memory_size(text: str) -> int:
    """``--max-memory``: a memory size, a number and a unit (B, KiB, MiB, GiB, TiB; KB.. in
    powers of 1000; K, M, G, T as binary), e.g. 512MiB, 1.5GiB; at least 1 MiB."""
    match = re.fullmatch(r"\s*([0-9][0-9_]*(?:\.[0-9]+)?)\s*([A-Za-z]*)\s*", text)
    if match is None or match[2].lower() not in MEMORY_UNITS:
        raise argparse.ArgumentTypeError(f"not a memory size: {text!r} (e.g. 512MiB, 4GiB)")
    value = float(match[1].replace("_", "")) * MEMORY_UNITS[match[2].lower()]
    if not (1 << 20) <= value < 2**63:
        raise argparse.ArgumentTypeError(f"must be at least 1MiB, got {text!r}")
    return int(value)
