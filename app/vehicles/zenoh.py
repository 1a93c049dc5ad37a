"""``--vehicle zenoh:ENDPOINT``: a vehicle in another process or on another machine, served by
``mcl vehicle --zenoh`` (docs/ZENOH.md, docs/ZENOH_SECURITY.md)."""

from __future__ import annotations

import argparse

from app import zenoh_options
from app.vehicles.kind import Invalid, Options, Vehicle

NAME = "zenoh"
WHERE = "ENDPOINT"
HELP = "a vehicle served by 'mcl vehicle', e.g. zenoh:tcp/127.0.0.1:7447"
TITLE = "Zenoh link (--vehicle zenoh:...)"
INJECT = ("--inject is for the vehicle process: "
          "mcl vehicle --zenoh ENDPOINT --inject FAULT@SECONDS")


def add_options(options: Options) -> None:
    options.add_argument("--scouting", action="store_true",
                         help="also find the vehicle by Zenoh's multicast scouting (off by "
                              "default)")
    zenoh_options.add_arguments(options, "player")


def build(where: str, args: argparse.Namespace) -> Vehicle:
    from aal.zenoh import DEFAULT_ENDPOINT, check_endpoint
    from vehicle_adapters.zenoh_link import ZenohVehicle

    try:
        security = zenoh_options.from_args(args, "player")
    except ValueError as exc:
        raise Invalid(str(exc)) from None
    try:
        endpoint = check_endpoint(where or DEFAULT_ENDPOINT)
    except ValueError as exc:
        raise Invalid(f"--vehicle {args.vehicle}: error: {exc}", verbatim=True) from None
    adapter = ZenohVehicle(endpoint, "auv", security=security, scouting=args.scouting)
    return Vehicle(adapter, declares=adapter, link=adapter, status=adapter,
                   where=f"zenoh:{endpoint}")
