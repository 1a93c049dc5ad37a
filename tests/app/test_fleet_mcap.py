"""``mcl run FLEET.mcl --mcap FILE`` and ``mcl export`` of a fleet's logs with its channel
record (issue 25 deliverable 1, "a fleet run: one namespace per vehicle"): one MCAP file,
each vehicle's log, status and track under ``/NAME``, the channel record on
``/channel/NAME`` (sent, delivered, lost). Read back with ``mcap``'s reader, every message
validated against its schema, log times never going back, and the metadata's digests those
of the logs and of the record."""

from __future__ import annotations

import json
from collections import Counter
from pathlib import Path
from typing import Any

import pytest

from app import export, run
from tests.support import MISSIONS

jsonschema = pytest.importorskip("jsonschema")
reader = pytest.importorskip("mcap.reader")

MCM = str(MISSIONS / "mcm.mcl")
VEHICLES = ("asv", "uuv")


def read_mcap(path: Path) -> dict[str, Any]:
    """Everything the file holds, as its reader gives it."""
    with path.open("rb") as f:
        r = reader.make_reader(f)
        messages = [(schema, channel, message, json.loads(message.data))
                    for schema, channel, message in r.iter_messages(log_time_order=False)]
        metadata = {m.name: m.metadata for m in r.iter_metadata()}
        attachments = {a.name: a for a in r.iter_attachments()}
    return {"messages": messages, "metadata": metadata, "attachments": attachments}


def lines(path: Path) -> list[dict[str, Any]]:
    return [json.loads(line) for line in path.read_text("ascii").splitlines()]


@pytest.fixture(scope="module")
def mcm_run(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path]:
    """Paper 003's fleet, half its messages lost (seed 3: some delivered, some lost)."""
    folder = tmp_path_factory.mktemp("fleet")
    logs, out = folder / "logs", folder / "mcm.mcap"
    code = run.main([MCM, "--log-dir", str(logs), "--mcap", str(out), "--loss", "0.5",
                     "--seed", "3", "--quiet"])
    assert code in (0, 1), code  # the uuv may ascend: a fail, still a whole run
    return logs, out


@pytest.mark.slow
def test_every_message_validates_each_vehicle_in_its_namespace(mcm_run: Any) -> None:
    logs, out = mcm_run
    held = read_mcap(out)
    topics = Counter(channel.topic for _, channel, _, _ in held["messages"])
    validators: dict[int, Any] = {}  # one per schema: compiled once, not per message
    for schema, channel, _, data in held["messages"]:
        assert schema.encoding == "jsonschema" and channel.message_encoding == "json"
        if schema.id not in validators:
            spec = json.loads(schema.data)
            jsonschema.validators.validator_for(spec).check_schema(spec)
            validators[schema.id] = jsonschema.validators.validator_for(spec)(spec)
        validators[schema.id].validate(data)
    assert not [t for t in topics if not t.startswith(("/asv/", "/uuv/", "/channel/"))]
    for name in VEHICLES:
        records = lines(logs / f"{name}.jsonl")
        assert topics[f"/{name}/mission/log"] == len(records) - 1
        assert topics[f"/{name}/vehicle/pose/true"] > 100  # 5 a second over the run
        assert held["metadata"][f"mcl.run/{name}"]["final_digest"] == records[-1]["digest"]
        assert f"{name}/mcm.mcl" in held["attachments"]
    times = [m.log_time for _, _, m, _ in held["messages"]]
    assert times == sorted(times)


@pytest.mark.slow
def test_the_channel_record_is_a_topic_of_sent_delivered_and_lost(mcm_run: Any) -> None:
    logs, out = mcm_run
    record = lines(logs / "channels.jsonl")
    held = read_mcap(out)
    events = [d for _, c, _, d in held["messages"] if c.topic == "/channel/guide"]
    said = Counter(r["kind"] for r in record[1:-1])
    assert Counter(e["fate"] for e in events) == said
    assert said["sent"] > 0 and said["delivered"] > 0 and said["lost"] > 0, said
    low, high = record[0]["channels"]["guide"]["delay"]
    for e in events:
        assert (e["sender"], e["channel"]) == ("asv", "guide")
        if e["fate"] == "delivered":
            assert e["receiver"] == "uuv" and low - 1e-6 <= e["delay"] <= high + 1e-6, e
    fleet = held["metadata"]["mcl.fleet"]
    assert fleet["fleet"] == "mcm" and fleet["seed"] == "3"
    assert fleet["final_digest"] == record[-1]["digest"]
    assert json.loads(fleet["loss"]) == {"guide": 0.5}
    assert held["attachments"]["channels.jsonl"].data == (logs / "channels.jsonl").read_bytes()


@pytest.mark.slow
def test_export_of_the_fleet_s_logs_and_record_holds_the_same_channel(
        mcm_run: Any, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    logs, out = mcm_run
    again = tmp_path / "again.mcap"
    # the record named otherwise: its header, not its name, says what it is
    other = tmp_path / "guide-record.jsonl"
    other.write_bytes((logs / "channels.jsonl").read_bytes())
    assert export.main([str(logs / "asv.jsonl"), str(logs / "uuv.jsonl"), str(other),
                        "--mcap", str(again)]) == 0
    ran, exported = read_mcap(out), read_mcap(again)

    def channel(held: dict[str, Any]) -> list[Any]:
        return [d for _, c, _, d in held["messages"] if c.topic == "/channel/guide"]

    assert channel(exported) == channel(ran) != []
    assert exported["metadata"]["mcl.fleet"] == ran["metadata"]["mcl.fleet"]
    assert "/guide-record/mission/log" not in {c.topic for _, c, _, _ in exported["messages"]}


@pytest.mark.slow
@pytest.mark.parametrize("case, says", [
    ("edited", "the digest chain breaks here"),
    ("alone", "a channel record alone"),
])
def test_export_refuses_a_bad_channel_record_and_writes_nothing(
        mcm_run: Any, tmp_path: Path, capsys: pytest.CaptureFixture[str], case: str,
        says: str) -> None:
    logs, _ = mcm_run
    record = tmp_path / "channels.jsonl"
    text = (logs / "channels.jsonl").read_text("ascii")
    record.write_text(text.replace('"lost"', '"delivered"', 1) if case == "edited" else text)
    assert (record.read_text("ascii") != text) == (case == "edited")
    given = [str(logs / "asv.jsonl"), str(logs / "uuv.jsonl")] if case == "edited" else []
    out = tmp_path / "x.mcap"
    assert export.main([*given, str(record), "--mcap", str(out)]) == 2
    err = capsys.readouterr().err
    assert says in err and "Traceback" not in err and len(err.strip().splitlines()) <= 2
    assert not out.exists()


def test_an_mcap_that_cannot_be_written_is_refused_before_the_start(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    logs = tmp_path / "logs"
    code = run.main([MCM, "--log-dir", str(logs), "--mcap", str(tmp_path / "no" / "x.mcap"),
                     "--quiet", "--no-verify"])
    assert code == 2
    err = capsys.readouterr().err
    assert "--mcap" in err and "Traceback" not in err
    assert not logs.exists() or not list(logs.iterdir())  # nothing ran
