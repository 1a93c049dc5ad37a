"""Link health and take-over: when the mission no longer drives the vehicle.

The vehicle's HEARTBEAT says it is there, its mode and whether it is armed. The link is lost
when no HEARTBEAT has come for ``link_timeout`` wall s. Once a HEARTBEAT has shown the mode
the adapter set (and armed, if it arms), a change it did not ask for is a take-over: ArduSub's
own failsafe switched mode, or it disarmed; the reason names the last CRITICAL STATUSTEXT.
"""

from __future__ import annotations

import threading
import time
from typing import Any

from pymavlink.dialects.v20 import ardupilotmega as mavlink

from aal.mavlink import MODE_NAMES


class LinkHealth:
    """What the vehicle's HEARTBEATs say. The adapter calls :meth:`expect`,
    :meth:`on_heartbeat` and :meth:`release` with its lock held; ``heard`` and ``controlled``
    are events for the threads that wait on them."""

    def __init__(self, arm: bool, link_timeout: float) -> None:
        self.arm, self.link_timeout = arm, link_timeout
        self.heard = threading.Event()  # the vehicle's HEARTBEAT has come
        self.controlled = threading.Event()  # a HEARTBEAT has shown the mode set (and armed)
        self.last_heartbeat = 0.0  # monotonic
        self.mode: int | None = None
        self.armed = False
        self.signs = False  # its HEARTBEATs are signed
        self.wanted_mode: int | None = None  # the mode the adapter last set
        self.in_control = False  # the vehicle is in that mode (and armed): a change is a take-over

    def expect(self, mode: int) -> None:
        """The adapter asks for ``mode``: no take-over, watched from its first HEARTBEAT."""
        self.wanted_mode, self.in_control = mode, False

    def release(self) -> None:
        """The adapter lets go (disarming at the end is no take-over)."""
        self.in_control = False

    def on_heartbeat(self, msg: Any, critical: str, lost: bool) -> str:
        """Take in a HEARTBEAT (``critical``: the last CRITICAL STATUSTEXT); why the vehicle
        took over, or ''."""
        if msg.type == mavlink.MAV_TYPE_GCS:
            return ""
        self.last_heartbeat = time.monotonic()
        self.signs = bool(msg.get_header().incompat_flags & mavlink.MAVLINK_IFLAG_SIGNED)
        mode, armed = msg.custom_mode, bool(msg.base_mode & mavlink.MAV_MODE_FLAG_SAFETY_ARMED)
        taken_over = ""
        if self.in_control and (mode != self.wanted_mode or (self.arm and not armed)):
            # the vehicle left the mode we set (its failsafe) or disarmed on its own: the
            # mission no longer drives it
            taken_over = (f"the vehicle took over: {mode_name(self.wanted_mode)} -> "
                          f"{mode_name(mode)}{'' if armed else ', disarmed'}"
                          + (f" ({critical})" if critical else ""))
            self.in_control = False
        elif (not self.in_control and self.wanted_mode is not None and not lost
              and mode == self.wanted_mode and (armed or not self.arm)):
            self.in_control = True
            self.controlled.set()
        self.mode, self.armed = mode, armed
        self.heard.set()
        return taken_over

    def silent(self, now: float, lost: bool) -> str:
        """Why the link is lost at monotonic ``now`` (no HEARTBEAT for too long), or ''."""
        if self.heard.is_set() and not lost and now - self.last_heartbeat > self.link_timeout:
            return f"no HEARTBEAT from the vehicle for {self.link_timeout:g} s"
        return ""


def mode_name(mode: int | None) -> str:
    return MODE_NAMES.get(mode, str(mode)) if mode is not None else "?"
