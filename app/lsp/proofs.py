"""The proofs behind the editor: mclc's verification of a mission, debounced, in a process of
its own, cancellable and bounded, so that typing never waits for a proof.

A change restarts the wait (:data:`PROOF_DELAY` of quiet); then the mission's text is verified
in a child process forked from a server that has the pipeline loaded (multiprocessing's
``forkserver``), by the same call as ``mclc`` (mcl.analysis.verification.verify_mission, the
explicit route's limits of markings and memory, the structural route beyond them); with a
vehicle named (``mcl lsp --vehicle sim``), the mission is also checked against what it
declares, as ``mcl run`` does before the first action (mission/capabilities.py). A newer
change, a closed document or :data:`PROOF_SECONDS` of proof end the child at once
(``terminate``): a proof never runs on for a text nobody sees.

A fleet (a file whose top level is ``FLEET``) is proved as ``mclc`` proves it: each vehicle's
mission by the same call as a single mission's (its receptions as events of its
environment), then the fleet's own properties (mcl.analysis.fleet_verification.verify_fleet,
``auto``) within :data:`FLEET_MAX_MARKINGS` joint markings: beyond them the compositional
route, so that a fleet's proof stays within seconds.
"""

from __future__ import annotations

import asyncio
import multiprocessing
from collections.abc import Callable
from dataclasses import dataclass, field
from multiprocessing.connection import Connection
from typing import Any

from aal.messages import Declaration
from behaviours import capabilities
from diagnostics import Diagnostic, MclError, Source
from mcl.analysis.fleet_verification import verify_fleet
from mcl.analysis.verification import MAX_BYTES, MAX_MARKINGS, verify_mission
from mcl.api import Compiled, compile_source
from mcl.fleet import compile_fleet_source, is_fleet
from mission.capabilities import check_capabilities

PROOF_DELAY = 0.4  # seconds of quiet after a change before its proof starts
PROOF_SECONDS = 120.0  # a proof still running after this long is stopped
POLL = 0.05  # seconds between looks at a running proof
# A fleet's product explored within this many joint markings (about 10 s here), else the
# compositional route (mclc --max-markings 500000 proves the fleet's own properties alike)
FLEET_MAX_MARKINGS = 500_000

# The vehicles a mission can be checked against in the editor: their declarations.
VEHICLES: dict[str, Callable[[str], Declaration]] = {
    "sim": capabilities.simulated,  # mcl run's default vehicle: every registered behaviour
    "ictineu": capabilities.ictineu,  # the paper's stack: its seven behaviours
}


@dataclass(frozen=True)
class Outcome:
    """What a proof reports. ``kind``: "verified" (``verification``: mclc's verdict as its
    JSON, ``Verdict.to_json()``; ``lacks``: what the vehicle does not have), "invalid" (a
    text the pipeline rejects: its errors are shown already) or "stopped" (``why``). For a
    fleet, ``vehicles``: each vehicle's verdict (as ``verification``), and ``fleet``: the
    fleet's (``FleetVerdict.to_json()``, with ``channel_places``: each channel's
    ``[line, col]``, where its steps of a counterexample are shown)."""

    kind: str
    verification: dict[str, Any] | None = None
    lacks: tuple[Diagnostic, ...] = ()
    why: str = ""
    vehicles: dict[str, dict[str, Any]] = field(default_factory=dict)
    fleet: dict[str, Any] | None = None


Report = Callable[[str, int | None, Outcome], None]  # (uri, version, outcome)


def prove(path: str, text: str, vehicle: str | None = None, max_markings: int = MAX_MARKINGS,
          max_bytes: int = MAX_BYTES, fleet_markings: int = FLEET_MAX_MARKINGS) -> Outcome:
    """mclc's verdict on the mission or fleet ``text`` (at ``path``), and what ``vehicle`` (a
    name of :data:`VEHICLES`) lacks to run it (a fleet's product: within
    ``fleet_markings``)."""
    source = Source(path, text)
    if is_fleet(source):
        return prove_fleet(source, vehicle, max_markings, max_bytes, fleet_markings)
    try:
        compiled = compile_source(source)
    except MclError:
        return Outcome("invalid")
    lacks = lacking(compiled, vehicle)
    verdict = verify_mission(compiled, "auto", max_markings=max_markings, max_bytes=max_bytes)
    return Outcome("verified", verdict.to_json(), lacks)


