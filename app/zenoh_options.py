"""The Zenoh link's security options on the command line (``mcl vehicle --zenoh``, ``mcl run
--vehicle zenoh:...``, ``mcl monitor``): :func:`add_arguments` adds one role's options,
:func:`from_args` reads them back into an :class:`aal.zenoh_security.Security` (every mistake
a ValueError whose message names the option). docs/ZENOH_SECURITY.md."""

from __future__ import annotations

import argparse
from typing import Any, Protocol

from aal.zenoh_security import DEFAULT_PLAYER, PASSWORD_ENV, Security, for_role


class Container(Protocol):
    """An argparse parser or argument group (or anything with their ``add_argument``)."""

    def add_argument(self, *names: str, **options: Any) -> argparse.Action: ...


def add_arguments(parser: Container, role: str) -> None:
    """Add the security options of ``role`` (vehicle | player | observer) to ``parser``."""
    if role == "vehicle":
        parser.add_argument("--users", metavar="FILE",
                            help="accept only these users: one 'user:password' a line "
                                 "(enables access control)")
        parser.add_argument("--player-user", default=DEFAULT_PLAYER, metavar="NAME",
                            help="the user allowed to put actions; every other user in "
                                 f"--users only reads (default {DEFAULT_PLAYER})")
        parser.add_argument("--player-cn", default=DEFAULT_PLAYER, metavar="NAME",
                            help="with TLS: the certificate common name allowed to put "
                                 f"actions (default {DEFAULT_PLAYER})")
    else:
        parser.add_argument("--user", metavar="NAME",
                            help="authenticate to the vehicle as NAME (password from "
                                 f"--password-file or ${PASSWORD_ENV})")
        parser.add_argument("--password-file", metavar="FILE",
                            help="the password of --user, on the file's first line")
    parser.add_argument("--tls-ca", metavar="FILE",
                        help="mutual TLS (tls/HOST:PORT endpoints): the CA certificate (PEM)")
    parser.add_argument("--tls-cert", metavar="FILE",
                        help="mutual TLS: this side's certificate (PEM), signed by --tls-ca")
    parser.add_argument("--tls-key", metavar="FILE",
                        help="mutual TLS: this side's private key (PEM)")


def from_args(args: argparse.Namespace, role: str) -> Security:
    """The Security the parsed options describe; raises ValueError with a clear message."""
    def given(name: str) -> str | None:
        value = getattr(args, name, None)
        return None if value is None else str(value)

    return for_role(role, endpoint(args), user=given("user"),
                    password_file=given("password_file"), users_file=given("users"),
                    player_user=given("player_user"), player_cn=given("player_cn"),
                    tls_ca=given("tls_ca"), tls_cert=given("tls_cert"),
                    tls_key=given("tls_key"))


def endpoint(args: argparse.Namespace) -> str:
    """The Zenoh endpoint the command uses (``--zenoh`` or ``--vehicle zenoh:ENDPOINT``)."""
    from aal.zenoh import DEFAULT_ENDPOINT

    chosen = getattr(args, "zenoh", None)
    vehicle = getattr(args, "vehicle", None)
    if not chosen and isinstance(vehicle, str) and vehicle.startswith("zenoh:"):
        chosen = vehicle.partition(":")[2]
    return str(chosen or DEFAULT_ENDPOINT)
