"""Action -> event round trip through the Zenoh adapter, against bare Zenoh, on loopback.

    python bench/bench_zenoh.py [--count 2000] [--warmup 200] [--json]

Two processes: this one (the player side) and a tiny echo (the vehicle side, this file run
with ``--echo ENDPOINT``). The echo answers

- each action on ``mcl/bench/aal/action`` (validated with ActionMessage.from_json) with an
  event on ``mcl/bench/aal/event`` (EventMessage JSON), as the vehicle server does;
- each payload on ``bench/raw/ping`` with the same bytes on ``bench/raw/pong`` (bare Zenoh).

Adapter round trip: ``ZenohVehicle.send`` until ``ZenohVehicle.receive`` returns the event
(JSON encoding, validation both ways, the adapter's queue). Bare round trip: ``put`` until the
pong reaches a subscriber callback's queue in this process. Both use express publishers and the
same configuration (:func:`zenoh_config`); they are interleaved in one run, so that the ratio
is what the adapter adds. Target: adapter p99 < 2 ms.
"""

from __future__ import annotations

import argparse
import json
import os
import queue
import statistics
import subprocess
import sys
import threading
import time
from pathlib import Path
from typing import Any

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

import zenoh  # noqa: E402

from aal.messages import ActionMessage, EventMessage, InvalidMessage  # noqa: E402
from aal.zenoh import keys, zenoh_config  # noqa: E402
from vehicle_adapters.zenoh_link import ZenohVehicle  # noqa: E402

from tests.support import first_line, free_endpoint  # the repository's test helpers

NAME = "bench"
PING, PONG = "bench/raw/ping", "bench/raw/pong"
TARGET_P99_MS = 2.0


def echo(endpoint: str) -> None:
    """The vehicle side: answer actions with events and pings with pongs, until stdin closes."""
    k = keys(NAME)
    session = zenoh.open(zenoh_config(endpoint, listen=True))
    block = zenoh.CongestionControl.BLOCK
    events = session.declare_publisher(k["event"], congestion_control=block, express=True,
                                       priority=zenoh.Priority.INTERACTIVE_HIGH)
    pong = session.declare_publisher(PONG, congestion_control=block, express=True,
                                     priority=zenoh.Priority.INTERACTIVE_HIGH)
    clock = session.declare_publisher(k["clock"], express=True)
    behaviours = session.declare_publisher(f"{k['telemetry']}/behaviours")
    seq = iter(range(1 << 62))
    t0 = time.monotonic()
    runs: list[str] = []  # the players' runs, as a vehicle reports the one it takes

    def on_player(sample: zenoh.Sample) -> None:
        if sample.kind == zenoh.SampleKind.PUT:
            runs.append(str(sample.key_expr).rpartition("/")[2])

    def on_action(sample: zenoh.Sample) -> None:
        try:
            a = ActionMessage.from_json(sample.payload.to_bytes())
        except InvalidMessage:
            return
        events.put(EventMessage(next(seq), time.monotonic() - t0, a.behaviour, "ack",
                                {"seq": a.seq}).to_json())

    entities: list[Any] = [session.declare_subscriber(k["action"], on_action),
                session.declare_subscriber(PING, lambda s: pong.put(s.payload.to_bytes())),
                session.liveliness().declare_subscriber(f"{k['alive_player']}/*", on_player,
                                                        history=True),
                session.liveliness().declare_token(k["alive_vehicle"])]
    clock.put(json.dumps({"t": 0.0, "speed": 1.0, "running": True}))
    print("ready", flush=True)
    stop = threading.Event()

    def wait_stdin() -> None:  # the bench closes our stdin to stop us
        sys.stdin.read()
        stop.set()

    threading.Thread(target=wait_stdin, daemon=True).start()
    while not stop.wait(0.1):  # the clock and the run taken, as a vehicle would publish them
        clock.put(json.dumps({"t": time.monotonic() - t0, "speed": 1.0, "running": True}))
        if runs:
            behaviours.put(json.dumps({"run": runs[-1]}))
    for e in entities:
        e.undeclare()
    session.close()  # type: ignore[no-untyped-call]


def percentile(values: list[float], q: float) -> float:
    s = sorted(values)
    return s[min(len(s) - 1, int(round(q * (len(s) - 1))))]