def prove_fleet(source: Source, vehicle: str | None, max_markings: int, max_bytes: int,
                fleet_markings: int) -> Outcome:
    """A fleet proved as ``mclc`` proves it (the module's doc)."""
    try:
        fleet = compile_fleet_source(source, require_values=False)
    except MclError:
        return Outcome("invalid")
    lacks: tuple[Diagnostic, ...] = ()
    vehicles = {}
    for name, compiled in fleet.vehicles.items():
        lacks += lacking(compiled, vehicle, tuple(fleet.channels))
        vehicles[name] = verify_mission(compiled, "auto", max_markings=max_markings,
                                        max_bytes=max_bytes).to_json()
    verdict = verify_fleet(fleet, "auto", max_markings=min(max_markings, fleet_markings),
                           max_bytes=max_bytes).to_json()
    verdict["channel_places"] = {c.name: [c.origin.line, c.origin.col]
                                 for c in fleet.channels.values()}
    return Outcome("verified", lacks=lacks, vehicles=vehicles, fleet=verdict)


def lacking(compiled: Compiled, vehicle: str | None,
            channels: tuple[str, ...] = ()) -> tuple[Diagnostic, ...]:
    """What ``vehicle`` (a name of :data:`VEHICLES`, or None: nothing checked) lacks to run
    the mission; a fleet's ``channels`` carry its Send and Receive, not the vehicle."""
    if vehicle is None:
        return ()
    try:
        check_capabilities(compiled, VEHICLES[vehicle](vehicle), channels)
    except MclError as exc:
        return tuple(exc.diagnostics)
    return ()


def work(out: Connection, path: str, text: str, vehicle: str | None) -> None:
    """The child process: one proof, its outcome sent back, every failure as an outcome."""
    try:
        outcome = prove(path, text, vehicle)
    except Exception as exc:  # a bug of ours: reported in the editor, never a dead server
        outcome = Outcome("stopped", why=f"internal error: {type(exc).__name__}: {exc}")
    out.send(outcome)
    out.close()


class Prover:
    """Runs at most one proof per document, the latest text's, after a quiet spell."""

    def __init__(self, report: Report, delay: float = PROOF_DELAY,
                 seconds: float = PROOF_SECONDS, vehicle: str | None = None):
        self.report = report
        self.vehicle = vehicle
        self.delay = delay
        self.seconds = seconds
        self.context = multiprocessing.get_context("forkserver")
        self.context.set_forkserver_preload(["app.lsp.proofs"])
        self.running: dict[str, asyncio.Task[None]] = {}

    def request(self, uri: str, path: str, text: str, version: int | None) -> None:
        """Prove this version of the document, once typing has paused (the older proof of
        the document, waiting or running, is dropped)."""
        self.cancel(uri)
        self.running[uri] = asyncio.get_running_loop().create_task(
            self.run(uri, path, text, version))

    def cancel(self, uri: str) -> None:
        """Drop the document's proof, waiting or running (its process is ended)."""
        task = self.running.pop(uri, None)
        if task is not None:
            task.cancel()

    def close(self) -> None:
        for uri in list(self.running):
            self.cancel(uri)

    async def run(self, uri: str, path: str, text: str, version: int | None) -> None:
        await asyncio.sleep(self.delay)
        outcome = await self.in_child(path, text)
        if self.running.get(uri) is asyncio.current_task():
            del self.running[uri]
        self.report(uri, version, outcome)

    async def in_child(self, path: str, text: str) -> Outcome:
        """:func:`prove` in a child process, ended if this coroutine is cancelled or the
        proof outlasts :attr:`seconds`."""
        loop = asyncio.get_running_loop()
        receive, send = self.context.Pipe(duplex=False)
        child = self.context.Process(target=work, args=(send, path, text, self.vehicle), daemon=True)
        child.start()
        send.close()
        deadline = loop.time() + self.seconds
        try:
            while not receive.poll():
                if not child.is_alive() and not receive.poll():
                    return Outcome("stopped", why="the proof's process ended with status "
                                   f"{child.exitcode}")
                if loop.time() > deadline:
                    return Outcome("stopped", why=f"the proof took longer than "
                                   f"{self.seconds:g} s; run mclc for the full verdict")
                await asyncio.sleep(POLL)
            outcome: Outcome = receive.recv()
            return outcome
        except EOFError:
            return Outcome("stopped", why="the proof's process ended without a verdict")
        finally:
            if child.is_alive():
                child.terminate()
            child.join(1.0)
            receive.close()
