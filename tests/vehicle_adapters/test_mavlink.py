"""The MAVLink adapter with real processes on loopback UDP.

The vehicle is ``mcl vehicle --mavlink udpout:127.0.0.1:PORT`` (the simulated stack served as
an ArduSub-like vehicle) in a subprocess; the player is ``mcl run ... --vehicle
mavlink:udpin:127.0.0.1:PORT`` in a subprocess, or :class:`MavlinkVehicle` here when a test
must time what the adapter sees. MAVProxy, when used, is the real ground-station router.
Every process is stopped in a ``finally``; every wait is bounded; tests synchronise on lines
and messages, not on sleeps.

The *task sequence* of a run is the ordered list of its action records as
``(task, action, behaviour)``, e.g. ``("GoTo@34:9", "enable", "GoTo")``: which task calls
started and stopped which behaviours, in which order. A run over MAVLink must end with the same
status and the same task sequence as the same mission in process.
"""

from __future__ import annotations

import json
import os
import queue
import re
import socket
import subprocess
import threading
import time
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import pytest

from mcl.api import compile_file
from petri.execution.player import Player, Record
from petri.execution.runner import run
from vehicle.control.stack import IctineuStack, StackConfig
from vehicle_adapters.inprocess import InProcess
from vehicle_adapters.mavlink.link import MODES, MavlinkVehicle, mavutil
from pymavlink.dialects.v20 import ardupilotmega as mavlink  # noqa: I001  (MAVLink 2 is set)

from tests.dam_runs import DamRuns
from tests.in_process import mcl_in_process
from tests.support import BIN, MISSIONS, REPO, budget, end, free_udp_port, started, stop

pytestmark = pytest.mark.slow  # real vehicle processes over MAVLink: not in make test-quick

DAM = str(MISSIONS / "dam_inspection.mcl")
SPEED = 100.0  # the dam mission lasts ~1200 s of simulated time: ~15 s of wall time here
SEED = 1
MAVPROXY = BIN / "mavproxy.py"


def env(tmp_path: Path) -> dict[str, str]:
    """The children's environment: signing timestamps kept under tmp_path, no key inherited."""
    e = dict(os.environ, PYTHONDONTWRITEBYTECODE="1", MCL_STATE_DIR=str(tmp_path / "state"))
    e.pop("MCL_MAVLINK_KEY", None)
    return e


class Lines:
    """A process's stdout read line by line on a thread, so that waits can be bounded."""

    def __init__(self, proc: subprocess.Popen[str]):
        self.queue: queue.Queue[str] = queue.Queue()
        self.seen: list[str] = []
        threading.Thread(target=self._read, args=(proc,), daemon=True).start()

    def _read(self, proc: subprocess.Popen[str]) -> None:
        assert proc.stdout is not None
        try:
            for line in proc.stdout:
                self.queue.put(line)
        except (OSError, ValueError):  # the pipe was closed under us (the process stopped)
            pass
        self.queue.put("")  # end of output

    def _next(self, deadline: float) -> str | None:
        """The next line before the deadline, kept in ``seen``; None at the deadline or at the
        end of the output."""
        try:
            line = self.queue.get(timeout=max(0.01, deadline - time.monotonic()))
        except queue.Empty:
            return None
        if line == "":
            return None
        self.seen.append(line)
        return line

    def wait_for(self, text: str, timeout: float) -> str:
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline and (line := self._next(deadline)) is not None:
            if text in line:
                return line
        pytest.fail(f"no line with {text!r} within {timeout:g} s; got {self.seen[-10:]}")

    def drain(self, timeout: float) -> None:
        """Keep what the process still says until it ends (bounded)."""
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline and self._next(deadline) is not None:
            pass


@contextmanager
def vehicle_process(port: int, tmp_path: Path, *extra: str, speed: float = SPEED
                    ) -> Iterator[tuple[subprocess.Popen[str], Lines]]:
    """``mcl vehicle --mavlink udpout:127.0.0.1:PORT`` until it says it is ready."""
    with started([str(BIN / "mcl"), "vehicle", "--mavlink", f"udpout:127.0.0.1:{port}",
                  "--speed", str(speed), "--seed", str(SEED), *extra],
                 ready=None, env=env(tmp_path)) as proc:
        lines = Lines(proc)
        try:
            lines.wait_for("ready", budget(3))
            yield proc, lines
        finally:
            end(proc)
            lines.drain(5)  # the vehicle's summary at exit


