"""What a mission runs on: the adapter the player drives, and what else the vehicle has.

:class:`Vehicle` bundles the adapter (:class:`aal.messages.Vehicle`: ``now``, ``send``,
``receive``, ``idle``, a context manager) with the optional features a run uses, each None
when the vehicle has not got it. A kind of ``mcl run --vehicle`` builds one
(``app/vehicles/``); a Python program builds one with :func:`mission.simulated_vehicle`, or
passes a bare adapter to :func:`mission.run_mission`, which looks for the features on it
(:meth:`Vehicle.around`).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Protocol, runtime_checkable

if TYPE_CHECKING:
    from aal.messages import Declaration
    from aal.messages import Vehicle as Adapter
    from vehicle.control.stack import IctineuStack


@runtime_checkable
class Declares(Protocol):
    """Says what the vehicle can do (before connecting, or once connected; None: not known)."""

    def declaration(self) -> Declaration | None: ...


@runtime_checkable
class Link(Protocol):
    """A link to another process that can be lost (``Link.lost``)."""

    @property
    def lost(self) -> bool: ...

    lost_reason: str


@runtime_checkable
class Answers(Protocol):
    """A link that knows whether any vehicle answered since it was opened (a MAVLink
    HEARTBEAT, a Zenoh liveliness token): a link lost while nobody answered is no vehicle."""

    @property
    def answered(self) -> bool: ...


@runtime_checkable
class StatusFeed(Protocol):
    """Takes the mission's status, for ``mcl monitor``; ``run`` names this player's run."""

    run: str

    def publish_status(self, status: dict[str, Any]) -> None: ...


@runtime_checkable
class Summary(Protocol):
    """Sums up, at the end, what went over the link (counts, latencies)."""

    def summary(self) -> dict[str, Any]: ...


@runtime_checkable
class Modem(Protocol):
    """A vehicle's side of a fleet's channels (docs/FLEET_RUN.md): what it says with a message
    it sends, what it does with one it hears (a navigator fuses a fix), and where it is (the
    channel's delay grows with the distance; None: not known)."""

    def payload(self, channel: str, message: str, t: float) -> dict[str, Any]: ...
    def heard(self, channel: str, message: str, data: dict[str, Any], t: float) -> None: ...
    def position(self) -> tuple[float, float, float] | None: ...


@dataclass
class Vehicle:
    """The vehicle of one run: the adapter the player runs on and what else it has."""

    adapter: Adapter  # now, send, receive, idle; a context manager (aal.messages.Vehicle)
    stack: IctineuStack | None = None  # the simulated stack behind it: survey, images, seabed
    declares: Declares | None = None
    link: Link | None = None
    status: StatusFeed | None = None
    summary: Summary | None = None
    where: str = ""  # where the vehicle is reached (a URL, an endpoint), for messages
    modem: Modem | None = None  # its side of a fleet's channels (mission/fleet.py)

    @classmethod
    def around(cls, adapter: Adapter) -> Vehicle:
        """An adapter alone, with the features it has itself (an in-process adapter declares
        what its stack can do; a Zenoh adapter is also a link and a status feed)."""
        return cls(adapter,
                   declares=adapter if isinstance(adapter, Declares) else None,
                   link=adapter if isinstance(adapter, Link) else None,
                   status=adapter if isinstance(adapter, StatusFeed) else None,
                   summary=adapter if isinstance(adapter, Summary) else None)
