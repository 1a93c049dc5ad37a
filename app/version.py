"""``--version``: the installed package's version, as both commands print it."""

from __future__ import annotations

import argparse
from collections.abc import Sequence
from typing import Any

DISTRIBUTION = "mcl-auv"  # pyproject.toml's [project] name


def version_text(prog: str) -> str:
    """``mclc 0.1.0 (mcl-auv)``; a tree that is not installed says so instead of failing."""
    # Lazy for start-up speed: importlib.metadata costs 13 ms of CPU (a fifth of a bare
    # Python's start), and only --version needs it.
    from importlib import metadata

    try:
        number = metadata.version(DISTRIBUTION)
    except metadata.PackageNotFoundError:
        number = "unknown (the package is not installed: pip install -e .)"
    return f"{prog} {number} ({DISTRIBUTION})"


class VersionAction(argparse.Action):
    """``--version``: print :func:`version_text` for the parser's program and exit. Unlike
    argparse's ``action="version"``, the version is looked up only when asked for."""

    def __init__(self, option_strings: Sequence[str], dest: str = argparse.SUPPRESS,
                 default: Any = argparse.SUPPRESS,
                 help: str = "show program's version number and exit"):
        super().__init__(option_strings, dest, nargs=0, default=default, help=help)

    def __call__(self, parser: argparse.ArgumentParser, namespace: argparse.Namespace,
                 values: Any, option_string: str | None = None) -> None:
        print(version_text(parser.prog))
        parser.exit()