@contextmanager
def mavproxy(master_port: int, out_port: int, tmp_path: Path) -> Iterator[None]:
    """MAVProxy routing between the vehicle (master) and the player (out), headless."""
    if not MAVPROXY.exists():
        pytest.fail(f"{MAVPROXY} is not installed: make test installs it (pip install "
                    "--no-deps MAVProxy, see the Makefile)")
    proc = subprocess.Popen(
        [str(MAVPROXY), f"--master=udpin:127.0.0.1:{master_port}",
         f"--out=udpout:127.0.0.1:{out_port}", "--daemon", "--non-interactive", "--no-state",
         "--default-modules=", "--mav20"],
        cwd=tmp_path, env=env(tmp_path), stdin=subprocess.DEVNULL, stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT, text=True)
    try:
        Lines(proc).wait_for("Waiting for heartbeat", 30)  # listening on the master port
        yield
    finally:
        stop(proc)


def mcl_run(port: int, tmp_path: Path, *extra: str) -> subprocess.Popen[str]:
    return subprocess.Popen(
        [str(BIN / "mcl"), "run", DAM, "--vehicle", f"mavlink:udpin:127.0.0.1:{port}",
         "--log", str(tmp_path / "run.jsonl"), *extra],
        cwd=REPO, env=env(tmp_path), stdin=subprocess.DEVNULL, stdout=subprocess.PIPE,
        stderr=subprocess.PIPE, text=True)


def finish(proc: subprocess.Popen[str], timeout: float) -> tuple[int, str, str]:
    try:
        out, err = proc.communicate(timeout=timeout)
    except subprocess.TimeoutExpired:
        end(proc)  # pipes left open: what it said is in the message
        out, err = proc.communicate()
        pytest.fail(f"mcl run did not end within {timeout:g} s: {out[-2000:]} {err[-2000:]}")
    return proc.returncode, out, err


def task_sequence(records: list[dict[str, Any]]) -> list[tuple[str, str, str]]:
    return [(r["task"], r["action"], r["behaviour"]) for r in records if r["kind"] == "action"]


def transitions(records: list[dict[str, Any]]) -> list[str]:
    """The event and timer transitions fired, in order (immediate ones left out)."""
    return [r["cause"] for r in records if r["kind"] == "fire" and r["cause"] != "immediate"]


def read_log(path: Path) -> list[dict[str, Any]]:
    return [json.loads(line) for line in path.read_text("utf-8").splitlines()[1:]]


def reference(faults: list[tuple[str, float]]) -> dict[str, Any]:
    """The dam mission on the same simulated vehicle, in process: status and sequences."""
    compiled = compile_file(DAM, require_values=True)
    player = Player(compiled.net)
    records: list[Record] = []
    player.observers.append(records.append)
    with InProcess(IctineuStack(StackConfig(seed=SEED, faults=faults))) as vehicle:
        outcome = run(player, vehicle, "dam_inspection")
    return sequences(outcome.status, records)


def sequences(status: str, records: list[Record]) -> dict[str, Any]:
    """A run's status, task sequence and transitions, of its records."""
    flat = [{"kind": r.kind, **r.data} for r in records]
    return {"status": status, "tasks": task_sequence(flat), "transitions": transitions(flat)}


@pytest.fixture(scope="module")
def in_process(dam_runs: DamRuns) -> dict[str, Any]:
    """reference([]): tests/dam_runs.py's run of the dam mission with the vehicle's seed, made
    once per test run for this file, test_zenoh.py and the stack's tests."""
    assert SEED == 1  # the seed of dam_runs["dam"]
    dam = dam_runs["dam"]
    return sequences(dam.outcome.status, dam.records)


def check_same_as_in_process(code: int, out: str, err: str, log: Path,
                             in_process: dict[str, Any]) -> list[dict[str, Any]]:
    assert in_process["status"] == "ok"
    assert code == 0, f"{out[-2000:]}\n{err[-2000:]}"
    assert "mission dam_inspection ended OK" in out
    records = read_log(log)
    statuses = [r["status"] for r in records if r["kind"] == "status"]
    assert statuses[-1] == "ok"
    assert task_sequence(records) == in_process["tasks"]
    assert transitions(records) == in_process["transitions"]
    replay = subprocess.run([str(BIN / "mcl"), "replay", str(log), DAM], capture_output=True,
                            text=True, timeout=budget(6), cwd=REPO)
    assert replay.returncode == 0, replay.stdout + replay.stderr
    return records


