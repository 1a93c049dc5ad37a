"""Commands to the vehicle (COMMAND_LONG) with their retries: mode switching, arming, the
camera's and the logger's start and stop, the telemetry streams asked for.

A behaviour that switches a device (``Behaviour.switches``, behaviours/base.py) is that
device's start and stop command (:data:`DEVICES`): StartCamera the camera's, StartLogs the
logger's, and any behaviour registered since that switches one of them (:data:`COMMANDS`, a
view of the registry).

A command without its COMMAND_ACK is sent again after ``ACK_TIMEOUT`` wall s with the next
``confirmation``, at most ``ACK_TRIES`` times (the reader thread calls :meth:`Commands.retry`);
MAV_RESULT_IN_PROGRESS keeps it waiting. Thread-safe: the player's thread sends, the reader
thread takes the answers.
"""

from __future__ import annotations

import logging
import threading
import time
from collections.abc import Callable, Iterator, Mapping
from dataclasses import dataclass, field
from typing import Any

from pymavlink.dialects.v20 import ardupilotmega as mavlink

from aal.mavlink import MODES, VEHICLE_SYSID
from behaviours import registry

log = logging.getLogger(__name__)

VEHICLE_COMPID = mavlink.MAV_COMP_ID_AUTOPILOT1
ACK_TIMEOUT = 0.5  # wall s before a command without COMMAND_ACK is sent again
ACK_TRIES = 3

# the devices ArduSub starts and stops by command: device -> (start, stop) MAV_CMD
DEVICES = {"camera": (mavlink.MAV_CMD_IMAGE_START_CAPTURE, mavlink.MAV_CMD_IMAGE_STOP_CAPTURE),
           "logs": (mavlink.MAV_CMD_LOGGING_START, mavlink.MAV_CMD_LOGGING_STOP)}


class DeviceCommands(Mapping[tuple[str, str], int]):
    """The behaviours that are a command to the vehicle: (behaviour, "enable" or "disable") ->
    MAV_CMD, read from the registry at each look-up (a behaviour registered later is in)."""

    def _table(self) -> dict[tuple[str, str], int]:
        table: dict[tuple[str, str], int] = {}
        for device, (start, stop) in DEVICES.items():
            for name in registry.switching(device):
                table[name, "enable"], table[name, "disable"] = start, stop
        return table

    def __getitem__(self, key: tuple[str, str]) -> int:
        return self._table()[key]

    def __iter__(self) -> Iterator[tuple[str, str]]:
        return iter(self._table())

    def __len__(self) -> int:
        return len(self._table())


COMMANDS = DeviceCommands()


@dataclass
class Command:
    """A COMMAND_LONG waiting for its COMMAND_ACK."""

    command: int
    params: tuple[float, ...]
    sent_at: float  # monotonic, first send
    last_sent: float
    tries: int = 1
    result: int | None = None
    done: threading.Event = field(default_factory=threading.Event)

    def message(self, confirmation: int) -> Any:
        return mavlink.MAVLink_command_long_message(
            VEHICLE_SYSID, VEHICLE_COMPID, self.command, confirmation, *self.params)


