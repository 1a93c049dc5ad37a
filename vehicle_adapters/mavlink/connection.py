"""The ground station's end of the MAVLink link: the connection and its ONE reader thread.

MAVLink 2, dialect ardupilotmega; the player is a ground station (sysid 255, compid 190,
MAV_COMP_ID_MISSIONPLANNER) talking to the vehicle's autopilot (sysid 1, compid 1). Opening
makes the connection (URL as pymavlink writes it) and enables signing if a key is given. On
``udpin:`` it sends only to the address the vehicle's accepted messages come from
(:class:`aal.mavlink_udp.PeerUdp`), never to whoever else sent it a datagram.

The reader thread hands every message from the vehicle to the adapter and does the periodic
work of a ground station: once the vehicle has been heard, the GCS HEARTBEAT (1 Hz) and a
neutral MANUAL_CONTROL stream (10 Hz), which ArduSub's ground-station and pilot-input
failsafes expect; then the adapter's own periodic work (link health, command retries); and
the signing timestamp saved now and then. Every send goes through one lock (pymavlink's
sequence numbers and signing timestamps are not thread-safe), and so does every receive
(checking a signature moves the signing timestamp).
"""

from __future__ import annotations

import logging
import os
import select
import threading
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

os.environ["MAVLINK20"] = "1"  # before pymavlink loads a dialect: MAVLink 2 only

# mavutil is re-exported: importing it from here guarantees MAVLink 2
from pymavlink import mavutil as mavutil  # noqa: E402
from pymavlink.dialects.v20 import ardupilotmega as mavlink  # noqa: E402

from aal import mavlink_udp, signing  # noqa: E402
from aal.mavlink import GCS_SYSID, VEHICLE_SYSID, parse_url  # noqa: E402
from diagnostics import Diagnostic, MclError  # noqa: E402

log = logging.getLogger(__name__)

DEFAULT_URL = "udpin:127.0.0.1:14550"
GCS_COMPID = mavlink.MAV_COMP_ID_MISSIONPLANNER
LINK_PERIOD = {"HEARTBEAT": 1.0, "MANUAL_CONTROL": 0.1}  # wall s: what the failsafes expect
SAVE_PERIOD = 5.0  # wall s between saves of the signing timestamp
BURST = 500  # messages read before the periodic work runs again


class MavlinkError(MclError):
    """A MAVLink URL or connection the user gave that cannot be used (``mcl run`` exit 2)."""

    def __init__(self, message: str, hint: str = ""):
        super().__init__(Diagnostic("error", message, hint=hint))


def check_url(url: str) -> str:
    """The URL if pymavlink can open it as a network link, else MavlinkError saying why."""
    try:
        parse_url(url)
    except ValueError as exc:
        raise MavlinkError(f"--vehicle mavlink:{url}: {exc}",
                           "e.g. --vehicle mavlink:udpin:127.0.0.1:14550") from None
    return url


