"""``--vehicle sim``: the simulated Ictineu in front of a dam wall, in this process, in
simulated time (docs/VEHICLES.md). Its options are ``mcl run``'s own: ``--seed``, ``--inject``,
``--realtime``, ``--no-images``."""

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
    from behaviours import capabilities
    from vehicle.control.stack import IctineuStack, StackConfig, parse_fault
    from vehicle_adapters.inprocess import InProcess

    try:
        faults = [parse_fault(item) for item in args.inject]
    except ValueError as exc:
        raise Invalid(f"--inject {exc}") from None
    stack = IctineuStack(StackConfig(seed=args.seed, faults=faults))
    adapter = InProcess(stack, speed=1.0 if args.realtime else None,
                        declaration=capabilities.simulated("sim (the simulated Ictineu)"))
    return Vehicle(adapter, stack=stack, declares=adapter)
