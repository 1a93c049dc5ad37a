"""What a kind of vehicle supplies (:class:`Kind`), what it builds for a run (a
:class:`mission.vehicle.Vehicle`, named here for the kinds' imports), and how it refuses its
input (:class:`Invalid`). docs/EXTENDING.md, "Add a kind of vehicle"."""

from __future__ import annotations

import argparse
from typing import Any, Protocol, runtime_checkable

from diagnostics import Diagnostic, MclError
from mission.vehicle import Vehicle

__all__ = ["Invalid", "Kind", "Options", "Vehicle", "error_line"]


class Invalid(MclError):
    """Invalid input that is not MCL source (an option, a vehicle file), said on one line that
    starts with the option or file it is about: ``--inject leak@: error: ...``. ``verbatim``:
    the message is that whole line already."""

    def __init__(self, message: str, verbatim: bool = False):
        self.line = message if verbatim else error_line(message)
        super().__init__(Diagnostic("error", message.split("\n")[0]))

    def format(self) -> str:
        return self.line


def error_line(message: str) -> str:
    """``NAME: error: what``, NAME the option or file the message starts with
    (``--inject leak@: ...``, ``v.toml: no such file``, ``--user is for ...``)."""
    first, newline, more = message.partition("\n")
    if ": error:" in first:
        return message
    head, colon, rest = first.partition(": ")
    if colon and (head.startswith("--") or " " not in head):
        return f"{head}: error: {rest}{newline}{more}"
    option, _, rest = first.partition(" ")
    return f"{option}: error: {rest}{newline}{more}"


class Options:
    """The group of one kind's options in ``mcl run --help``; remembers what it adds, so that
    an option of one kind given with another kind is refused."""

    def __init__(self, group: argparse._ArgumentGroup):
        self.group = group
        self.actions: list[argparse.Action] = []

    def add_argument(self, *names: str, **options: Any) -> argparse.Action:
        action = self.group.add_argument(*names, **options)
        self.actions.append(action)
        return action


@runtime_checkable
class Kind(Protocol):
    """One kind of vehicle: a module of ``app/vehicles/`` with these names.

    ``NAME`` what ``--vehicle`` starts with; ``WHERE`` what follows ``NAME:`` ("" if nothing
    does); ``HELP`` a phrase for ``--vehicle``'s help; ``TITLE`` the title of its options' group
    in ``mcl run --help``; ``INJECT`` None if it takes ``--inject FAULT@SECONDS``, else the line
    that refuses it; ``add_options`` adds its options; ``build`` makes the vehicle of a run
    (raising :class:`Invalid` for input it refuses)."""

    NAME: str
    WHERE: str
    HELP: str
    TITLE: str
    INJECT: str | None

    def add_options(self, options: Options) -> None: ...

    def build(self, where: str, args: argparse.Namespace) -> Vehicle: ...
