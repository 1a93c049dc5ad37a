"""Shared helpers: the repository's paths, compiling from text, running the real CLIs, and
subprocesses on loopback (free ports, started until ready, always stopped)."""

from __future__ import annotations

import os
import queue
import random
import socket
import subprocess
import sys
import threading
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import TYPE_CHECKING

import pytest

if TYPE_CHECKING:
    from petri.net import Net

REPO = Path(__file__).resolve().parents[1]
MISSIONS = REPO / "missions"


def single_missions() -> list[Path]:
    """The shipped single-vehicle missions, sorted (fleet files, FLEET ..., are not)."""
    # loaded here, not at the top: every test imports this module, few need the compiler
    from mcl.fleet import is_fleet

    return sorted(p for p in MISSIONS.glob("*.mcl") if not is_fleet(str(p)))


def shipped_nets() -> list[tuple[str, Net]]:
    """The net of every shipped mission and of every vehicle of every shipped fleet, each
    with its name (``dam_inspection.mcl``, ``mcm.mcl uuv``)."""
    # loaded here, not at the top: every test imports this module, few need the compiler
    from mcl.api import compile_file
    from mcl.fleet import compile_fleet_file, is_fleet

    out: list[tuple[str, Net]] = []
    for p in sorted(MISSIONS.glob("*.mcl")):
        if is_fleet(str(p)):
            fleet = compile_fleet_file(str(p))
            out += [(f"{p.name} {name}", c.net) for name, c in fleet.vehicles.items()]
        else:
            out.append((p.name, compile_file(str(p)).net))
    return out
SHARED = REPO.parent / "shared"
BIN = Path(sys.executable).parent


# -- wall-clock budgets ---------------------------------------------------------------------------
# The suite must hold on a loaded 2-core machine (other jobs, a CPU hog beside it): a wall-clock
# bound in a test is a budget against a hang, never a speed target (speed is measured in bench/).

def time_scale() -> float:
    """$MCL_TEST_TIME_SCALE (default 1): stretches every budget, e.g. 3 on a very busy machine."""
    try:
        scale = float(os.environ.get("MCL_TEST_TIME_SCALE", "1"))
    except ValueError:
        return 1.0
    return scale if scale >= 1.0 else 1.0


def budget(seconds: float) -> float:
    """The wall-clock budget of a step that takes ``seconds`` on an idle machine: ten times as
    long (a loaded 2-core machine runs a step several times slower), times :func:`time_scale`.
    For bounds that catch a hang or a lost wake-up, and for waits polled up to a deadline."""
    return 10.0 * seconds * time_scale()


# The Zenoh transport lease (1 s by default) of the processes the tests start, and of players
# made in process where a test passes it: a process starved for a second on a loaded machine
# must not look like a lost vehicle, except in the one test of the lease itself.
TOLERANT_LEASE_MS = round(budget(0.5) * 1000)


def subprocess_env(**extra: str) -> dict[str, str]:
    """This environment for a subprocess: no bytecode written, the tolerant Zenoh lease."""
    return dict(os.environ, PYTHONDONTWRITEBYTECODE="1",
                MCL_ZENOH_LEASE_MS=str(TOLERANT_LEASE_MS), **extra)


def cli(name: str, *args: str, timeout: float = budget(30), cwd: Path | None = None
        ) -> subprocess.CompletedProcess[str]:
    """Run one of the installed console scripts (mclc, mcl) as a real subprocess; ``timeout``
    catches a hang (the dam mission with its survey report takes 20-30 s of CPU)."""
    exe = BIN / name
    if not exe.exists():
        pytest.fail(f"{exe} is not installed: run 'make test' (it installs the project)")
    env = subprocess_env()
    return subprocess.run([str(exe), *args], capture_output=True, text=True, timeout=timeout,
                          cwd=cwd or REPO, env=env, stdin=subprocess.DEVNULL)


def write(tmp_path: Path, text: str, name: str = "m.mcl") -> Path:
    path = tmp_path / name
    path.write_text(text, encoding="utf-8")
    return path


# Generic blocks for testing templates, shipped with the package (mcl/tasks/generic.tasks).
GENERIC_TASKS = (REPO / "mcl" / "tasks" / "generic.tasks").read_text("utf-8")
# A task library whose task Fast enables GoTo with a parameter (speed) no vehicle takes: the
# run is refused before the mission starts, or the mission fails when it is enabled.
FAST_TASKS = ("behaviour GoTo drives x, y, z, yaw events reached, failed;\n"
              "task Fast(target: point) {\n"
              "    start:   enable GoTo(x = target.x, speed = 3);\n"
              "    ok:      GoTo.reached;\n"
              "    timeout: 1 min -> fail;\n"
              "    stop:    disable GoTo;\n"
              "}\n")


# -- subprocesses on loopback ---------------------------------------------------------------------

# Under pytest-xdist (``make test`` runs two workers) several processes pick ports at once. A
# port the kernel hands out for bind(0) lies in its ephemeral range, where another worker's
# outgoing connection (a Zenoh client, say) may take it before our subprocess binds it. So each
# worker draws from its own slice of PORTS, below the ephemeral range (32768-60999 on Linux), in
# turn from a random start (two test runs side by side rarely meet), skipping a port it cannot
# bind: no two workers of a run ever get the same port, and no worker gets one twice until it
# has gone round its slice.
PORTS = range(20000, 32768)


