"""Benchmark: ``mcl lsp``, the time from a change to its diagnostics (issue 26, deliverable 5;
figures, not a test).

A real server process (the ``mcl`` console script beside this Python, ``mcl lsp``) driven over
stdio by pytest-lsp's client (a pygls client that can wait for a notification). For each mission: open it, wait for its proof (the notification
``mcl/proved``); then, round after round, send a change and time

* **check**: a change that breaks the text (a ``;`` before ``}``) until the parser's error is
  published (parse and check run on every change);
* **proof**: a change back to the valid text until ``mcl/proved`` for that version (the proof
  waits for 0.4 s of quiet, the server's ``--proof-delay``, then runs in a process of its own:
  the figure includes that wait).

Missions: the dam (missions/dam_inspection.mcl) and a 1,000-task latched sequence
(bench_scale.latched_sequence). Medians of the rounds.

    .venv/bin/python bench/bench_lsp.py [--rounds N]
"""

from __future__ import annotations

import argparse
import asyncio
import functools
import logging
import statistics
import sys
import time
from pathlib import Path
from typing import Any

from lsprotocol import types
from pytest_lsp import LanguageClient, client_capabilities
from pytest_lsp.client import make_test_lsp_client

HERE = Path(__file__).resolve().parent
REPO = HERE.parent
sys.path.insert(0, str(HERE))
from bench_scale import latched_sequence  # noqa: E402

MCL = str(Path(sys.executable).parent / "mcl")
PROVED = "mcl/proved"
WAIT = 300.0  # s: the longest wait for one answer before the bench gives up


async def until(done: Any) -> float:
    """Seconds until ``done()`` holds (polled every millisecond, for at most WAIT s)."""
    start = time.perf_counter()
    while not done():
        if time.perf_counter() - start > WAIT:
            raise TimeoutError("no answer from mcl lsp")
        await asyncio.sleep(0.001)
    return time.perf_counter() - start


async def proved(client: LanguageClient, change: Any, version: int) -> float:
    """Seconds from ``change()`` to ``mcl/proved`` for ``version`` of the document."""
    start = time.perf_counter()
    waiting = asyncio.ensure_future(client.wait_for_notification(PROVED))
    change()
    while True:
        params = await asyncio.wait_for(waiting, WAIT)
        got = (params.get("version") if isinstance(params, dict)
               else getattr(params, "version", None))
        if got == version:
            return time.perf_counter() - start
        waiting = asyncio.ensure_future(client.wait_for_notification(PROVED))


async def measure(name: str, path: Path, rounds: int) -> tuple[str, list[float], list[float]]:
    client: LanguageClient = make_test_lsp_client()
    await client.start_io(MCL, "lsp")
    await client.initialize_session(types.InitializeParams(
        capabilities=client_capabilities("visual-studio-code"), root_uri=path.parent.as_uri()))
    uri, text = path.as_uri(), path.read_text("utf-8")
    broken = text[:text.rindex("}")].rstrip() + ";\n}\n"
    await proved(client, lambda: client.text_document_did_open(types.DidOpenTextDocumentParams(
        types.TextDocumentItem(uri, "mcl", 1, text))), 1)
    checks, proofs = [], []
    version = 1

    def change(v: int, new: str) -> None:
        client.text_document_did_change(types.DidChangeTextDocumentParams(
            types.VersionedTextDocumentIdentifier(v, uri),
            [types.TextDocumentContentChangeWholeDocument(new)]))

    for _ in range(rounds):
        version += 1
        client.diagnostics.pop(uri, None)
        change(version, broken)
        checks.append(await until(lambda: any(
            d.severity == types.DiagnosticSeverity.Error
            for d in client.diagnostics.get(uri, []))))
        version += 1
        v = version
        proofs.append(await proved(client, functools.partial(change, v, text), v))
    await client.shutdown_session()
    return name, checks, proofs


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rounds", type=int, default=5)
    args = ap.parse_args()
    logging.getLogger("pygls").setLevel(logging.ERROR)  # mcl/proved is ours: pygls says so
    import tempfile

    with tempfile.TemporaryDirectory() as tmp:
        big = Path(tmp) / "latched_1000.mcl"
        big.write_text(latched_sequence(1000), "utf-8")
        cases = [("dam mission", REPO / "missions" / "dam_inspection.mcl"),
                 ("1,000-task latched sequence", big)]
        print(f"mcl lsp, change -> diagnostics, median of {args.rounds} rounds "
              "(check: a parse error published; proof: mcl/proved, 0.4 s of quiet included)")
        for name, path in cases:
            label, checks, proofs = asyncio.run(measure(name, path, args.rounds))
            print(f"  {label:30s} check {statistics.median(checks) * 1000:7.0f} ms   "
                  f"proof {statistics.median(proofs):6.2f} s")


if __name__ == "__main__":
    main()
