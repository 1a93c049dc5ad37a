"""Access control of a fleet's channels (docs/ZENOH_SECURITY.md, "Fleets"): on the vehicle of a
channel's sender, only its player may put on the channel; the receivers, admitted as readers,
hear it; an observer's put, or the player's put on a channel its vehicle does not send on, is
dropped. Real Zenoh sessions on loopback in this process: the vehicle is a session listening
with the vehicle's configuration (users file, access control), as ``mcl vehicle`` opens it.

A put that must be dropped is followed, on the same link, by a status query the player answers
through the vehicle (the observer's) or by a put that must arrive (the player's): when that
comes back, the vehicle has judged the first.
"""

from __future__ import annotations

import queue
import time
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import pytest

zenoh = pytest.importorskip("zenoh")

from aal.zenoh import close_session, keys, zenoh_config  # noqa: E402
from aal.zenoh_security import Security, access_control, for_role  # noqa: E402
from vehicle_adapters.zenoh_channels import channel_key  # noqa: E402

from tests.support import budget, free_endpoint  # noqa: E402

GUIDE, ABORT = channel_key("mcm", "guide"), channel_key("mcm", "abort")  # asv -> uuv, uuv -> asv
WAIT = budget(1.0)
NEVER = 1.0  # wall s: how long to wait for what must not come
K = keys("asv")


@pytest.fixture
def users(tmp_path: Path) -> Path:
    (tmp_path / "users.txt").write_text("player:pilot\nuuv:listener\noperator:watch\n")
    return tmp_path / "users.txt"


@contextmanager
def opened(config: Any) -> Iterator[Any]:
    session = zenoh.open(config)
    try:
        yield session
    finally:
        close_session(session)


def who(user: str, password: str) -> Security:
    return Security(user=user, password=password)


def wait_matched(publisher: Any) -> None:
    end = time.monotonic() + WAIT
    while not publisher.matching_status.matching:
        assert time.monotonic() < end, "the put would not even be sent"
        time.sleep(0.005)


@contextmanager
def fleet_link(users: Path, channels: tuple[str, ...]
               ) -> Iterator[tuple[Any, Any, Any, queue.Queue[tuple[str, bytes]]]]:
    """The asv's vehicle (access control with ``channels``), its player (a peer), the uuv's
    carrier session (a client of the asv's vehicle, subscribed to the fleet's channels) and an
    operator (a client); yields the player, the operator, the uuv and what the uuv heard."""
    endpoint = free_endpoint()
    vehicle = for_role("vehicle", endpoint, users_file=str(users), channels=channels)
    heard: queue.Queue[tuple[str, bytes]] = queue.Queue()
    with (opened(zenoh_config(endpoint, listen=True, security=vehicle, role="vehicle")),
          opened(zenoh_config(endpoint, connect=True, security=who("player", "pilot"))) as pl,
          opened(zenoh_config(endpoint, "client", connect=True,
                              security=who("uuv", "listener"), role="observer")) as uuv,
          opened(zenoh_config(endpoint, "client", connect=True,
                              security=who("operator", "watch"), role="observer")) as op):
        uuv.declare_subscriber("mcl/fleet/mcm/channel/*", lambda s: heard.put(
            (str(s.key_expr), s.payload.to_bytes())))
        pl.declare_queryable(K["status"], lambda q: q.reply(K["status"], b'{"v": 1}'))
        yield pl, op, uuv, heard


def test_only_the_senders_player_puts_on_its_channel(users: Path) -> None:
    with fleet_link(users, (GUIDE,)) as (player, operator, _, heard):
        intruder = operator.declare_publisher(GUIDE)
        wait_matched(intruder)
        intruder.put(b"from the operator")
        replies = list(operator.get(K["status"], timeout=WAIT))  # the put has been judged
        assert [r.ok.payload.to_bytes() for r in replies if r.ok] == [b'{"v": 1}']
        player.put(ABORT, b"the player on the uuv's channel")
        publisher = player.declare_publisher(GUIDE)
        wait_matched(publisher)
        publisher.put(b"release")
        assert heard.get(timeout=WAIT) == (GUIDE, b"release")
        time.sleep(0.1)
        assert heard.empty(), "a put that access control must drop came through"


@pytest.mark.slow
def test_a_secured_vehicle_without_the_fleet_lets_no_channel_through(users: Path) -> None:
    with fleet_link(users, ()) as (player, _, _, heard):
        player.put(GUIDE, b"release")
        with pytest.raises(queue.Empty):
            heard.get(timeout=NEVER)


def test_the_channel_rule_is_the_players_and_keys_are_checked(users: Path) -> None:
    acl = access_control(for_role("vehicle", "tcp/127.0.0.1:7447", users_file=str(users),
                                  channels=(GUIDE,)))
    player = next(p for p in acl["policies"] if p["id"] == "player")
    rule = next(r for r in acl["rules"] if r["key_exprs"] == [GUIDE])
    assert rule["id"] in player["rules"] and rule["messages"] == ["put"]
    readers = next(p for p in acl["policies"] if p["id"] == "readers")
    assert rule["id"] not in readers["rules"]
    for bad in ("mcl/**", "mcl/fleet/mcm/channel/*", "mcl/asv/aal/action"):
        with pytest.raises(ValueError, match="not a fleet channel"):
            for_role("vehicle", "tcp/127.0.0.1:7447", users_file=str(users), channels=(bad,))
    with pytest.raises(ValueError, match="on the vehicle"):
        for_role("player", "tcp/127.0.0.1:7447", channels=(GUIDE,))