def port_slice(worker: str | None = None, workers: str | None = None) -> range:
    """This worker's share of :data:`PORTS`: worker ``gwN`` of ``workers`` (by default from
    $PYTEST_XDIST_WORKER and $PYTEST_XDIST_WORKER_COUNT; without xdist, all of it)."""
    worker = os.environ.get("PYTEST_XDIST_WORKER", "gw0") if worker is None else worker
    workers = os.environ.get("PYTEST_XDIST_WORKER_COUNT", "1") if workers is None else workers
    try:
        index, count = int(worker.removeprefix("gw")), max(1, int(workers))
    except ValueError:
        index, count = 0, 1
    size = len(PORTS) // count
    start = PORTS.start + (index % count) * size
    return range(start, start + size)


class PortDrawer:
    """Ports of one slice in turn, from a random start, each checked free by binding it."""

    def __init__(self, ports: range) -> None:
        self.ports = ports
        # a generator of its own, seeded from the system: Hypothesis seeds the global one
        self.at = random.Random().randrange(len(ports))

    def draw(self, kind: socket.SocketKind) -> int:
        """The next port of the slice that a ``kind`` socket can bind on 127.0.0.1 now."""
        for _ in range(len(self.ports)):
            port = self.ports[self.at]
            self.at = (self.at + 1) % len(self.ports)
            with socket.socket(socket.AF_INET, kind) as s:
                try:
                    s.bind(("127.0.0.1", port))
                except OSError:
                    continue
            return port
        raise RuntimeError(f"no free port in {self.ports.start}-{self.ports.stop - 1}")


DRAWER = PortDrawer(port_slice())


def free_tcp_port() -> int:
    """A TCP port on 127.0.0.1, free a moment ago, that no other worker of this run gets."""
    return DRAWER.draw(socket.SOCK_STREAM)


def free_udp_port() -> int:
    """A UDP port on 127.0.0.1, free a moment ago, that no other worker of this run gets."""
    return DRAWER.draw(socket.SOCK_DGRAM)


def free_endpoint(scheme: str = "tcp") -> str:
    """A Zenoh endpoint on a free loopback port, e.g. ``tcp/127.0.0.1:PORT``."""
    return f"{scheme}/127.0.0.1:{free_tcp_port()}"


def first_line(proc: subprocess.Popen[str], timeout: float) -> str | None:
    """The first line of the process's stdout ('' if it ended first), read on a thread;
    None if there is none within ``timeout`` s."""
    lines: queue.Queue[str] = queue.Queue()
    threading.Thread(target=lambda: lines.put(proc.stdout.readline()),  # type: ignore
                     daemon=True).start()
    try:
        return lines.get(timeout=timeout)
    except queue.Empty:
        return None


def end(proc: subprocess.Popen[str]) -> None:
    """Terminate the process, wait 5 s, kill it, wait 5 s; its pipes are left open."""
    if proc.poll() is None:
        proc.terminate()
        try:
            proc.wait(timeout=5)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait(timeout=5)


def stop(proc: subprocess.Popen[str]) -> None:
    """:func:`end` the process, then close its stdout and stderr."""
    end(proc)
    for stream in (proc.stdout, proc.stderr):
        if stream:
            stream.close()


def _stderr(proc: subprocess.Popen[str], grace: float) -> str:
    """What the process wrote on stderr, once it has ended (on its own within ``grace`` s, or
    ended); read on a thread, for at most 5 s."""
    try:
        proc.wait(timeout=grace)
    except subprocess.TimeoutExpired:
        end(proc)
    got: list[str] = []
    reader = threading.Thread(target=lambda: got.append(proc.stderr.read()),  # type: ignore
                              daemon=True)
    reader.start()
    reader.join(5)
    return got[0][-2000:] if got else "(not readable within 5 s)"


@contextmanager
def started(args: list[str], *, ready: str | None = "ready", timeout: float = budget(6),
            env: dict[str, str] | None = None, cwd: Path | str = REPO
            ) -> Iterator[subprocess.Popen[str]]:
    """``args`` as a subprocess (stdin closed, stdout and stderr piped, text), stopped on exit.

    With ``ready``, yields once the first line of stdout has come (within ``timeout`` s) and
    contains it (``""``: any line), else fails the test with the process's stderr; with None,
    yields at once. ``env`` defaults to :func:`subprocess_env`."""
    if env is None:
        env = subprocess_env()
    proc = subprocess.Popen(args, cwd=cwd, env=env, stdin=subprocess.DEVNULL,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        if ready is not None:
            name = " ".join(Path(a).name if i == 0 else a for i, a in enumerate(args[:3]))
            line = first_line(proc, timeout)
            if line is None:
                pytest.fail(f"{name}: no line within {timeout:g} s; stderr: {_stderr(proc, 0)}")
            if not line or ready not in line:
                err = _stderr(proc, 5)
                said = f"first line {line!r}" if line else "stdout ended before any line"
                pytest.fail(f"{name}: {said}, expected one with {ready!r} "
                            f"(exit status {proc.returncode}); stderr: {err}")
        yield proc
    finally:
        stop(proc)
