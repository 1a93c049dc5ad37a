"""The vehicle side of the Zenoh link: the simulated Ictineu stack served over Zenoh.

    mcl vehicle --zenoh tcp/127.0.0.1:7447 [--name auv] [--speed 10] [--seed 1]
                [--inject leak@600] [--player-timeout 3]

(its command line: ``app/vehicle.py``; here :func:`serve` and :class:`VehicleServer`). It listens on the endpoint in peer mode
(multicast scouting off, see :func:`aal.zenoh.zenoh_config`), declares the
liveliness token ``mcl/<v>/alive/vehicle``, takes actions from ``mcl/<v>/aal/action``
(validated; an invalid one is logged and dropped), publishes the stack's events on
``mcl/<v>/aal/event``, its clock on ``mcl/<v>/telemetry/clock`` and telemetry (navigator
estimate, wall tracker, behaviour states) on ``mcl/<v>/telemetry/{navigator,wall,behaviours}``.

Time: the simulated clock starts when a player's liveliness token first appears (so that a
mission starts from the stack's initial state, as in process), then runs at ``speed`` times
wall time, one stack tick (``DT``) at a time, paced with ``time.monotonic``; actions that have
arrived are applied between ticks. If the machine cannot keep up, the simulated clock falls
behind wall time x speed (the player follows the published clock, not its own guess).

Link health: when the player's token has been gone for ``player_timeout`` **wall** seconds
(link health is about the real link, not the simulation's speed), the vehicle disables every
active behaviour and enables Surface, its own safe action. A player that comes back re-arms it.
A player that leaves after its mission ended is not lost: the vehicle reads the mission status
the player publishes (``mcl/<v>/mission/status``), and once that status says the current run's
mission ended (ok or fail), the player's token going away is its goodbye — logged, and no
failsafe.

Restarts: players announce themselves with ``mcl/<v>/alive/player/<run>``. The vehicle takes
actions from the latest run only; an action of another run, or one whose ``seq`` is not above
the last taken from its run, is stale and dropped (counted in telemetry ``stale``); an action
that names no run is dropped as invalid (counted in ``dropped``). When a new
run appears the vehicle first switches every behaviour off, so nothing a previous mission
enabled is left on. A restarted vehicle process starts with every behaviour off.

The modem (a fleet's vehicle, docs/FLEET_ZENOH.md): a stack with a side of a fleet's channels
(``payload``, ``heard``: paper 003's ASV and UUV) answers the query ``mcl/<v>/modem/payload``
(parameters ``channel``, ``message``, ``t``) with what a message it sends says, and the query
``mcl/<v>/modem/heard`` (payload JSON ``{"channel", "message", "data", "t"}``: a message its
player was delivered) once its stack has heard it, both applied between ticks.
``vehicle/servers/mcm_server.py`` serves the two vehicles of one simulated world this way, on
one clock.
"""

from __future__ import annotations

import json
import logging
import queue
import threading
import time
from collections.abc import Iterable
from dataclasses import dataclass, field
from typing import Any

import zenoh

from aal.messages import ActionMessage, Declaration, InvalidMessage
from aal.zenoh import (
    DEFAULT_ENDPOINT,
    LEASE_MS,
    close_session,
    keys,
    payload_text,
    zenoh_config,
)
from aal.zenoh_security import Security
from behaviours import capabilities
from behaviours.base import progress_of
from vehicle.control.stack import DT, IctineuStack, StackConfig

log = logging.getLogger(__name__)

@dataclass(frozen=True)
class NewRun:
    """A marker in the queue of actions: a new player run began (applied in the loop, before
    its actions: what the last run left on is switched off first)."""

    run: str


@dataclass
class ModemCall:
    """A modem's word asked or told by a player, applied in the loop between ticks: a
    payload asked (``data`` None; answered in ``answer``) or a message heard; ``done`` set
    once applied (the player waits for it)."""

    channel: str
    message: str
    t: float
    data: dict[str, Any] | None = None
    answer: dict[str, Any] | None = None
    done: threading.Event = field(default_factory=threading.Event)


CLOCK_PERIOD = 0.02  # wall s between clock messages
TELEMETRY_PERIOD = 0.2  # wall s between telemetry messages (5 Hz)
MAX_SLEEP = 0.01  # wall s: the loop looks at stop, actions and the player at least this often
MODEM_WAIT = 2.0  # wall s: the longest a modem's query (payload, heard) waits for the loop


