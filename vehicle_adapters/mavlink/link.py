"""The MAVLink adapter (docs/AAL.md): the player on one side, an ArduSub-class vehicle on the
other.

    with MavlinkVehicle("udpin:127.0.0.1:14550") as vehicle: run(player, vehicle, ...)

The player's Vehicle (``send``, ``receive``, ``now``, ``lost``, ``declaration``), tying
together one concern a module of this package: ``connection`` (the connection, its ONE reader
thread and the ground station's streams), ``commands`` (retries, modes, arming, the devices'
commands), ``telemetry`` (what the behaviours perceive), ``failsafe`` (link health, take-over),
``guided`` (the registered behaviours' position laws on GUIDED setpoints, one coordinator).

Entering opens the connection, starts the reader, waits (bounded) for the vehicle's
HEARTBEAT, asks for the telemetry it needs, sets GUIDED and arms. The behaviours map onto
GUIDED setpoints (every registered behaviour with a position law), the SURFACE mode, commands
(the behaviours that switch a device: StartCamera, StartLogs) and STATUSTEXT
(docs/MAVLINK.md).

Clock: every ``time_boot_ms`` the vehicle sends is its (simulated) clock; ``now()`` is the last
one received, run on by wall time x the speed estimated from them (bounded). Link health:
when the vehicle's HEARTBEAT has been missing for ``link_timeout`` wall seconds (or never came
within ``connect_timeout``), one synthetic ``Link.lost`` event; from then on the clock runs on
wall time x the last speed, so that the player's timers still end the run.
"""

from __future__ import annotations

import logging
import threading
import time
from pathlib import Path
from typing import Any

from aal.mavlink import MODES as MODES
from aal.messages import ActionMessage, Declaration, EventMessage
from behaviours import capabilities
from behaviours.base import progress_of

from vehicle_adapters.link import MAX_POLL, RemoteVehicle
from vehicle_adapters.mavlink.commands import COMMANDS, Commands, result_name
from vehicle_adapters.mavlink.connection import DEFAULT_URL as DEFAULT_URL
from vehicle_adapters.mavlink.connection import Connection
from vehicle_adapters.mavlink.connection import MavlinkError as MavlinkError
from vehicle_adapters.mavlink.connection import mavutil as mavutil
from vehicle_adapters.mavlink.failsafe import LinkHealth
from vehicle_adapters.mavlink.guided import Event, Guided
from vehicle_adapters.mavlink.telemetry import Telemetry, intervals, perceive

log = logging.getLogger(__name__)

MAX_EXTRAPOLATION = 0.1  # wall s the clock runs on past the last time_boot_ms


