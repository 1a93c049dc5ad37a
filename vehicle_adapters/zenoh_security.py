"""Securing the Zenoh link: who may connect, and who may publish actions (AAL.md).

STUB (being built): the interface is fixed, the body is not.

- :class:`Security` holds this side's credentials and, on the vehicle, who may do what.
- :func:`add_arguments` adds the command-line options of one role (``vehicle``, ``player``,
  ``observer``) to an argparse parser; :func:`from_args` reads them back.
- :func:`apply` writes them into a ``zenoh.Config`` (called by ``zenoh_config``).
"""

from __future__ import annotations

import argparse
from dataclasses import dataclass
from typing import Any


@dataclass(frozen=True)
class Security:
    """Nothing set: an open link (the default, as on a bench)."""

    def __bool__(self) -> bool:
        return False


def add_arguments(parser: argparse.ArgumentParser, role: str) -> None:
    """Add the security options of ``role`` (vehicle | player | observer) to ``parser``."""


def from_args(args: argparse.Namespace, role: str) -> Security:
    """The Security the parsed options describe; raises ValueError with a clear message."""
    return Security()


def apply(config: Any, security: Security, role: str) -> None:
    """Write ``security`` into the zenoh.Config ``config`` for ``role``."""