def test_dam_mission_over_mavlink_matches_in_process(tmp_path: Path,
                                                     in_process: dict[str, Any]) -> None:
    port = free_udp_port()
    with vehicle_process(port, tmp_path) as (vehicle, _):
        player = mcl_run(port, tmp_path)
        try:
            code, out, err = finish(player, 120)
        finally:
            stop(player)
        assert vehicle.poll() is None, "the vehicle died"
    check_same_as_in_process(code, out, err, tmp_path / "run.jsonl", in_process)
    assert in_process["transitions"] == [
        "GoTo.reached", "AchieveHeadDist.achieved", "WallInspection.done", "GoTo.reached"]


def test_leak_alarm_surfaces_as_in_process(tmp_path: Path) -> None:
    """A leak 100 s in: STATUSTEXT "Leak Detected" -> Alarms.leak, the CATCH -> SURFACE mode ->
    Surface.surfaced, and the mission ends as in process."""
    expected = reference([("leak", 100.0)])
    assert expected["transitions"] == ["GoTo.reached", "AchieveHeadDist.achieved",
                                       "Alarms.leak", "Surface.surfaced"]
    port = free_udp_port()
    with vehicle_process(port, tmp_path, "--inject", "leak@100"):
        player = mcl_run(port, tmp_path)
        try:
            code, out, err = finish(player, 60)
        finally:
            stop(player)
    check_same_as_in_process(code, out, err, tmp_path / "run.jsonl", expected)


def test_dam_mission_through_mavproxy_with_signing(tmp_path: Path,
                                                   in_process: dict[str, Any]) -> None:
    key = tmp_path / "key"
    key.write_text("a passphrase shared by the ground station and the vehicle\n")
    master, out_port = free_udp_port(), free_udp_port()
    signed = ("--signing-key", str(key), "--require-signing")
    with mavproxy(master, out_port, tmp_path), \
            vehicle_process(master, tmp_path, *signed) as (vehicle, said):
        player = mcl_run(out_port, tmp_path, *signed)
        try:
            code, out, err = finish(player, 150)
        finally:
            stop(player)
        assert vehicle.poll() is None, "the vehicle died"
    check_same_as_in_process(code, out, err, tmp_path / "run.jsonl", in_process)
    # the vehicle's count at exit: the player's messages all signed, MAVProxy's own unsigned
    # HEARTBEATs rejected
    counts = [line for line in said.seen if "signing:" in line]
    assert counts, said.seen
    m = re.search(r"(\d+) signed accepted, (\d+) unsigned accepted, (\d+) unsigned rejected",
                  counts[0])
    assert m is not None, counts
    signed_ok, unsigned_ok, unsigned_rejected = map(int, m.groups())
    assert signed_ok > 1000 and unsigned_ok == 0 and unsigned_rejected > 0, counts
    assert list((tmp_path / "state").glob("mavlink-signing-player-*")), \
        "the player's signing timestamp was not saved"


def test_vehicle_killed_gives_link_lost_within_3_s_and_fail(tmp_path: Path) -> None:
    compiled = compile_file(DAM, require_values=True)
    port = free_udp_port()
    killed: dict[str, float] = {}
    with vehicle_process(port, tmp_path) as (proc, _):
        player = Player(compiled.net)
        records: list[Record] = []
        player.observers.append(records.append)

        def kill_on_reached(record: Record) -> None:
            if record.kind == "event" and record.data["event"] == "GoTo.reached" \
                    and not killed:
                proc.kill()  # SIGKILL: no goodbye from the vehicle
                killed["at"] = time.monotonic()

        player.observers.append(kill_on_reached)
        start = time.monotonic()
        with MavlinkVehicle(f"udpin:127.0.0.1:{port}") as vehicle:
            outcome = run(player, vehicle, "dam_inspection", max_time=3000)
        wall = time.monotonic() - start
    assert killed, "the mission never reached GoTo.reached"
    assert vehicle.lost and vehicle.lost_at is not None
    # three missed heartbeats (1 s apart) on an idle machine; slack for a loaded one
    assert vehicle.lost_at - killed["at"] < 3.0 + budget(0.5), "Link.lost came late"
    events = [r.data["event"] for r in records if r.kind == "event"]
    assert events[-1] == "Link.lost"
    assert outcome.status == "fail", outcome
    assert wall < budget(10)


