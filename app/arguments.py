"""The types of the options several commands take, each range-checked, so that a bad value
is exit 2 and one line, never a traceback nor a value that means nothing (``--seed -1``,
``--speed 1e308``)."""

from __future__ import annotations

import argparse

MAX_SEED = 2**64 - 1  # the simulated vehicle's random generators take any seed in 0..2**64-1
MAX_SPEED = 1000.0  # mcl vehicle --speed, times wall time: past it no vehicle keeps its clock


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