class Connection:
    """The link to the vehicle: :meth:`open`, :meth:`start` the reader, :meth:`send` from any
    thread, :meth:`close`. Counts what it receives."""

    def __init__(self, url: str, *, signing_key: bytes | None = None,
                 require_signing: bool = False, timestamp_file: Path | None = None):
        self.url = check_url(url)
        if require_signing and signing_key is None:
            raise MavlinkError("--require-signing needs a key",
                               "give --signing-key FILE or set $" + signing.ENV_KEY)
        self.signing_key, self.require_signing = signing_key, require_signing
        self.timestamp_file = timestamp_file
        self.conn: Any = None
        self.signing: signing.SigningState | None = None
        self._io = threading.Lock()  # every send and receive on the connection
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self.received = 0  # messages from the vehicle
        self.bad_data = 0  # unparsable or rejected (signing) messages

    @property
    def reading(self) -> bool:
        return self._thread is not None

    def open(self) -> None:
        """Make the connection and enable signing; MavlinkError if it cannot be opened."""
        try:
            self.conn = mavlink_udp.connect(
                self.url, source_system=GCS_SYSID, source_component=GCS_COMPID,
                peer_system=VEHICLE_SYSID, autoreconnect=False, retries=0)
        except (OSError, ValueError) as exc:
            raise MavlinkError(f"--vehicle mavlink:{self.url}: cannot open it: {exc}",
                               "is another program using that port?") from None
        if self.signing_key is not None:
            path = self.timestamp_file or signing.default_timestamp_file(
                self.signing_key, "player")
            try:
                self.signing = signing.enable(self.conn, self.signing_key,
                                              require=self.require_signing, link_id=1,
                                              timestamp_file=path,
                                              skew=signing.PLAYER_CLOCK_SKEW)
            except BaseException:
                self.close()
                raise

    def start(self, on_message: Callable[[Any], None], on_tick: Callable[[float], None],
              heard: threading.Event) -> None:
        """Start the reader: ``on_message`` with each message from the vehicle, ``on_tick``
        with the monotonic time after each burst; the ground station's streams once ``heard``
        is set."""
        self._thread = threading.Thread(target=self._reader, args=(on_message, on_tick, heard),
                                        name="mavlink-reader", daemon=True)
        self._thread.start()

    def send(self, msg: Any) -> None:
        with self._io:
            if self.conn is not None:
                self.conn.mav.send(msg)

    def close(self) -> None:
        """Stop the reader, save the signing timestamp, close the connection."""
        self._stop.set()
        if self._thread is not None:
            self._thread.join(timeout=2.0)
        with self._io:
            if self.signing is not None:
                self._save_signing()
            if self.conn is not None:
                self.conn.close()
            self.conn = None

    # -- the reader thread ------------------------------------------------------------------------
    def _reader(self, on_message: Callable[[Any], None], on_tick: Callable[[float], None],
                heard: threading.Event) -> None:
        next_beat = {name: 0.0 for name in LINK_PERIOD}
        next_save = time.monotonic() + SAVE_PERIOD
        while not self._stop.is_set():
            count = 0
            while count < BURST:  # a burst is bounded: the periodic work below still runs
                with self._io:
                    try:
                        msg = self.conn.recv_msg()
                    except (OSError, mavlink.MAVError) as exc:
                        log.debug("receive error: %s", exc)
                        msg = None
                if msg is None:
                    break
                count += 1
                if msg.get_type() == "BAD_DATA":
                    self.bad_data += 1
                    continue
                if msg.get_srcSystem() != VEHICLE_SYSID:
                    continue  # another ground station, or a router's own messages
                self.received += 1
                try:
                    on_message(msg)
                except Exception:  # one bad message must not stop the link
                    log.exception("could not handle %s", msg.get_type())
            now = time.monotonic()
            for name, period in LINK_PERIOD.items():
                if now >= next_beat[name] and heard.is_set():
                    self.send(ground_station(name))
                    next_beat[name] = now + period
            on_tick(now)
            if self.signing is not None and now >= next_save:
                with self._io:
                    self._save_signing()
                next_save = now + SAVE_PERIOD
            if count == 0:
                try:
                    select.select([self.conn.fd], [], [], 0.02)
                except (OSError, ValueError):
                    time.sleep(0.02)

    def _save_signing(self) -> None:
        assert self.signing is not None
        try:
            self.signing.save()
        except OSError as exc:
            log.warning("could not save the signing timestamp: %s", exc)


def ground_station(name: str) -> Any:
    """The ground station's periodic message: its HEARTBEAT, or neutral MANUAL_CONTROL."""
    if name == "HEARTBEAT":
        return mavlink.MAVLink_heartbeat_message(
            mavlink.MAV_TYPE_GCS, mavlink.MAV_AUTOPILOT_INVALID, 0, 0,
            mavlink.MAV_STATE_ACTIVE, 3)
    # neutral sticks: x, y, r centred, z (throttle) at mid-range 500, no buttons
    return mavlink.MAVLink_manual_control_message(VEHICLE_SYSID, 0, 0, 500, 0, 0)