@pytest.mark.slow
def test_the_adapter_tells_the_surveys_progress(tmp_path: Path) -> None:
    """Issue 25: the behaviours the MAVLink adapter runs tell their progress to the mission
    status: the survey's waypoint k of 82 and the path to go, going down."""
    from petri.execution.status import MissionStatus

    compiled = compile_file(DAM, require_values=True)
    port = free_udp_port()
    published: list[dict[str, Any]] = []

    def surveyed() -> str | None:  # stop once the survey has passed its third waypoint
        seen = [r["progress"] for s in published for r in s["running"]
                if r["task"] == "WallInspect@39:13" and "progress" in r]
        return "seen" if seen and seen[-1]["waypoint"] >= 3 else None

    with vehicle_process(port, tmp_path) as _:
        player = Player(compiled.net)
        with MavlinkVehicle(f"udpin:127.0.0.1:{port}") as vehicle:
            status = MissionStatus(player, "dam_inspection", "r", published.append,
                                   progress=vehicle.progress, every=5.0)
            player.observers.append(status)
            run(player, vehicle, "dam_inspection", max_time=600, stop=surveyed,
                rounds=[status.tick])
    survey = [r["progress"] for s in published for r in s["running"]
              if r["task"] == "WallInspect@39:13" and "progress" in r]
    assert survey and survey[-1]["waypoint"] >= 3 and {p["of"] for p in survey} == {82}
    to_go = [p["to_go"] for p in survey]
    assert to_go[0] > to_go[-1] and 100 < to_go[0] < 160


def test_vehicle_surfaces_when_the_player_goes_away(tmp_path: Path) -> None:
    port = free_udp_port()
    with vehicle_process(port, tmp_path, "--gcs-timeout", "1.5", "--pilot-timeout", "1.5",
                         speed=20) as (vehicle, _):
        player = mcl_run(port, tmp_path)
        try:
            Lines(player).wait_for("GoTo.reached", budget(6))  # armed, GUIDED, on its way
        finally:
            player.kill()  # no goodbye, no disarm
            player.wait(timeout=5)
            stop(player)
        # an independent listener takes the player's port: it sends nothing, so the vehicle's
        # failsafes still see no ground station and no pilot
        listener = mavutil.mavlink_connection(f"udpin:127.0.0.1:{port}", source_system=254,
                                              dialect="ardupilotmega")
        try:
            seen: dict[str, Any] = {"texts": []}
            deadline = time.monotonic() + budget(1.5)
            while time.monotonic() < deadline and seen.get("mode") != MODES["SURFACE"]:
                msg = listener.recv_match(type=["HEARTBEAT", "STATUSTEXT"], blocking=True,
                                          timeout=0.5)
                if msg is None or msg.get_srcSystem() != 1:
                    continue
                if msg.get_type() == "HEARTBEAT":
                    seen["mode"] = msg.custom_mode
                else:
                    seen["texts"].append(msg.text)
        finally:
            listener.close()
        assert vehicle.poll() is None, "the vehicle died"
    assert seen.get("mode") == MODES["SURFACE"], seen
    # said before the switch; at least the pilot-input one comes after the listener is there
    assert any("Lost manual control" in t or "heartbeat lost" in t for t in seen["texts"]), seen


@pytest.mark.parametrize("vehicle_key, counter", [
    (None, "rejected_unsigned"),  # an unsigned vehicle, a player that requires signing
    ("another key", "rejected_bad"),  # both sign, with different keys
])
def test_vehicle_without_the_key_is_rejected_and_counted(tmp_path: Path, vehicle_key: str | None,
                                                         counter: str) -> None:
    extra: tuple[str, ...] = ()
    if vehicle_key is not None:
        (tmp_path / "vehicle.key").write_text(vehicle_key)
        extra = ("--signing-key", str(tmp_path / "vehicle.key"), "--require-signing")
    port = free_udp_port()
    with vehicle_process(port, tmp_path, *extra):
        with MavlinkVehicle(f"udpin:127.0.0.1:{port}", signing_key=bytes(range(32)),
                            require_signing=True, connect_timeout=budget(0.3),
                            timestamp_file=tmp_path / "ts") as vehicle:
            events = vehicle.receive(vehicle.now() + 1.0)
    assert [e.event for e in events] == ["Link.lost"]
    assert vehicle.signing is not None and getattr(vehicle.signing, counter) > 0
    assert vehicle.acks_received == 0
    assert (tmp_path / "ts").exists()