class Commands:
    """The commands sent and their answers; ``send`` puts a message on the link."""

    def __init__(self, send: Callable[[Any], None]) -> None:
        self._send = send
        self._lock = threading.Lock()
        self._pending: list[Command] = []
        self.sent = 0
        self.acks = 0
        self.latencies: list[float] = []  # wall s from first send to COMMAND_ACK
        self.results: dict[int, int] = {}  # command -> last MAV_RESULT

    def command(self, command: int, *params: float, wait: float | None = None) -> int | None:
        """Send a COMMAND_LONG; with ``wait``, block at most that long for its COMMAND_ACK and
        return its MAV_RESULT (None: none came)."""
        padded = tuple(float(p) for p in params) + (0.0,) * (7 - len(params))
        now = time.monotonic()
        pending = Command(command, padded, now, now)
        with self._lock:
            self._pending.append(pending)
            self.sent += 1
        self._send(pending.message(0))
        if wait is None:
            return None
        pending.done.wait(wait)
        return pending.result

    def set_mode(self, mode: str, wait: float | None = None) -> int | None:
        """Ask for one of ArduSub's modes (:data:`aal.mavlink.MODES`)."""
        return self.command(mavlink.MAV_CMD_DO_SET_MODE,
                            mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, MODES[mode], wait=wait)

    def arm(self, arm: bool, wait: float | None = None) -> int | None:
        return self.command(mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 1 if arm else 0, wait=wait)

    def set_interval(self, message_id: int, interval: float) -> None:
        """Ask for a telemetry stream every ``interval`` us (-1: stop it)."""
        self.command(mavlink.MAV_CMD_SET_MESSAGE_INTERVAL, message_id, interval)

    def take_control(self, remaining: Callable[[], float]) -> tuple[str, int | None] | None:
        """GUIDED, then arming, each waiting at most ``remaining()`` wall s for its answer:
        None when both are accepted, else what was refused and the answer (None: none)."""
        result = self.set_mode("GUIDED", wait=max(0.1, remaining()))
        if result != mavlink.MAV_RESULT_ACCEPTED:
            return "GUIDED mode", result
        result = self.arm(True, wait=max(0.1, remaining()))
        if result != mavlink.MAV_RESULT_ACCEPTED:
            return "arming", result
        return None

    def unanswered(self) -> list[int]:
        """The commands still waiting for their COMMAND_ACK."""
        with self._lock:
            return [c.command for c in self._pending]

    def accepted(self, command: int) -> bool:
        return bool(self.results.get(command) == mavlink.MAV_RESULT_ACCEPTED)

    def confirm_off(self, names: list[str], on: Callable[[], list[str]], timeout: float) -> str:
        """Wait (at most ``timeout`` wall s) until every command is answered, the stops of the
        behaviours ``names`` that are commands accepted and nothing is ``on()``: what holds."""
        end = time.monotonic() + timeout
        while True:
            pending, still = self.unanswered(), on()
            refused = [n for n in names if (n, "disable") in COMMANDS and
                       not self.accepted(COMMANDS[n, "disable"])]
            if not pending and not still and not refused:
                return (f"confirmed: every command acknowledged ({self.acks} COMMAND_ACKs), "
                        "no behaviour on")
            if not pending and refused:
                return f"NOT confirmed: the vehicle did not accept stopping {', '.join(refused)}"
            if time.monotonic() >= end:
                break
            time.sleep(0.02)
        what = [f"{len(pending)} command(s) unacknowledged"] if pending else []
        what += [f"{', '.join(still)} still on"] if still else []
        return f"NOT confirmed within {timeout:g} s: {'; '.join(what)}"

    # -- the reader thread ------------------------------------------------------------------------
    def on_ack(self, msg: Any) -> None:
        with self._lock:
            for c in self._pending:
                if c.command == msg.command:
                    if msg.result == mavlink.MAV_RESULT_IN_PROGRESS:
                        return
                    self._pending.remove(c)
                    self.acks += 1
                    self.latencies.append(time.monotonic() - c.sent_at)
                    self.results[c.command] = c.result = msg.result
                    if msg.result != mavlink.MAV_RESULT_ACCEPTED:
                        log.warning("the vehicle answered command %d with %s", c.command,
                                    result_name(msg.result))
                    c.done.set()
                    return

    def retry(self, now: float, give_up: bool = False) -> None:
        """Send again what has waited ``ACK_TIMEOUT``; drop what has had ``ACK_TRIES`` (all of
        it with ``give_up``: the link is lost)."""
        again: list[tuple[Command, int]] = []
        with self._lock:
            for c in list(self._pending):
                if now - c.last_sent < ACK_TIMEOUT:
                    continue
                if c.tries >= ACK_TRIES or give_up:
                    self._pending.remove(c)
                    log.warning("no COMMAND_ACK for command %d after %d tries", c.command,
                                c.tries)
                    c.done.set()
                    continue
                c.tries += 1
                c.last_sent = now
                again.append((c, c.tries - 1))
        for c, confirmation in again:
            self._send(c.message(confirmation))


def result_name(result: int | None) -> str:
    if result is None:
        return "no answer"
    entry = mavlink.enums["MAV_RESULT"].get(result)
    return entry.name if entry is not None else str(result)
