"""A fleet's logs checked together (mission/fleet_evidence.py, issue 23 deliverable 5): the
genuine logs of a run agree; a channel record edited (and re-chained, as a forger would) is
refused at the line that lies: a delivery outside the DELAY range, a message delivered that
was not sent, a message heard that the record does not deliver, a loss on a channel that is
not LOSSY, a drop outside EVERY, a Send with no sent line; an edit that is not re-chained
breaks the chain."""

from __future__ import annotations

import json
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest

from mcl.fleet import CompiledFleet, compile_fleet_file
from mission.fleet import run_fleet
from mission.fleet_evidence import RecordProblem, problem, read_record
from mission.vehicle import Vehicle
from petri.execution.runlog import GENESIS, chain, read_log
from tests.support import REPO
from vehicle.scripted import ScriptedVehicle, parse_script
from vehicle_adapters.inprocess import InProcess

PAIR = REPO / "examples" / "fleet" / "pair.mcl"
SCRIPT = parse_script({"behaviours": {"GoTo": {"on_enable": {"after": 12.0, "event": "reached"}},
                                      "Surface": {"on_enable": {"after": 9.0,
                                                                "event": "surfaced"}}}})
Lines = list[dict[str, Any]]


@pytest.fixture(scope="module")
def run(tmp_path_factory: pytest.TempPathFactory) -> tuple[CompiledFleet, Path]:
    """A run of the example with a loss, a drop and deliveries (seed chosen to show all)."""
    fleet = compile_fleet_file(str(PAIR), require_values=True)
    folder = tmp_path_factory.mktemp("fleet")
    run_fleet(fleet, {n: Vehicle(InProcess(ScriptedVehicle(SCRIPT))) for n in fleet.vehicles},
              loss=0.5, seed=0, log_dir=folder, verify=False)
    return fleet, folder


def rechained(lines: Lines) -> str:
    """The record's lines with their digests computed again (what a forger can do)."""
    out, previous = [], GENESIS
    for obj in lines:
        body = json.dumps({k: v for k, v in obj.items() if k not in ("digest", "_line")},
                          separators=(",", ":"))
        previous = chain(previous, body)
        out.append(body[:-1] + f',"digest":"{previous}"' + "}")
    return "\n".join(out) + "\n"


def judged(run: tuple[CompiledFleet, Path], tmp_path: Path,
           edit: Callable[[Lines], Lines] | None = None) -> RecordProblem | None:
    fleet, folder = run
    lines = [json.loads(x) for x in (folder / "channels.jsonl").read_text("ascii").splitlines()]
    path = tmp_path / "channels.jsonl"
    path.write_text(rechained(edit(lines) if edit is not None else lines), "ascii")
    logs = {n: read_log(folder / f"{n}.jsonl") for n in fleet.vehicles}
    return problem(fleet, read_record(path), path, logs)


def first(lines: Lines, kind: str) -> int:
    return next(i for i, r in enumerate(lines) if r["kind"] == kind)


def test_the_run_shows_every_fate_and_its_logs_agree(run: tuple[CompiledFleet, Path],
                                                     tmp_path: Path) -> None:
    kinds = [json.loads(x)["kind"] for x in
             (run[1] / "channels.jsonl").read_text("ascii").splitlines()]
    assert {"sent", "delivered", "lost"} <= set(kinds)
    assert judged(run, tmp_path) is None


def late(lines: Lines) -> Lines:
    i = first(lines, "delivered")
    lines[i]["t"] = lines[i]["sent"] + 3.5
    return lines


def unsent(lines: Lines) -> Lines:
    i = first(lines, "delivered")
    lines[i]["seq"] = 99
    return lines


def hidden(lines: Lines) -> Lines:  # a delivery dropped from the record: the log heard it
    del lines[first(lines, "delivered")]
    return lines


def lost_on_reliable(lines: Lines) -> Lines:
    i = first(lines, "delivered")
    lines[i] = {**lines[i], "kind": "lost"}
    return lines


def no_sent(lines: Lines) -> Lines:
    i = max(i for i, r in enumerate(lines) if r["kind"] == "sent")
    seq = lines[i]["seq"]
    return [r for r in lines if r.get("seq") != seq]


@pytest.mark.parametrize("edit, says", [
    (late, "outside orders's DELAY 1 .. 3 s"),
    (unsent, "which was not sent"),
    (hidden, "which the channel record does not deliver"),
    (no_sent, "has no 'sent' line"),
])
def test_a_forged_record_is_refused_at_what_it_claims(
        run: tuple[CompiledFleet, Path], tmp_path: Path, edit: Callable[[Lines], Lines],
        says: str) -> None:
    found = judged(run, tmp_path, edit)
    assert found is not None and says in found.reason


def test_a_loss_on_a_channel_that_is_not_lossy_is_refused(
        run: tuple[CompiledFleet, Path], tmp_path: Path) -> None:
    fleet, folder = run
    reliable = compile_fleet_file(str(PAIR), require_values=True)
    reliable.channels["orders"] = type(fleet.channels["orders"])(
        **{**fleet.channels["orders"].__dict__, "lossy": False})
    found = judged((reliable, folder), tmp_path, lambda lines: lines)
    assert found is not None and "not LOSSY" in found.reason


def test_a_drop_outside_every_is_refused(run: tuple[CompiledFleet, Path],
                                         tmp_path: Path) -> None:
    def dropped(lines: Lines) -> Lines:
        i = first(lines, "lost")
        lines[i] = {**lines[i], "kind": "dropped"}
        return lines

    found = judged(run, tmp_path, dropped)
    assert found is not None and "closer than EVERY" in found.reason


def test_an_edit_that_is_not_rechained_breaks_the_chain(run: tuple[CompiledFleet, Path],
                                                        tmp_path: Path) -> None:
    text = (run[1] / "channels.jsonl").read_text("ascii").replace('"kind":"lost"',
                                                                  '"kind":"dropped"', 1)
    path = tmp_path / "channels.jsonl"
    path.write_text(text, "ascii")
    with pytest.raises(RecordProblem, match="chain breaks"):
        read_record(path)