class VehicleServer:
    """One simulated vehicle on one Zenoh endpoint. :meth:`run` blocks until ``stop`` is set."""

    def __init__(self, endpoint: str = DEFAULT_ENDPOINT, vehicle_name: str = "auv",
                 speed: float = 10.0, seed: int = 1,
                 faults: Iterable[tuple[str, float]] = (),
                 stop: threading.Event | None = None, player_timeout: float = 3.0,
                 wait_for_player: bool = True, lease_ms: int = LEASE_MS,
                 ready: threading.Event | None = None, security: Security | None = None,
                 scouting: bool = False, stack: Any = None,
                 declaration: Declaration | None = None,
                 safe: str | None = "Surface", dt: float = DT):
        """``stack``: the simulated stack to serve (default the Ictineu's, of ``seed`` and
        ``faults``), with ``declaration`` its behaviours; ``safe``: the behaviour it enables
        when its player is lost (None: only switch every behaviour off); ``dt``: its tick."""
        if not speed > 0:
            raise ValueError("speed must be positive")
        self.endpoint = endpoint
        self.name = vehicle_name
        self.keys = keys(vehicle_name)
        self.speed = float(speed)
        self.stack: Any = stack if stack is not None else IctineuStack(
            StackConfig(seed=seed, faults=list(faults)))
        self.declaration = declaration or capabilities.simulated(
            f"{vehicle_name} (mcl vehicle --zenoh {endpoint})", list(self.stack.behaviours))
        self.safe, self.dt = safe, dt
        self.modem = callable(getattr(self.stack, "payload", None))
        self.stop = stop or threading.Event()
        self.player_timeout = player_timeout
        self.wait_for_player = wait_for_player
        self.lease_ms = lease_ms
        self.security = security
        self.scouting = scouting
        self.ready = ready or threading.Event()
        self._actions: queue.Queue[ActionMessage | NewRun | ModemCall] = queue.Queue()
        self._lock = threading.Lock()
        self._player_present = threading.Event()
        self._player_gone_at: float | None = None  # monotonic, while the player is away
        self.failsafe = False  # the safe action has been taken (and not re-armed)
        self._run = ""  # the player run whose actions are taken (its token's last part)
        # the run whose actions the stack applies: telemetry names it, so that a state of the
        # new run never shows what the last one left on (the loop switches that off first)
        self._applied_run = ""
        self._ended: dict[str, str] = {}  # run -> how its mission ended (its last status)
        self._begun: set[str] = set()  # the runs whose missions have said their status
        self._last_seq: dict[str, int] = {}  # per run: the last action seq taken
        self.stale = 0  # actions of another run, or replayed, dropped
        self.dropped = 0  # invalid actions dropped
        self.actions = 0
        self.events = 0

    # -- Zenoh callbacks ----------------------------------------------------------------------
    def _on_action(self, sample: zenoh.Sample) -> None:
        try:
            action = ActionMessage.from_json(payload_text(sample))
        except InvalidMessage as exc:
            with self._lock:
                self.dropped += 1
            log.warning("vehicle dropped an invalid action: %s", exc)
            return
        self.take(action)

    def take(self, action: ActionMessage) -> str | None:
        """Queue ``action`` for the loop if it belongs to the current run and is new; else
        count it and return why it was dropped.

        An action must name its run: one without a run id belongs to no run, so nothing
        tells it from a replay (into this run or the next), and it is dropped as invalid."""
        with self._lock:
            if not action.run:
                self.dropped += 1
                reason = "it names no run (every action names the player run it belongs to)"
            elif action.run != self._run or action.seq <= self._last_seq.get(action.run, -1):
                self.stale += 1
                reason = (f"stale (run {action.run}, seq {action.seq}; current run "
                          f"{self._run or '-'})")
            else:
                self._last_seq[action.run] = action.seq
                reason = ""
        if reason:
            log.warning("vehicle dropped an action: %s: %s %s", reason, action.kind,
                        action.behaviour)
            return reason
        self._actions.put(action)
        return None

    def _on_player(self, sample: zenoh.Sample) -> None:
        run = str(sample.key_expr).rpartition("/")[2]
        with self._lock:
            if sample.kind == zenoh.SampleKind.PUT:
                if run != self._run:
                    if self._run:
                        log.warning("a new player run %s replaces %s", run, self._run)
                    self._run = run
                    self._actions.put(NewRun(run))  # applied in the loop, before its actions
                self._player_gone_at = None
                self._player_present.set()
                if self.failsafe:
                    log.warning("player is back: the safe action is re-armed")
                self.failsafe = False
            elif run == self._run and run in self._ended:  # a goodbye: no failsafe
                self._player_present.clear()
                log.warning("the player left after its mission ended %s: no failsafe",
                            self._ended[run].upper())
            elif run == self._run:
                self._player_present.clear()
                self._player_gone_at = time.monotonic()
                log.warning("player's token went away")

    def _on_status(self, sample: zenoh.Sample) -> None:
        """The mission status a player publishes: remember which runs' missions ended."""
        try:
            status = json.loads(payload_text(sample))
            run, how = str(status["run"]), str(status["status"])
        except (ValueError, KeyError, TypeError):
            return  # not a status this vehicle can read: nothing to remember
        with self._lock:
            self._begun.add(run)
            if how in ("ok", "fail"):
                self._ended[run] = how

    def _on_capabilities(self, query: zenoh.Query) -> None:
        """What this vehicle can do: the Ictineu stack's declaration (the task library's)."""
        d = self.declaration
        query.reply(self.keys["capabilities"], json.dumps(
            {"vehicle": d.vehicle, "source": d.source, "text": d.text}))

    def _on_payload(self, query: zenoh.Query) -> None:
        """A player asks what a message it sends says (its Send): the stack's payload."""
        try:
            p = query.parameters
            call = ModemCall(str(p["channel"]), str(p["message"]), float(str(p["t"])))
        except (KeyError, ValueError, TypeError):
            return  # not a question this vehicle can read: no answer
        if self._applied(call):
            query.reply(self.keys["modem_payload"], json.dumps(call.answer or {}))

    def _on_heard(self, query: zenoh.Query) -> None:
        """A player says a message was delivered to this vehicle: its stack hears it, then the
        player is answered (it acts on the message only after: vehicle_adapters/zenoh_modem.py)."""
        try:
            d = json.loads(query.payload.to_bytes() if query.payload is not None else b"")
            call = ModemCall(str(d["channel"]), str(d["message"]), float(d["t"]),
                             data=dict(d["data"]))
        except (ValueError, KeyError, TypeError):
            with self._lock:
                self.dropped += 1
            return  # not a message this vehicle can read: no answer
        if self._applied(call):
            query.reply(self.keys["modem_heard"], "{}")

    def _applied(self, call: ModemCall) -> bool:
        """Queue a modem's call for the loop and wait (at most ``MODEM_WAIT``) until it is
        applied: whether it was."""
        self._actions.put(call)
        return call.done.wait(MODEM_WAIT)

    # -- the loop -------------------------------------------------------------------------------
    def run(self) -> None:
        session = self.open()
        try:
            pub, entities = self.declare(session)
            self.ready.set()
            log.info("vehicle %s ready on %s", self.name, self.endpoint)
            self._loop(pub)
            for e in reversed(entities):
                e.undeclare()
        finally:
            close_session(session)

    def open(self) -> zenoh.Session:
        """The vehicle's session, listening on its endpoint."""
        return zenoh.open(zenoh_config(self.endpoint, listen=True, lease_ms=self.lease_ms,
                                       security=self.security, role="vehicle",
                                       scouting=self.scouting))

    def declare(self, session: zenoh.Session) -> tuple[dict[str, Any], list[Any]]:
        """Its publishers, and its subscribers, queryables and token (the token last: all
        is ready once it is seen)."""
        k = self.keys
        pub = {
            "event": session.declare_publisher(
                k["event"], congestion_control=zenoh.CongestionControl.BLOCK,
                priority=zenoh.Priority.INTERACTIVE_HIGH, express=True),
            "clock": session.declare_publisher(
                k["clock"], congestion_control=zenoh.CongestionControl.DROP, express=True),
        }
        for stream in ("navigator", "wall", "behaviours"):
            pub[stream] = session.declare_publisher(
                f"{k['telemetry']}/{stream}",
                congestion_control=zenoh.CongestionControl.DROP,
                priority=zenoh.Priority.DATA_LOW)
        entities: list[Any] = [
            session.declare_subscriber(k["action"], self._on_action),
            session.declare_subscriber(k["status"], self._on_status),
            session.liveliness().declare_subscriber(f"{k['alive_player']}/*",
                                                    self._on_player, history=True),
            session.declare_queryable(k["capabilities"], self._on_capabilities),
        ]
        if self.modem:
            entities += [session.declare_queryable(k["modem_payload"], self._on_payload),
                         session.declare_queryable(k["modem_heard"], self._on_heard)]
        entities.append(session.liveliness().declare_token(k["alive_vehicle"]))
        return pub, entities

    def player_present(self) -> bool:
        """Whether its player's token is there."""
        return self._player_present.is_set()

    def mission_begun(self) -> bool:
        """Whether its player's current run has begun its mission (said its status)."""
        with self._lock:
            return self._player_present.is_set() and self._run in self._begun

    def tick(self, pub: dict[str, Any]) -> None:
        """One tick of its stack; its events published."""
        for event in self.stack.due(self.stack.t + self.dt):
            pub["event"].put(event.to_json())
            self.events += 1

    def _loop(self, pub: dict[str, Any]) -> None:
        stack = self.stack
        next_clock = next_telemetry = 0.0
        while self.wait_for_player and not self._player_present.is_set():
            # paused at t = 0 until a player comes: say so (the player's clock stands still)
            if self.stop.is_set():
                return
            self.apply_actions()
            self.publish_clock(pub, False)
            if time.monotonic() >= next_telemetry:
                self.publish_telemetry(pub)
                next_telemetry = time.monotonic() + TELEMETRY_PERIOD
            self._player_present.wait(CLOCK_PERIOD)
        wall0, t0 = time.monotonic(), stack.t
        while not self.stop.is_set():
            self.apply_actions()
            self.check_player()
            now = time.monotonic()
            if stack.t + self.dt <= t0 + (now - wall0) * self.speed:  # a tick is due
                self.tick(pub)
            else:
                due_at = wall0 + (stack.t + self.dt - t0) / self.speed
                time.sleep(min(MAX_SLEEP, max(0.0, due_at - now)))
            now = time.monotonic()
            if now >= next_clock:
                self.publish_clock(pub, True)
                next_clock = now + CLOCK_PERIOD
            if now >= next_telemetry:
                self.publish_telemetry(pub)
                next_telemetry = now + TELEMETRY_PERIOD

    def apply_actions(self) -> None:
        """Apply what has arrived: actions, new runs, the modem's calls."""
        while True:
            try:
                action = self._actions.get_nowait()
            except queue.Empty:
                return
            if isinstance(action, ModemCall):
                self.modem_call(action)
                continue
            if isinstance(action, NewRun):
                self.switch_off("a new player run")
                self._applied_run = action.run
                continue
            self.actions += 1
            self.stack.on_action(action, self.stack.t)

    def modem_call(self, call: ModemCall) -> None:
        """A payload asked (answered) or a message heard, by the stack."""
        if call.data is None:
            answer = dict(self.stack.payload(call.channel, call.message, call.t))
            where = getattr(self.stack, "position", lambda: None)()
            call.answer = {**({"position": list(where)} if where is not None else {}),
                           **answer}
        else:
            self.stack.heard(call.channel, call.message, call.data, call.t)
        call.done.set()

    def check_player(self) -> None:
        """Take the safe action once the player has been gone too long."""
        with self._lock:
            gone = self._player_gone_at
            due = (gone is not None and not self.failsafe
                   and time.monotonic() - gone >= self.player_timeout)
            if due:
                self.failsafe = True
        if due:
            self.safe_action()

    def switch_off(self, why: str) -> list[str]:
        """Disable every active behaviour; returns their names."""
        stack, t = self.stack, self.stack.t
        active = [b.name for b in stack.behaviours.values() if b.active]
        if active:
            log.warning("%s: disabling %s", why, ", ".join(active))
        for i, name in enumerate(active):
            stack.on_action(ActionMessage(i, t, "vehicle", why, "disable", name, {}), t)
        return active

    def safe_action(self) -> None:
        """Disable every active behaviour, then enable its safe behaviour (Surface)."""
        self.switch_off(f"player lost for {self.player_timeout:g} s")
        if self.safe is None:
            return
        log.warning("%s (the player is lost)", self.safe)
        t = self.stack.t
        self.stack.on_action(ActionMessage(0, t, "vehicle", "failsafe", "enable", self.safe,
                                           {}), t)

    def publish_clock(self, pub: dict[str, Any], running: bool) -> None:
        pub["clock"].put(json.dumps({"t": self.stack.t, "speed": self.speed,
                                     "running": running}))

    def publish_telemetry(self, pub: dict[str, Any]) -> None:
        p = self.stack.perception()
        t = self.stack.t
        pub["navigator"].put(json.dumps({"t": t, "x": p.x, "y": p.y, "z": p.z, "yaw": p.psi,
                                         "u": p.u, "v": p.v, "w": p.w, "r": p.r}))
        pub["wall"].put(json.dumps({"t": t, "detected": p.wall_distance is not None,
                                    "distance": p.wall_distance, "heading": p.wall_heading}))
        pub["behaviours"].put(json.dumps({
            "t": t, "active": sorted(b.name for b in self.stack.behaviours.values() if b.active),
            "progress": progress_of(self.stack.behaviours.values()),
            "failsafe": self.failsafe, "player": self._player_present.is_set(),
            "run": self._applied_run, "actions": self.actions, "events": self.events,
            "dropped": self.dropped, "stale": self.stale}))


def serve(endpoint: str = DEFAULT_ENDPOINT, vehicle_name: str = "auv", speed: float = 10.0,
          seed: int = 1, faults: Iterable[tuple[str, float]] = (),
          stop: threading.Event | None = None, player_timeout: float = 3.0,
          **options: Any) -> VehicleServer:
    """Serve a simulated vehicle until ``stop`` is set (blocks); returns the server."""
    server = VehicleServer(endpoint, vehicle_name, speed, seed, faults, stop, player_timeout,
                           **options)
    server.run()
    return server
