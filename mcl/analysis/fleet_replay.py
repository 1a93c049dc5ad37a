"""A fleet's counterexample replayed on the players, and the players' joint states looked up
in the verified graph.

:func:`replay` feeds each vehicle's :class:`~petri.execution.player.Player` its own firings
in the counterexample's order, and carries the channels' messages between them by the
product's rule (in flight; heard by a Receive waiting for it, ignored when none waits, or
lost): a firing the player refuses, a reception of a message not on its way, or a message
ignored while a Receive waits for it, is an error.
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

    def sender(order: Order) -> None:
        message = order.params.get("message")
        flight.update(x for x in fnet.links
                      if x.channel == order.behaviour and x.message == message)

    players = {v: Player(s.net, sender=sender) for v, s in fnet.slices.items()}
    for at, t in enumerate(steps):
        step, ln = fnet.steps[t], fnet.steps[t].link
        if ln is not None and step.kind != "arrive" and ln not in flight:
            raise ReplayError(f"step {at + 1}: {fnet.step_text(t)}: no {ln.message} on its "
                              f"way to {ln.receiver}")
        if step.kind == "vehicle":
            assert step.vehicle is not None
            try:
                players[step.vehicle].fire(step.original, float(at))
            except ValueError as e:
                raise ReplayError(f"step {at + 1}: {e}") from None
            flight.discard(ln) if ln is not None else None
            continue
        assert ln is not None
        if step.kind == "arrive":
            flight.add(ln)
            continue
        if step.kind == "ignore" and any(
                players[ln.receiver].enabled(u)
                for u in players[ln.receiver].rules.waiting.get(ln.event, [])):
            raise ReplayError(f"step {at + 1}: {fnet.step_text(t)}: a Receive waits for it")
        flight.discard(ln)
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