def bench(count: int, warmup: int) -> dict[str, object]:
    endpoint = free_endpoint()
    proc = subprocess.Popen([sys.executable, __file__, "--echo", endpoint],
                            stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True,
                            env=dict(os.environ, PYTHONDONTWRITEBYTECODE="1"))
    raw = None
    try:
        if "ready" not in (first_line(proc, 20) or ""):
            raise RuntimeError("the echo did not start")
        pongs: queue.Queue[bytes] = queue.Queue()
        raw = zenoh.open(zenoh_config(endpoint, connect=True))
        ping = raw.declare_publisher(PING, congestion_control=zenoh.CongestionControl.BLOCK,
                                     express=True, priority=zenoh.Priority.INTERACTIVE_HIGH)
        sub = raw.declare_subscriber(PONG, lambda s: pongs.put(s.payload.to_bytes()))
        deadline = time.monotonic() + 5
        while not ping.matching_status and time.monotonic() < deadline:
            time.sleep(0.001)
        adapter_ms: list[float] = []
        bare_ms: list[float] = []
        with ZenohVehicle(endpoint, NAME) as vehicle:
            if vehicle.lost:
                raise RuntimeError(vehicle.lost_reason)
            for i in range(warmup + count):
                # adapter: one action out, its event back
                action = ActionMessage(i, vehicle.now(), "bench", "GoTo@1:1", "enable", "GoTo",
                                       {"x": 1.0, "y": 2.0, "z": 3.0, "yaw": 0.0,
                                        "tolerance": 0.5})
                start = time.perf_counter()
                vehicle.send(action)
                got: list[EventMessage] = []
                end_by = time.monotonic() + 2
                while not got and time.monotonic() < end_by:
                    got = vehicle.receive(vehicle.now() + 1.0)
                elapsed = time.perf_counter() - start
                if not got or got[0].data.get("seq") != i:
                    raise RuntimeError(f"round trip {i}: got {got}")
                # bare zenoh: the same size of payload out, back
                payload = action.to_json().encode()
                start2 = time.perf_counter()
                ping.put(payload)
                pongs.get(timeout=2)
                elapsed2 = time.perf_counter() - start2
                if i >= warmup:
                    adapter_ms.append(elapsed * 1e3)
                    bare_ms.append(elapsed2 * 1e3)
            dropped = vehicle.dropped
        sub.undeclare()  # type: ignore[no-untyped-call]
    finally:
        if raw is not None:
            raw.close()  # type: ignore[no-untyped-call]
        if proc.stdin:
            proc.stdin.close()
        try:
            proc.wait(timeout=5)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait(timeout=5)
    a50, a99 = statistics.median(adapter_ms), percentile(adapter_ms, 0.99)
    b50, b99 = statistics.median(bare_ms), percentile(bare_ms, 0.99)
    return {"count": count, "adapter_median_ms": round(a50, 4), "adapter_p99_ms": round(a99, 4),
            "adapter_max_ms": round(max(adapter_ms), 4),
            "bare_median_ms": round(b50, 4), "bare_p99_ms": round(b99, 4),
            "bare_max_ms": round(max(bare_ms), 4),
            "ratio_median": round(a50 / b50, 2), "ratio_p99": round(a99 / b99, 2),
            "dropped": dropped, "target_p99_ms": TARGET_P99_MS, "meets_target": a99 < TARGET_P99_MS}


def link_lost_delays(rounds: int) -> dict[str, list[float]]:
    """Wall seconds from the vehicle's end to Link.lost: killed (SIGKILL: its socket closes)
    and frozen (SIGSTOP: silent, noticed when the 1 s lease runs out)."""
    import signal

    delays: dict[str, list[float]] = {"killed": [], "frozen": []}
    for how in delays:
        for _ in range(rounds):
            endpoint = free_endpoint()
            proc = subprocess.Popen([sys.executable, "-m", "app.mcl", "vehicle", "--zenoh",
                                     endpoint, "--no-wait"], stdin=subprocess.DEVNULL,
                                    stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True,
                                    cwd=Path(__file__).resolve().parents[1])
            try:
                if "ready" not in (first_line(proc, 20) or ""):
                    raise RuntimeError("the vehicle did not start")
                with ZenohVehicle(endpoint, "auv") as vehicle:
                    if vehicle.lost:
                        raise RuntimeError(vehicle.lost_reason)
                    time.sleep(0.5)  # a running link: keep-alives flowing
                    ended = time.monotonic()
                    proc.send_signal(signal.SIGKILL if how == "killed" else signal.SIGSTOP)
                    while not vehicle.lost and time.monotonic() - ended < 10:
                        vehicle.receive(vehicle.now() + 1.0)
                    if vehicle.lost_at is None:
                        raise RuntimeError(f"no Link.lost within 10 s ({how})")
                    delays[how].append(vehicle.lost_at - ended)
            finally:
                proc.send_signal(signal.SIGCONT)
                proc.kill()
                proc.wait(timeout=5)
                if proc.stdout:
                    proc.stdout.close()
    return delays


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--echo", metavar="ENDPOINT", help=argparse.SUPPRESS)
    p.add_argument("--count", type=int, default=2000)
    p.add_argument("--warmup", type=int, default=200)
    p.add_argument("--json", action="store_true")
    p.add_argument("--loss-rounds", type=int, default=5,
                   help="vehicles killed and frozen to time Link.lost (0: skip)")
    args = p.parse_args(argv)
    if args.echo:
        echo(args.echo)
        return 0
    r = bench(args.count, args.warmup)
    if args.loss_rounds > 0:
        r["link_lost_s"] = link_lost_delays(args.loss_rounds)
    if args.json:
        print(json.dumps(r))
    else:
        print(f"action -> event round trip over Zenoh on loopback, {r['count']} messages")
        print(f"  adapter   median {r['adapter_median_ms']:.3f} ms  p99 {r['adapter_p99_ms']:.3f} ms"
              f"  max {r['adapter_max_ms']:.3f} ms")
        print(f"  bare      median {r['bare_median_ms']:.3f} ms  p99 {r['bare_p99_ms']:.3f} ms"
              f"  max {r['bare_max_ms']:.3f} ms")
        print(f"  ratio     median {r['ratio_median']}x  p99 {r['ratio_p99']}x")
        print(f"  target p99 < {TARGET_P99_MS} ms: {'met' if r['meets_target'] else 'NOT met'}")
        for how, d in dict(r.get("link_lost_s") or {}).items():
            print(f"Link.lost after the vehicle is {how}: median {statistics.median(d):.3f} s, "
                  f"max {max(d):.3f} s over {len(d)} (target: within the 1 s lease)")
    return 0 if r["meets_target"] else 1


if __name__ == "__main__":
    sys.exit(main())
