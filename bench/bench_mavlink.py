"""Command -> COMMAND_ACK latency through the MAVLink adapter, on loopback UDP.

    python bench/bench_mavlink.py [--count 1000] [--warmup 100] [--speed 100] [--json]

The player side is :class:`MavlinkVehicle` (ground station sysid 255) listening on a free UDP
port; it sends MAV_CMD_REQUEST_MESSAGE (HEARTBEAT) as a COMMAND_LONG and waits for the
COMMAND_ACK, one command at a time. Two peers answer, one after the other:

- the simulated ArduSub-like vehicle, ``mcl vehicle --mavlink udpout:... --speed N`` (a
  subprocess running the whole vehicle stack and its telemetry);
- a bare pymavlink echo peer (this file run with ``--peer URL``): a HEARTBEAT at 1 Hz, a
  LOCAL_POSITION_NED at 10 Hz and a COMMAND_ACK for every COMMAND_LONG, nothing else.

The latency is from the first send to the ACK's arrival in the adapter's reader thread
(``MavlinkVehicle.ack_latencies``); the ratio vehicle / echo is what the vehicle's work adds.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import threading
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from vehicle_adapters.mavlink.link import MavlinkVehicle, mavutil
from pymavlink.dialects.v20 import ardupilotmega as mavlink  # noqa: E402  (after: MAVLink 2)

from tests.support import first_line, free_udp_port, stop  # the repository's test helpers

REPO = Path(__file__).resolve().parents[1]


def peer(url: str) -> None:
    """A bare MAVLink 2 peer that answers every command, until its stdin closes."""
    conn = mavutil.mavlink_connection(url, source_system=1, source_component=1,
                                      dialect="ardupilotmega")
    stop = threading.Event()

    def wait_stdin() -> None:  # the bench closes our stdin to stop us
        sys.stdin.read()
        stop.set()

    threading.Thread(target=wait_stdin, daemon=True).start()
    print("ready", flush=True)
    t0 = time.monotonic()
    next_beat = next_position = 0.0
    while not stop.is_set():
        msg = conn.recv_msg()
        if msg is not None and msg.get_type() == "COMMAND_LONG":
            conn.mav.command_ack_send(msg.command, mavlink.MAV_RESULT_ACCEPTED, 0, 0,
                                      msg.get_srcSystem(), msg.get_srcComponent())
        now = time.monotonic()
        if now >= next_beat:
            conn.mav.heartbeat_send(mavlink.MAV_TYPE_SUBMARINE,
                                    mavlink.MAV_AUTOPILOT_ARDUPILOTMEGA,
                                    mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED
                                    | mavlink.MAV_MODE_FLAG_SAFETY_ARMED, 4,
                                    mavlink.MAV_STATE_ACTIVE)
            next_beat = now + 1.0
        if now >= next_position:
            conn.mav.local_position_ned_send(int((now - t0) * 1000), -6.0, -2.0, 0.3, 0, 0, 0)
            next_position = now + 0.1
        if msg is None:
            conn.select(0.005)
    conn.close()


def percentile(values: list[float], q: float) -> float:
    s = sorted(values)
    return s[min(len(s) - 1, int(round(q * (len(s) - 1))))]


def measure(argv: list[str], url: str, count: int, warmup: int) -> dict[str, float]:
    """Start the peer, then time ``count`` command round trips after ``warmup`` ones."""
    proc = subprocess.Popen(argv, cwd=REPO, stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                            text=True, env=dict(os.environ, PYTHONDONTWRITEBYTECODE="1"))
    try:
        if "ready" not in (first_line(proc, 30) or ""):
            raise RuntimeError(f"{argv[0]} did not start")
        with MavlinkVehicle(url, connect_timeout=10) as vehicle:
            if vehicle.lost:
                raise RuntimeError(vehicle.lost_reason)
            vehicle.ack_latencies.clear()
            for _ in range(warmup + count):
                result = vehicle.command(mavlink.MAV_CMD_REQUEST_MESSAGE,
                                         mavlink.MAVLINK_MSG_ID_HEARTBEAT, wait=2.0)
                if result is None:
                    raise RuntimeError("a command got no COMMAND_ACK within 2 s")
            ms = [s * 1e3 for s in vehicle.ack_latencies[warmup:]]
            retried = vehicle.commands_sent - vehicle.acks_received
    finally:
        if proc.stdin:
            proc.stdin.close()
        stop(proc)
    return {"median_ms": round(statistics.median(ms), 4), "p99_ms": round(percentile(ms, 0.99), 4),
            "max_ms": round(max(ms), 4), "unanswered": retried}


def bench(count: int, warmup: int, speed: float) -> dict[str, object]:
    port = free_udp_port()
    url = f"udpin:127.0.0.1:{port}"
    vehicle = measure([sys.executable, "-m", "app.mcl", "vehicle", "--mavlink",
                       f"udpout:127.0.0.1:{port}", "--speed", str(speed)], url, count, warmup)
    port = free_udp_port()
    url = f"udpin:127.0.0.1:{port}"
    echo = measure([sys.executable, __file__, "--peer", f"udpout:127.0.0.1:{port}"], url,
                   count, warmup)
    return {"count": count, "speed": speed, "vehicle": vehicle, "echo": echo,
            "ratio_median": round(vehicle["median_ms"] / echo["median_ms"], 2),
            "ratio_p99": round(vehicle["p99_ms"] / echo["p99_ms"], 2)}


def link_lost_delays(rounds: int) -> list[float]:
    """Wall seconds from the vehicle's death (SIGKILL) to Link.lost: the heartbeat's silence
    (the adapter's link timeout is 2 s; the target is within 3 s)."""
    delays = []
    for _ in range(rounds):
        port = free_udp_port()
        proc = subprocess.Popen([sys.executable, "-m", "app.mcl", "vehicle", "--mavlink",
                                 f"udpout:127.0.0.1:{port}", "--speed", "10"],
                                stdin=subprocess.DEVNULL, stdout=subprocess.PIPE,
                                stderr=subprocess.DEVNULL, text=True,
                                cwd=Path(__file__).resolve().parents[1])
        try:
            if "ready" not in (first_line(proc, 20) or ""):
                raise RuntimeError("the vehicle did not start")
            with MavlinkVehicle(f"udpin:127.0.0.1:{port}", connect_timeout=10) as vehicle:
                if vehicle.lost:
                    raise RuntimeError(vehicle.lost_reason)
                time.sleep(1.5)  # a running link: heartbeats flowing
                killed = time.monotonic()
                proc.kill()
                while not vehicle.lost and time.monotonic() - killed < 10:
                    vehicle.receive(vehicle.now() + 1.0)
                if vehicle.lost_at is None:
                    raise RuntimeError("no Link.lost within 10 s")
                delays.append(vehicle.lost_at - killed)
        finally:
            stop(proc)
    return delays


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=(__doc__ or "").split("\n")[0])
    p.add_argument("--peer", metavar="URL", help=argparse.SUPPRESS)
    p.add_argument("--count", type=int, default=1000)
    p.add_argument("--warmup", type=int, default=100)
    p.add_argument("--speed", type=float, default=100.0,
                   help="the simulated vehicle's speed (times wall time)")
    p.add_argument("--json", action="store_true")
    p.add_argument("--loss-rounds", type=int, default=5,
                   help="vehicles killed to time Link.lost (0: skip)")
    args = p.parse_args(argv)
    if args.peer:
        peer(args.peer)
        return 0
    r = bench(args.count, args.warmup, args.speed)
    if args.loss_rounds > 0:
        r["link_lost_s"] = link_lost_delays(args.loss_rounds)
    if args.json:
        print(json.dumps(r))
        return 0
    print(f"command -> COMMAND_ACK over MAVLink 2 on loopback UDP, {r['count']} commands "
          f"(MAV_CMD_REQUEST_MESSAGE)")
    for name, label in (("vehicle", f"vehicle x{args.speed:g}"), ("echo", "echo peer")):
        d = r[name]
        assert isinstance(d, dict)
        print(f"  {label:<13} median {d['median_ms']:.3f} ms  p99 {d['p99_ms']:.3f} ms  "
              f"max {d['max_ms']:.3f} ms  unanswered {d['unanswered']}")
    print(f"  ratio         median {r['ratio_median']}x  p99 {r['ratio_p99']}x")
    d = r.get("link_lost_s")
    if isinstance(d, list) and d:
        print(f"Link.lost after the vehicle is killed: median {statistics.median(d):.3f} s, "
              f"max {max(d):.3f} s over {len(d)} (target: within 3 s)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
