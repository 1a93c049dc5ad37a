"""A fleet's counterexample replayed on the players, and the players' joint states looked up
in the verified graph.

:func:`replay` feeds each vehicle's :class:`~petri.execution.player.Player` its own firings
in the counterexample's order, and carries the channels' messages between them by the
product's rule (in flight, delivered to a mailbox, lost; a reception takes the mailbox's
message): a firing the player refuses, or a reception with an empty mailbox, is an error.
:func:`visited` says whether a joint marking of the players is one the explicit route saw.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np

from petri.execution.player import Order, Player
from petri.verification.reachability import StateSpace

from mcl.analysis.fleet import FleetNet, Link


class ReplayError(ValueError):
    """A counterexample that the players (or the channels' rule) cannot follow."""


def replay(fnet: FleetNet, steps: Sequence[int]) -> dict[str, Player]:
    """Fire ``steps`` (product transitions) on one player per vehicle; the players, at the
    end. What a player sends (its ``sender``) goes in flight to the channel's receivers.
    Raises :class:`ReplayError` where a firing cannot happen."""
    flight: set[Link] = set()
    mailbox: set[Link] = set()

    def sender(order: Order) -> None:
        message = order.params.get("message")
        flight.update(x for x in fnet.links
                      if x.channel == order.behaviour and x.message == message)

    players = {v: Player(s.net, sender=sender) for v, s in fnet.slices.items()}
    for at, t in enumerate(steps):
        step = fnet.steps[t]
        ln = step.link
        if step.kind == "vehicle":
            assert step.vehicle is not None
            if ln is not None and ln not in mailbox:
                raise ReplayError(f"step {at + 1}: {fnet.step_text(t)}: no {ln.message} "
                                  "in the mailbox")
            try:
                players[step.vehicle].fire(step.original, float(at))
            except ValueError as e:
                raise ReplayError(f"step {at + 1}: {e}") from None
            mailbox.discard(ln) if ln is not None else None
            continue
        assert ln is not None
        if step.kind == "arrive":
            mailbox.add(ln)
            continue
        if ln not in flight:
            raise ReplayError(f"step {at + 1}: {fnet.step_text(t)}: nothing in flight")
        flight.discard(ln)
        if step.kind == "deliver":
            mailbox.add(ln)
    return players


def visited(space: StateSpace, fnet: FleetNet, markings: Mapping[str, Sequence[int]]) -> bool:
    """Whether the explored product holds a joint marking whose vehicles' parts are
    ``markings`` (vehicle -> its player's marking; vehicles left out and the channels'
    places may be anything)."""
    rows = np.ones(space.n_markings, bool)
    for v, marking in markings.items():
        s = fnet.slices[v]
        want = np.asarray(marking, dtype=space.markings.dtype)
        rows &= (space.markings[:, s.first:s.first + len(s.net.places)] == want).all(axis=1)
    return bool(rows.any())
