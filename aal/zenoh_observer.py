"""An observer's session to a vehicle (``mcl monitor``, ``mcl view``, docs/ZENOH_SECURITY.md).

An observer connects to the vehicle's endpoint as a Zenoh client (:func:`aal.zenoh.zenoh_config`,
role ``observer``) and sends nothing. Its session is opened again while the vehicle is not
there yet, a vehicle started after its observer being the usual case. A vehicle that is there
but refuses the session, because of wrong credentials (``--user``/``--password-file`` against
its ``--users``) or TLS certificates it does not trust, looks the same to Zenoh: its open
fails either way. What tells them apart is whether something accepts a TCP connection at the
endpoint (:func:`listens`): when it does and the session is refused :data:`REFUSALS` times in
a row, :func:`observer_session` raises :class:`SessionRefused`, which the commands say on one
line and exit 2, rather than waiting for a vehicle that is there.
"""

from __future__ import annotations

import socket
import threading
import time
from collections.abc import Callable
from typing import TYPE_CHECKING

from diagnostics import MclError

if TYPE_CHECKING:
    import zenoh

    from aal.zenoh_security import Security

REFUSALS = 2  # refusals in a row, by something that accepts TCP at the endpoint, before the
#               observer gives up (one may be a vehicle still starting)
RETRY = 0.5  # wall s between two attempts


class SessionRefused(MclError):
    """Something answers at the endpoint but will not open this observer's session: the
    vehicle refused its credentials (``--user``/``--password-file``, or its TLS certificate),
    or it is not a Zenoh vehicle. ``str()`` is the reason, to follow ``mcl COMMAND: error:``."""

    def __init__(self, endpoint: str) -> None:
        self.endpoint = endpoint
        reason = (f"the vehicle at {endpoint} accepts connections but refused this observer's "
                  "session: check --user and --password-file (or the TLS certificates) "
                  "against the vehicle's --users")
        super().__init__(reason, code="zenoh-refused", text=reason)


def listens(endpoint: str, timeout: float = 1.0) -> bool:
    """Whether something accepts a TCP connection at a ``tcp/`` or ``tls/`` endpoint (False
    for any other protocol: it cannot be told)."""
    proto, _, where = endpoint.partition("/")
    host, _, port = where.split("?")[0].split("#")[0].rpartition(":")
    if proto not in ("tcp", "tls") or not port.isdigit():
        return False
    try:
        with socket.create_connection((host.strip("[]"), int(port)), timeout=timeout):
            return True
    except OSError:
        return False


def observer_session(endpoint: str, security: Security | None, stop: threading.Event, *,
                     timeout: float | None = None, scouting: bool = False,
                     waiting: Callable[[str], None] | None = None) -> zenoh.Session | None:
    """An observer's client session to the vehicle at ``endpoint``, opened again every
    :data:`RETRY` seconds while the vehicle is not there; None once ``stop`` is set or
    ``timeout`` wall seconds have passed. ``waiting(why)`` is called once, the first time
    nothing listens at the endpoint (``why``: Zenoh's reason). :class:`SessionRefused` when
    something listens there but refuses the session :data:`REFUSALS` times in a row.

    Each attempt returns before this does (Zenoh's open is bounded by
    :data:`aal.zenoh.CLIENT_CONNECT_MS`): called on a thread, it leaves none inside Zenoh."""
    import zenoh  # lazy: for start-up speed (the commands import this before knowing they watch)

    from aal.zenoh import zenoh_config, zenoh_error

    deadline = time.monotonic() + timeout if timeout else None
    refused = 0
    while not stop.is_set():
        try:
            return zenoh.open(zenoh_config(endpoint, "client", connect=True, security=security,
                                           role="observer", scouting=scouting))
        except zenoh.ZError as exc:
            refused = refused + 1 if listens(endpoint) else 0
            if refused >= REFUSALS:
                raise SessionRefused(endpoint) from None
            if not refused and waiting is not None:
                waiting(zenoh_error(exc))
                waiting = None
        if deadline is not None and time.monotonic() >= deadline:
            return None
        stop.wait(RETRY)
    return None
