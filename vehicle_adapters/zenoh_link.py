"""The Zenoh adapter (docs/AAL.md): the player on one side of a Zenoh link, the vehicle on the
other.

The key layout and configuration both ends share are in :mod:`aal.zenoh`.

Restarts: a vehicle takes actions only from the run whose token it saw last (an action of
another run, or a ``seq`` at or below the last one taken, is stale: counted and dropped), and
switches every behaviour off when a new run appears, so nothing of a previous mission is left
enabled. A player whose vehicle went away (``Link.lost``) sends nothing more on that link: the
vehicle that comes back in its place starts with every behaviour off and is sent nothing old.

The player-side adapter, :class:`ZenohVehicle`, follows the vehicle's clock: ``now()`` is the
last vehicle time received, advanced by wall time x speed since (bounded, so a stalled vehicle
does not run the player's clock far ahead). When the vehicle's liveliness token goes away,
or never appears within ``connect_timeout`` wall seconds, it delivers one synthetic
``Link.lost`` event; from then on its clock runs on wall time x speed so that the player's
timers and time limits still end the run.
"""

from __future__ import annotations

import dataclasses
import json
import logging
import threading
import time
from typing import Any

import zenoh

from aal.messages import ActionMessage, Declaration, EventMessage, InvalidMessage
from aal.zenoh import (
    DEFAULT_ENDPOINT,
    LEASE_MS,
    MAX_EXTRAPOLATION,
    close_session,
    keys,
    payload_text,
    zenoh_config,
)
from aal.zenoh_security import Security

from vehicle_adapters.link import MAX_POLL, RemoteVehicle

log = logging.getLogger(__name__)


