"""A player's side of its vehicle's modem over Zenoh (docs/FLEET_ZENOH.md, "The modem").

A fleet's vehicle may have a side of the fleet's channels (paper 003's ASV says what its
``fix`` carries; the UUV's navigator fuses every fix it hears): :func:`payload` asks the
vehicle what a message it sends says (``mcl/<v>/modem/payload``; ``{}`` from a vehicle without
a modem, which does not answer), :func:`heard` tells it a message its player was delivered and
waits for its word (``mcl/<v>/modem/heard``, a query too: see there why). The vehicle's side:
vehicle/servers/zenoh_server.py.
"""

from __future__ import annotations

import json
import logging
from typing import Any

import zenoh

from aal.zenoh import keys, payload_text

log = logging.getLogger(__name__)

MODEM_TIMEOUT = 2.0  # wall s: the longest a Send, or a delivery, waits for its vehicle's word


def payload(session: zenoh.Session, vehicle: str, channel: str, message: str, t: float,
            timeout: float = MODEM_TIMEOUT) -> dict[str, Any]:
    """What ``vehicle`` says a message it sends at ``t`` (its clock) carries; ``{}`` when it
    has no modem, does not answer in ``timeout`` wall seconds, or answers what is not a
    JSON object."""
    replies = session.get(f"{keys(vehicle)['modem_payload']}?channel={channel};"
                          f"message={message};t={t!r}", timeout=timeout)
    for reply in replies:
        sample = reply.ok
        if sample is None:  # an error reply
            continue
        try:
            data = json.loads(payload_text(sample))
        except ValueError:
            continue
        if isinstance(data, dict):
            return data
    return {}


def heard(session: zenoh.Session, vehicle: str, channel: str, message: str,
          data: dict[str, Any], t: float, timeout: float = MODEM_TIMEOUT) -> bool:
    """Tell ``vehicle`` that its player was delivered ``message`` on ``channel`` at ``t``
    (its clock), with the message's ``data``, and wait (at most ``timeout`` wall seconds) for
    its word that its stack has heard it: True then; False from a vehicle without a modem
    (which does not answer) or one that did not answer in time.

    A query, not a put: the player acts on the message only once it returns, so the vehicle
    hears the message before any action the player takes on it (the UUV's navigator fuses the
    fix before FollowLine reads its estimate). A put gave no such order: Zenoh runs each
    subscriber's callbacks in a thread of its own, and the vehicle applied an action put after
    the message before the message (tests/vehicle/servers/test_zenoh_server.py)."""
    try:
        text = json.dumps({"channel": channel, "message": message, "data": data, "t": t},
                          allow_nan=False)
    except ValueError as exc:  # a payload that is not plain JSON: not told
        log.warning("modem of %s: %s.%s not told: %s", vehicle, channel, message, exc)
        return False
    told = False
    for reply in session.get(keys(vehicle)["modem_heard"], payload=text, timeout=timeout):
        told = told or reply.ok is not None
    return told