class MavlinkVehicle(RemoteVehicle):
    """The player's adapter to an ArduSub-class vehicle over MAVLink 2 (the Vehicle protocol).

    It does not raise if the vehicle is absent or refuses GUIDED or arming: the run then gets
    ``Link.lost`` (with the reason). A bad URL or a connection that cannot be opened raises
    :class:`MavlinkError`."""

    def __init__(self, url: str = DEFAULT_URL, *, signing_key: bytes | None = None,
                 require_signing: bool = False, connect_timeout: float = 10.0,
                 link_timeout: float = 2.0, max_poll: float = MAX_POLL,
                 timestamp_file: Path | None = None, arm: bool = True):
        super().__init__(max_poll=max_poll, max_extrapolation=MAX_EXTRAPOLATION)
        self.link = Connection(url, signing_key=signing_key, require_signing=require_signing,
                               timestamp_file=timestamp_file)
        self.url = self.link.url
        self.connect_timeout, self.arm = connect_timeout, arm
        self.health = LinkHealth(arm, link_timeout)
        self.commands = Commands(self.link.send)
        self.tel = Telemetry()
        self.guided = Guided()
        self._positioned = threading.Event()  # a LOCAL_POSITION_NED has come
        self._ref: tuple[float, float] | None = None  # (t, wall) the speed is measured from
        self.sent = 0  # actions sent
        self.unknown_actions: list[str] = []

    # -- what tests, benchmarks and the summary read ----------------------------------------
    @property
    def answered(self) -> bool:
        """Has the vehicle answered since the link opened (a HEARTBEAT)?"""
        return self.health.heard.is_set()

    @property
    def signing(self) -> Any:
        return self.link.signing

    @property
    def commands_sent(self) -> int:
        return self.commands.sent

    @property
    def acks_received(self) -> int:
        return self.commands.acks

    @property
    def ack_latencies(self) -> list[float]:
        return self.commands.latencies

    def command(self, command: int, *params: float, wait: float | None = None) -> int | None:
        """Send a COMMAND_LONG (:meth:`Commands.command`)."""
        return self.commands.command(command, *params, wait=wait)

    def set_mode(self, mode: str) -> None:
        with self.lock:  # a mode we ask for is no take-over: watched from its first heartbeat
            self.health.expect(MODES[mode])
        self.commands.set_mode(mode)

    # -- context manager ----------------------------------------------------------------------
    def __enter__(self) -> MavlinkVehicle:
        self.link.open()
        try:
            self.link.start(self._on_message, self._on_tick, self.health.heard)
            self._connect()
        except BaseException:
            self.__exit__()
            raise
        return self

    def _connect(self) -> None:
        """Wait for the vehicle, ask for telemetry, set GUIDED and arm (all bounded)."""
        deadline = time.monotonic() + self.connect_timeout
        if not self.health.heard.wait(self.connect_timeout):
            self.link_lost(f"no vehicle answered at mavlink:{self.url} within "
                            f"{self.connect_timeout:g} s (no HEARTBEAT)")
            return
        for message_id, interval in intervals():
            self.commands.set_interval(message_id, interval)
        if self.arm:
            with self.lock:
                self.health.expect(MODES["GUIDED"])
            refused = self.commands.take_control(lambda: deadline - time.monotonic())
            if refused is not None:
                what, result = refused
                hint = ""
                if result is None and self.link.signing is None and self.health.signs:
                    hint = ": it signs its messages, give its key (--signing-key FILE)"
                self.link_lost(f"the vehicle refused {what} ({result_name(result)})" + hint)
                return
            # from its HEARTBEAT on, a change of mode we did not ask for is a take-over
            if not self.health.controlled.wait(max(0.1, deadline - time.monotonic())):
                self.link_lost("the vehicle acknowledged GUIDED and arming but its "
                               "HEARTBEAT never showed them")
                return
        self._positioned.wait(max(0.1, deadline - time.monotonic()))

    def __exit__(self, *exc: object) -> None:
        if self.link.conn is None:
            return
        with self.lock:
            self.health.release()  # disarming at the end is no take-over
        try:
            if self.link.reading and not self.lost and self.arm and self.health.armed:
                self.commands.arm(False, wait=0.5)
        finally:
            self.link.close()
            log.info("MAVLink link closed: %s", self.summary())

    def declaration(self) -> Declaration:
        """What this adapter can make an ArduSub-class vehicle do: the registry's declarations
        of the behaviours it maps (those with a position law, and the devices' commands)."""
        names = set(self.guided.behaviours) | {name for name, _ in COMMANDS}
        return capabilities.registered(f"mavlink:{self.url} (an ArduSub-class vehicle)", names)

    def confirm_off(self, names: list[str], timeout: float) -> str:
        """Wait (at most ``timeout`` wall s) for the COMMAND_ACK of every command sent (the
        camera's and the logger's stop among them); the behaviours the adapter runs itself are
        off as soon as they are disabled."""
        if self.lost:
            return f"not confirmed: the link is lost ({self.lost_reason})"

        def on() -> list[str]:
            with self.lock:
                return self.guided.on()

        return self.commands.confirm_off(names, on, timeout)

    def progress(self) -> dict[str, Any]:
        """Each active behaviour's progress (the adapter runs them: waypoint k of n, metres to
        go), by its name."""
        with self.lock:
            return progress_of(self.guided.behaviours.values())

    def pose(self) -> tuple[float, float, float, float, float] | None:
        """Where the vehicle last said it is (LOCAL_POSITION_NED, ATTITUDE's yaw): ``(t, x,
        y, z, yaw)``, t on its clock (s), in the local NED frame (m, rad); None before its
        first position (``mcl run --view`` draws the track of it)."""
        with self.lock:
            tel = self.tel
            return (tel.t, tel.x, tel.y, tel.z, tel.yaw) if tel.positioned else None

    def summary(self) -> dict[str, Any]:
        """What went over the link: counts, command latencies, signing."""
        ms = sorted(1e3 * s for s in self.commands.latencies)
        return {"actions": self.sent, "commands": self.commands.sent,
                "acks": self.commands.acks,
                "ack_median_ms": round(ms[len(ms) // 2], 3) if ms else None,
                "ack_max_ms": round(ms[-1], 3) if ms else None,
                "messages": self.link.received, "bad_data": self.link.bad_data,
                "signing": self.link.signing.counts() if self.link.signing else None,
                "lost": self.lost_reason or None}

    # -- the reader thread --------------------------------------------------------------------
    def _on_message(self, msg: Any) -> None:
        kind = msg.get_type()
        if kind == "COMMAND_ACK":
            self.commands.on_ack(msg)
            return
        t_ms = getattr(msg, "time_boot_ms", None)
        taken_over = ""
        with self.lock:
            if t_ms is not None:
                self._on_clock(t_ms / 1000.0)
            if kind == "HEARTBEAT":
                taken_over = self.health.on_heartbeat(msg, self.tel.critical_text(),
                                                      self.lost)
            elif self.tel.decode(msg):  # a new position: the behaviours' tick
                self._positioned.set()
                self._steer_locked()
        if taken_over:
            self.link_lost(taken_over)

    def _on_tick(self, now: float) -> None:
        silent = self.health.silent(now, self.lost)
        if silent:
            self.link_lost(silent)
        self.commands.retry(now, give_up=self.lost)

    def _on_clock(self, t: float) -> None:
        wall = time.monotonic()
        if t <= self.base_t:
            return
        if self._ref is None:
            self._ref = (t, wall)
        elif wall - self._ref[1] >= 0.2:  # the speed over the last fifth of a wall second
            self.speed = (t - self._ref[0]) / (wall - self._ref[1])
            self._ref = (t, wall)
        if not self.lost:
            self.set_clock_locked(t)

    # -- the behaviours the adapter runs (self.lock held) --------------------------------------
    def _steer_locked(self) -> None:
        """Tick the behaviours, pass their events on, send the merged setpoint if due."""
        events, setpoint = self.guided.tick(perceive(self.tel))
        self._say_locked(events)
        if setpoint is not None:
            self.link.send(setpoint)

    def _say_locked(self, events: list[Event]) -> None:
        for behaviour, name, data in events:
            self.inbox.put(EventMessage(self.next_seq_locked(), self.now_locked(),
                                        behaviour, name, data))

    # -- the Vehicle protocol ---------------------------------------------------------------------
    def send(self, action: ActionMessage) -> None:
        if self.link.conn is None:
            raise RuntimeError("MavlinkVehicle used outside its 'with' block")
        if self.lost:
            log.warning("link lost: action %s %s not sent", action.kind, action.behaviour)
            return
        self.sent += 1
        name, kind = action.behaviour, action.kind
        if (name, kind) in COMMANDS:
            self.commands.command(COMMANDS[name, kind])
            return
        if name not in self.guided.behaviours:
            if (name, "enable") not in COMMANDS:
                log.warning("no MAVLink mapping for behaviour %s: action dropped", name)
                self.unknown_actions.append(name)
            return
        with self.lock:
            mode = self.guided.act(name, kind, action.params, perceive(self.tel),
                                   guided=self.health.mode == MODES["GUIDED"])
        if mode:  # before the setpoint: ArduSub ignores setpoints outside GUIDED
            self.set_mode(mode)
        with self.lock:
            if kind != "disable":
                self.guided.resend()
                if self.tel.positioned:
                    self._steer_locked()
            self._say_locked(self.guided.events(name))