def test_unsigned_player_is_refused_by_a_vehicle_that_requires_signing(tmp_path: Path) -> None:
    (tmp_path / "key").write_text("the vehicle's passphrase")
    port = free_udp_port()
    with vehicle_process(port, tmp_path, "--signing-key", str(tmp_path / "key"),
                         "--require-signing"):
        with MavlinkVehicle(f"udpin:127.0.0.1:{port}", connect_timeout=3) as vehicle:
            events = vehicle.receive(vehicle.now() + 1.0)
    assert [e.event for e in events] == ["Link.lost"]
    assert "refused GUIDED mode (no answer)" in vehicle.lost_reason
    assert "--signing-key" in vehicle.lost_reason
    assert vehicle.acks_received == 0 and vehicle.commands_sent > 0


def test_vehicle_taken_over_gives_link_lost(tmp_path: Path) -> None:
    """A mode change the adapter did not ask for (another ground station, or the vehicle's own
    failsafe) means the mission no longer drives the vehicle: Link.lost, saying so. Here the
    SURFACE order is sent around the adapter's own bookkeeping, as another station would."""
    port = free_udp_port()
    with vehicle_process(port, tmp_path):
        with MavlinkVehicle(f"udpin:127.0.0.1:{port}", connect_timeout=10) as vehicle:
            assert not vehicle.lost, vehicle.lost_reason
            assert vehicle.command(mavutil.mavlink.MAV_CMD_DO_SET_MODE,
                                   mavutil.mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED,
                                   MODES["SURFACE"], wait=5) == \
                mavutil.mavlink.MAV_RESULT_ACCEPTED
            events = []
            deadline = time.monotonic() + budget(1.0)
            while not events and time.monotonic() < deadline:
                events = vehicle.receive(vehicle.now() + 1.0)
    assert [e.event for e in events] == ["Link.lost"], vehicle.lost_reason
    assert "the vehicle took over: GUIDED -> SURFACE" in vehicle.lost_reason


def test_no_vehicle_gives_link_lost_without_hanging(tmp_path: Path) -> None:
    port = free_udp_port()  # nobody sends there
    start = time.monotonic()
    with MavlinkVehicle(f"udpin:127.0.0.1:{port}", connect_timeout=0.5) as vehicle:
        events = vehicle.receive(vehicle.now() + 1.0)
    assert time.monotonic() - start < 0.5 + budget(1.0)  # the timeout, not a hang
    assert [e.event for e in events] == ["Link.lost"]
    assert vehicle.lost and "no HEARTBEAT" in vehicle.lost_reason


@pytest.mark.parametrize("args, message", [
    (["--vehicle", "mavlink:udpin:nowhere"], "not a MAVLink URL"),
    (["--vehicle", "mavlink:serial0:127.0.0.1:14550"], "not a MAVLink URL"),
    (["--vehicle", "mavlink:udpin:127.0.0.1:70000"], "port 70000 is not in 1..65535"),
    (["--vehicle", "mavlink:", "--signing-key", "/nonexistent/key"], "no such signing key"),
    (["--vehicle", "mavlink:", "--require-signing"], "--require-signing needs a key"),
])
def test_bad_input_exits_2_with_a_clear_message(tmp_path: Path, args: list[str],
                                                message: str, monkeypatch: pytest.MonkeyPatch
                                                ) -> None:
    for name, value in env(tmp_path).items():  # the environment of the processes above
        monkeypatch.setenv(name, value)
    monkeypatch.delenv("MCL_MAVLINK_KEY", raising=False)
    result = mcl_in_process("run", DAM, *args, "--log", str(tmp_path / "run.jsonl"))
    assert result.returncode == 2, result.stdout + result.stderr
    assert message in result.stderr
    assert "Traceback" not in result.stderr


def test_port_in_use_exits_2(tmp_path: Path) -> None:
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as taken:
        taken.bind(("127.0.0.1", 0))
        port = taken.getsockname()[1]
        result = subprocess.run([str(BIN / "mcl"), "run", DAM, "--vehicle",
                                 f"mavlink:udpin:127.0.0.1:{port}", "--log",
                                 str(tmp_path / "run.jsonl")], capture_output=True, text=True,
                                timeout=budget(6), cwd=REPO, env=env(tmp_path),
                                stdin=subprocess.DEVNULL)
    assert result.returncode == 2, result.stdout + result.stderr
    assert "cannot open it" in result.stderr and "Traceback" not in result.stderr


def test_constants_follow_ardusub() -> None:
    assert MODES["GUIDED"] == 4 and MODES["SURFACE"] == 9 and MODES["MANUAL"] == 19
    assert mavlink.MAV_COMP_ID_MISSIONPLANNER == 190