class ZenohVehicle(RemoteVehicle):
    """The player's adapter to a vehicle stack reached over Zenoh (the Vehicle protocol).

    ``with ZenohVehicle("tcp/127.0.0.1:7447", "auv") as vehicle: run(player, vehicle, ...)``.
    Entering opens the session, declares the player's liveliness token, the action publisher,
    the event, clock and behaviour-telemetry subscribers and the vehicle's liveliness watch,
    and waits (at most ``connect_timeout`` wall seconds) for the vehicle's token, its clock and
    its word that it takes this run's actions (its telemetry names this run: a vehicle whose
    access control refuses us never does). It does not raise if the vehicle is absent or
    refuses us: the run then gets ``Link.lost`` saying why.
    """

    def __init__(self, endpoint: str = DEFAULT_ENDPOINT, vehicle: str = "auv", *,
                 connect_timeout: float = 5.0, lease_ms: int = LEASE_MS,
                 max_poll: float = MAX_POLL, config: zenoh.Config | None = None,
                 security: Security | None = None, scouting: bool = False):
        super().__init__(max_poll=max_poll, max_extrapolation=MAX_EXTRAPOLATION)
        self.endpoint = endpoint
        self.name = vehicle
        self.keys = keys(vehicle)
        self.connect_timeout = connect_timeout
        self._config = config or zenoh_config(endpoint, connect=True, lease_ms=lease_ms,
                                              security=security, role="player",
                                              scouting=scouting)
        self._alive = threading.Event()  # the vehicle's token is present
        self._answered = threading.Event()  # the vehicle's token has been seen once
        self._clocked = threading.Event()  # a clock message has arrived
        self._taken = threading.Event()  # the vehicle's telemetry names this run
        self.dropped = 0  # invalid events received and dropped
        self.received = 0  # valid events received
        self.sent = 0
        self.session: zenoh.Session | None = None
        self.run = ""  # this run's id: the session's Zenoh id
        self._declared: list[Any] = []
        self._status: bytes | None = None  # the latest mission status (JSON)
        self._declaration: Declaration | None = None
        self._asked = False
        self._active: list[str] | None = None  # the vehicle's behaviours on, per telemetry
        self._active_t = -1.0  # the vehicle time of that telemetry
        self._progress: dict[str, Any] = {}  # the behaviours' progress, per telemetry
        self._pose: tuple[float, float, float, float, float] | None = None  # the navigator's
        self._sent_t = 0.0  # vehicle time when the last action was sent

    @property
    def answered(self) -> bool:
        """Has the vehicle answered since the session opened (its liveliness token)?"""
        return self._answered.is_set()

    # -- context manager ----------------------------------------------------------------------
    def __enter__(self) -> ZenohVehicle:
        self.session = zenoh.open(self._config)
        s = self.session
        self.run = str(s.zid())
        try:
            k = self.keys
            self._status_publisher = s.declare_publisher(
                k["status"], congestion_control=zenoh.CongestionControl.BLOCK)
            self._publisher = s.declare_publisher(
                k["action"], congestion_control=zenoh.CongestionControl.BLOCK,
                priority=zenoh.Priority.INTERACTIVE_HIGH, express=True)
            self._declared += [
                self._publisher, self._status_publisher,
                s.declare_queryable(k["status"], self._on_status_query),
                s.declare_subscriber(k["event"], self._on_event),
                s.declare_subscriber(k["clock"], self._on_clock),
                s.declare_subscriber(f"{k['telemetry']}/behaviours", self._on_behaviours),
                s.declare_subscriber(f"{k['telemetry']}/navigator", self._on_navigator),
                s.liveliness().declare_subscriber(k["alive_vehicle"], self._on_liveliness,
                                                  history=True),
                s.liveliness().declare_token(f"{k['alive_player']}/{self.run}"),
            ]
            self._wait_for_vehicle()
        except BaseException:
            self.__exit__()
            raise
        return self

    def _wait_for_vehicle(self) -> None:
        """Bounded by ``connect_timeout``: the vehicle's token, its clock, its taking this run
        (else ``Link.lost``), and the action publisher matched so that no action is lost."""
        k, deadline = self.keys, time.monotonic() + self.connect_timeout
        if not self._alive.wait(self.connect_timeout):
            self.link_lost(f"no vehicle answered at zenoh:{self.endpoint} within "
                            f"{self.connect_timeout:g} s (no vehicle token on "
                            f"{k['alive_vehicle']})")
            return
        self._clocked.wait(max(0.0, deadline - time.monotonic()))
        if not self._taken.wait(max(0.0, deadline - time.monotonic())):
            self.link_lost(f"the vehicle does not take this run's actions within "
                           f"{self.connect_timeout:g} s: are we its player? (with access "
                           "control: --user / --tls-cert must be the vehicle's --player-user "
                           "/ --player-cn)")
            return
        while not self._publisher.matching_status and time.monotonic() < deadline:
            time.sleep(0.002)

    def __exit__(self, *exc: object) -> None:
        for entity in reversed(self._declared):
            try:
                entity.undeclare()
            except Exception:  # already gone with the session
                pass
        self._declared.clear()
        if self.session is not None:
            close_session(self.session)
            self.session = None

    # -- Zenoh callbacks (Zenoh's threads) --------------------------------------------------------
    def _on_event(self, sample: zenoh.Sample) -> None:
        try:
            event = EventMessage.from_json(payload_text(sample))
        except InvalidMessage as exc:
            with self.lock:
                self.dropped += 1
            log.warning("player dropped an invalid event on %s: %s", sample.key_expr, exc)
            return
        with self.lock:
            self.received += 1
            if event.t > self.vehicle_time_locked():  # the event is news of the clock too
                self.set_clock_locked(event.t, running=self.clock_running)
        self.deliver(event)

    def _on_clock(self, sample: zenoh.Sample) -> None:
        try:
            d = json.loads(payload_text(sample))
            t, speed, running = float(d["t"]), float(d["speed"]), bool(d["running"])
            if not (t >= 0 and speed > 0):
                raise ValueError("bad clock")
        except (ValueError, KeyError, TypeError) as exc:
            log.warning("player ignored an invalid clock message: %s", exc)
            return
        with self.lock:
            if not self.lost:
                self.set_clock_locked(t, speed, running)
        self._clocked.set()

    def _on_behaviours(self, sample: zenoh.Sample) -> None:
        """The vehicle says whose actions it takes: this run's (taken), or, once taken,
        another's — a second player took the vehicle, whose events are not ours any more."""
        try:
            d = json.loads(payload_text(sample))
            run = d.get("run")
        except (ValueError, AttributeError):
            return
        if run == self.run and isinstance(d.get("active"), list):
            with self.lock:
                self._active = [str(b) for b in d["active"]]
                self._active_t = float(d.get("t", 0.0))
                if isinstance(d.get("progress"), dict):
                    self._progress = d["progress"]
        if run == self.run:
            self._taken.set()
        elif self._taken.is_set() and run:
            self.link_lost(f"another player (run {run}) took the vehicle")

    def _on_navigator(self, sample: zenoh.Sample) -> None:
        try:
            d = json.loads(payload_text(sample))
            pose = (float(d["t"]), float(d["x"]), float(d["y"]), float(d["z"]),
                    float(d["yaw"]))
        except (ValueError, TypeError, KeyError, AttributeError):
            return
        with self.lock:
            self._pose = pose

    def pose(self) -> tuple[float, float, float, float, float] | None:
        """The vehicle's navigator estimate as its telemetry last said it: ``(t, x, y, z,
        yaw)``, t on its clock; None before the first (``mcl run --view`` draws its track)."""
        with self.lock:
            return self._pose

    def progress(self) -> dict[str, Any]:
        """Each active behaviour's progress, as the vehicle's telemetry last said it
        (behaviours/base.py, :meth:`Behaviour.progress_report`)."""
        with self.lock:
            return dict(self._progress)

    def _on_status_query(self, query: zenoh.Query) -> None:
        status = self._status
        if status is not None:
            query.reply(self.keys["status"], status)

    def publish_status(self, status: dict[str, Any]) -> None:
        """Publish the mission's status (and keep it for the queryable); never raises."""
        self._status = json.dumps(status, separators=(",", ":")).encode()
        if self.session is None:
            return
        try:
            self._status_publisher.put(self._status)
        except zenoh.ZError as exc:  # a status lost is not worth ending a mission for
            log.warning("mission status not published: %s", exc)

    def _on_liveliness(self, sample: zenoh.Sample) -> None:
        if sample.kind == zenoh.SampleKind.PUT:
            self._alive.set()
            self._answered.set()
        else:
            self._alive.clear()
            self.link_lost(f"the vehicle's token {sample.key_expr} went away")

    # -- the Vehicle protocol ---------------------------------------------------------------------
    def send(self, action: ActionMessage) -> None:
        if self.session is None:
            raise RuntimeError("ZenohVehicle used outside its 'with' block")
        if self.lost:
            log.warning("link lost: action %s %s not sent", action.kind, action.behaviour)
            return
        self._publisher.put(dataclasses.replace(action, run=self.run).to_json())
        self.sent += 1
        with self.lock:
            self._sent_t = self.vehicle_time_locked()

    def declaration(self) -> Declaration | None:
        """What the vehicle says it can do (asked once, at most ``connect_timeout`` s; None
        before connecting, after ``Link.lost``, or if it does not say)."""
        if self.session is None or self.lost:
            return None
        if not self._asked:
            self._asked = True
            try:
                for reply in self.session.get(self.keys["capabilities"],
                                              timeout=self.connect_timeout):
                    if reply.ok is None:
                        continue
                    d = json.loads(reply.ok.payload.to_bytes())
                    self._declaration = Declaration(
                        str(d["vehicle"]), f"{d['source']} (said by {self.keys['capabilities']})",
                        str(d["text"]))
                    break
            except (zenoh.ZError, ValueError, KeyError, TypeError) as exc:
                log.warning("the vehicle's capabilities could not be read: %s", exc)
        return self._declaration

    def confirm_off(self, names: list[str], timeout: float) -> str:
        """Wait (at most ``timeout`` wall s) for the vehicle's telemetry, sent after the last
        action, to show no behaviour on."""
        if self.lost:
            return f"not confirmed: the link is lost ({self.lost_reason})"
        end = time.monotonic() + timeout
        while True:
            with self.lock:
                active, fresh = self._active, self._active_t >= self._sent_t
            if fresh and active == []:
                return "confirmed by the vehicle's telemetry: no behaviour on"
            if time.monotonic() >= end:
                break
            time.sleep(0.02)
        if not fresh or active is None:
            return f"NOT confirmed: no telemetry from the vehicle within {timeout:g} s"
        return f"NOT confirmed: the vehicle still reports {', '.join(active)} on"
