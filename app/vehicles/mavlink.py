"""``--vehicle mavlink:URL``: an ArduSub-class vehicle over MAVLink 2, e.g. the one served by
``mcl vehicle --mavlink`` (docs/MAVLINK.md)."""

from __future__ import annotations

import argparse

from app.vehicles.kind import Invalid, Options, Vehicle

NAME = "mavlink"
WHERE = "URL"
HELP = "an ArduSub-class vehicle, e.g. mavlink:udpin:127.0.0.1:14550"
TITLE = "MAVLink link (--vehicle mavlink:...)"
INJECT = ("--inject is for the vehicle process: "
          "mcl vehicle --mavlink URL --inject FAULT@SECONDS")


def add_options(options: Options) -> None:
    options.add_argument("--signing-key", metavar="FILE",
                         help="MAVLink 2 signing: the secret key file (default: "
                              "$MCL_MAVLINK_KEY if set, else unsigned)")
    options.add_argument("--require-signing", action="store_true",
                         help="refuse unsigned or wrongly signed messages from the vehicle")


def build(where: str, args: argparse.Namespace) -> Vehicle:
    from aal.signing import SigningError, load_key
    from vehicle_adapters.mavlink.link import DEFAULT_URL, MavlinkVehicle

    try:
        key = load_key(args.signing_key)
    except SigningError as exc:
        raise Invalid(str(exc)) from None
    adapter = MavlinkVehicle(where or DEFAULT_URL, signing_key=key,
                             require_signing=args.require_signing)
    return Vehicle(adapter, declares=adapter, link=adapter, summary=adapter,
                   where=f"mavlink:{adapter.url}")
