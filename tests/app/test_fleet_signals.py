"""Every exit of a fleet run is a safe exit for every vehicle (issue 23, docs/FLEET_RUN.md):
real signals sent to a real ``mcl run FLEET.mcl --realtime`` once both vehicles' logs show
their missions running. Each vehicle's log closes with its end record saying the signal,
every behaviour is off in every vehicle (the disables, then the ON STOP's own behaviours on
and off again), the channel record closes, and the process exits 128 + N (docs/EXIT.md); a
second signal halts the stop handlers, still switching everything off.

``--realtime`` paces the one clock at wall time, so that the signal comes mid-run; waits are
bounded generously and only fail a test that hangs.
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import time
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import pytest

from tests.support import BIN, MISSIONS, REPO, end

MCM = str(MISSIONS / "mcm.mcl")
RELAY = str(MISSIONS / "fleet_relay.mcl")
WAIT = 120.0  # s: the longest any wait here may take before the test fails (a hang)


@contextmanager
def fleet_run(tmp_path: Path, mission: str) -> Iterator[tuple[subprocess.Popen[bytes], Path]]:
    """``mcl run FLEET --realtime --log-dir tmp/logs``, its output in a file."""
    logs = tmp_path / "logs"
    out = open(tmp_path / "run.out", "wb")  # noqa: SIM115 - closed below
    env = dict(os.environ, PYTHONDONTWRITEBYTECODE="1", MCL_STATE_DIR=str(tmp_path / "state"))
    proc = subprocess.Popen([str(BIN / "mcl"), "run", mission, "--realtime", "--log-dir",
                             str(logs)], cwd=REPO, env=env, stdin=subprocess.DEVNULL,
                            stdout=out, stderr=subprocess.STDOUT)
    try:
        yield proc, logs
    finally:
        end(proc)  # type: ignore[arg-type]  # bytes or text: the same stop
        out.close()


def records(log: Path) -> list[dict[str, Any]]:
    """The log's complete lines, read while it is being written."""
    if not log.exists():
        return []
    return [json.loads(line) for line in log.read_text("utf-8").splitlines()
            if line.endswith("}")]


def output(logs: Path) -> str:
    path = logs.parent / "run.out"
    return path.read_text("utf-8", "replace")[-3000:] if path.exists() else ""


def wait_for(proc: subprocess.Popen[bytes], logs: Path, what: str,
             seen: Any) -> None:
    """Until ``seen()`` is true; fails if the run ends first or it takes past WAIT."""
    deadline = time.monotonic() + WAIT
    while time.monotonic() < deadline:
        if seen():
            return
        assert proc.poll() is None, f"mcl run ended before {what}: {output(logs)}"
        time.sleep(0.05)
    pytest.fail(f"not {what} within {WAIT:g} s: {output(logs)}")


def running(logs: Path, names: list[str]) -> bool:
    """Every vehicle's mission runs with a behaviour of its own on."""
    for name in names:
        recs = records(logs / f"{name}.jsonl")
        if not (any(r.get("status") == "running" for r in recs)
                and left_on(recs)):
            return False
    return True


def left_on(recs: list[dict[str, Any]]) -> set[str]:
    """What the logged actions leave on."""
    on: set[str] = set()
    for r in recs:
        if r["kind"] == "action" and r["action"] == "enable":
            on.add(r["behaviour"])
        elif r["kind"] == "action" and r["action"] == "disable":
            on.discard(r["behaviour"])
    return on


def finish(proc: subprocess.Popen[bytes], logs: Path) -> int:
    try:
        return proc.wait(timeout=WAIT)
    except subprocess.TimeoutExpired:
        end(proc)  # type: ignore[arg-type]
        pytest.fail(f"mcl run did not end within {WAIT:g} s: {output(logs)}")


def check_vehicle(log: Path, sig: int) -> dict[str, Any]:
    """The vehicle's log ends with its end record saying the signal, its mission was
    aborted, every behaviour it had on was disabled and the vehicle confirmed it; returns
    the end record."""
    recs = records(log)
    last = recs[-1]
    assert last["kind"] == "end", f"{log.name}: no end record: {recs[-3:]}"
    assert last["how"] == "signal" and last["exit"] == 128 + sig, last
    assert signal.Signals(sig).name in last["why"], last
    assert any(r["kind"] == "note" and "mission aborted" in r["note"] for r in recs), \
        f"{log.name}: the mission was not aborted through its net"
    enabled = {r["behaviour"] for r in recs if r["kind"] == "action"
               and r["action"] == "enable"}
    assert enabled, f"{log.name}: nothing was ever on: the test proves nothing"
    assert left_on(recs) == set(), f"{log.name}: left on: {left_on(recs)}"
    assert last["confirmed"].startswith("confirmed"), last["confirmed"]
    times = [r["t"] for r in recs[1:]]
    assert times == sorted(times), f"{log.name}: mission time went back"
    return last


def check_fleet(proc: subprocess.Popen[bytes], logs: Path, names: list[str], sig: int
                ) -> dict[str, dict[str, Any]]:
    code = finish(proc, logs)
    text = output(logs)
    assert code == 128 + sig, text
    assert "Traceback" not in text and "KeyboardInterrupt" not in text, text
    ends = {name: check_vehicle(logs / f"{name}.jsonl", sig) for name in names}
    channel = records(logs / "channels.jsonl")
    assert channel[-1]["kind"] == "end", channel[-2:]
    assert text.count("ended STOPPED") == len(names), text
    return ends


@pytest.mark.slow
@pytest.mark.parametrize(("mission", "names", "handlers", "sig"), [
    (MCM, ["asv", "uuv"], ["uuv"], signal.SIGINT),  # the asv has no ON STOP
    (RELAY, ["leader", "follower"], ["leader", "follower"], signal.SIGTERM),
], ids=["mcm-SIGINT", "relay-SIGTERM"])
def test_a_signal_stops_every_vehicle_through_its_stop_handler(
        tmp_path: Path, mission: str, names: list[str], handlers: list[str], sig: int) -> None:
    with fleet_run(tmp_path, mission) as (proc, logs):
        wait_for(proc, logs, "every vehicle running", lambda: running(logs, names))
        proc.send_signal(sig)
        ends = check_fleet(proc, logs, names, sig)
    for name, last in ends.items():  # ON STOP ran, and ended by itself
        if name in handlers:
            assert last["stop_handler"]["how"] == "ended ok", (name, last["stop_handler"])
        else:
            assert "stop_handler" not in last, (name, last)


@pytest.mark.slow
def test_a_second_signal_halts_the_stop_handlers_and_switches_them_off(tmp_path: Path
                                                                       ) -> None:
    names = ["leader", "follower"]
    leader = tmp_path / "logs" / "leader.jsonl"

    def surfacing() -> bool:  # the leader's ON STOP has sent its abort and is surfacing
        return any(r["kind"] == "action" and r["action"] == "send" for r in records(leader))

    with fleet_run(tmp_path, RELAY) as (proc, logs):
        wait_for(proc, logs, "every vehicle running", lambda: running(logs, names))
        proc.send_signal(signal.SIGINT)
        wait_for(proc, logs, "the leader's ON STOP running", surfacing)
        proc.send_signal(signal.SIGINT)
        ends = check_fleet(proc, logs, names, signal.SIGINT)
    handler = ends["leader"]["stop_handler"]
    assert handler["how"] == "halted", handler  # Surface takes 7 s: the 2nd signal cut it
    assert "Surface" in {r["behaviour"] for r in records(leader)
                         if r["kind"] == "action" and r["action"] == "disable"}
