"""``--vehicle sim``: the simulated Ictineu in front of a dam wall, in this process, in
simulated time (docs/VEHICLES.md), as :func:`mission.simulated_vehicle` builds it. Its options
are ``mcl run``'s own: ``--seed``, ``--inject``, ``--realtime``, ``--no-images``."""

from __future__ import annotations

import argparse

from app.vehicles.kind import Invalid, Options, Vehicle

NAME = "sim"
WHERE = ""
HELP = "default: the simulated Ictineu in front of a dam wall"
TITLE = "simulated vehicle (--vehicle sim)"
INJECT = None  # it takes --inject FAULT@SECONDS


def add_options(options: Options) -> None:
    """None of its own: --seed, --inject, --realtime and --no-images are mcl run's."""


def build(where: str, args: argparse.Namespace) -> Vehicle:
    from vehicle.control.stack import parse_fault

    from mission.simulated import simulated_vehicle

    try:
        faults = [parse_fault(item) for item in args.inject]
    except ValueError as exc:
        raise Invalid(f"--inject {exc}") from None
    return simulated_vehicle(seed=args.seed, faults=faults, realtime=args.realtime)
