"""What both ends of a MAVLink link agree on, as ArduSub has it: identities, mode numbers, the
texts of its alarms and failsafes, and the URLs pymavlink opens. Used by the simulated vehicle
(:mod:`vehicle.servers.ardusub`) and the player's adapter (:mod:`vehicle_adapters.mavlink.link`).
"""

from __future__ import annotations

import re

VEHICLE_SYSID = 1  # the autopilot: component MAV_COMP_ID_AUTOPILOT1 (1)
GCS_SYSID = 255  # ArduSub's SYSID_MYGCS: the ground station it obeys
MODES = {"STABILIZE": 0, "ACRO": 1, "ALT_HOLD": 2, "AUTO": 3, "GUIDED": 4, "CIRCLE": 7,
         "SURFACE": 9, "POSHOLD": 16, "MANUAL": 19}  # ArduSub's custom_mode numbers
MODE_NAMES = {n: name for name, n in MODES.items()}

# ArduSub's STATUSTEXTs (failsafe.cpp)
LEAK_TEXT = "Leak Detected"
TEMPERATURE_TEXT = "Internal temperature critical!"
PRESSURE_TEXT = "Internal pressure critical!"
PILOT_TEXT = "Lost manual control"
GCS_TEXT = f"MYGCS: {GCS_SYSID}, heartbeat lost"

URL_SCHEMES = ("udpin", "udpout", "udp", "udpbcast", "tcp", "tcpin")
_URL = re.compile(r"(%s):([^:\s]+):(\d{1,5})" % "|".join(URL_SCHEMES))


def parse_url(url: str) -> tuple[str, str, int]:
    """``udpin:127.0.0.1:14550`` -> ("udpin", "127.0.0.1", 14550); ValueError saying why not."""
    m = _URL.fullmatch(url)
    if m is None:
        raise ValueError(f"{url!r} is not a MAVLink URL: write it as pymavlink does, "
                         "udpin:HOST:PORT (listen), udpout:HOST:PORT (send there), "
                         "udpbcast:HOST:PORT, tcp:HOST:PORT (connect) or tcpin:HOST:PORT")
    port = int(m[3])
    if not 0 < port < 65536:
        raise ValueError(f"{url!r}: port {port} is not in 1..65535")
    return m[1], m[2], port
