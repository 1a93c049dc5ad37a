"""``--version``: the installed package's version, as both commands print it."""

from __future__ import annotations

from importlib import metadata

DISTRIBUTION = "mcl-auv"  # pyproject.toml's [project] name


def version_text(prog: str) -> str:
    """``mclc 0.1.0 (mcl-auv)``; a tree that is not installed says so instead of failing."""
    try:
        number = metadata.version(DISTRIBUTION)
    except metadata.PackageNotFoundError:
        number = "unknown (the package is not installed: pip install -e .)"
    return f"{prog} {number} ({DISTRIBUTION})"
