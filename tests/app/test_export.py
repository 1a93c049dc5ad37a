"""``mcl run --mcap`` and ``mcl export``: a run as an MCAP file Foxglove opens (docs/MCAP.md).

The file is read back with ``mcap``'s own reader: every message is validated against the
JSON schema it is recorded under (``jsonschema``), Foxglove's well-known schema names are
used, log times never go back, the metadata's final digest is the run log's last, and the
mission, its task libraries and the mosaic are attached. A log whose chain does not verify is
refused and nothing is written.
"""

from __future__ import annotations

import base64
import json
import re
from collections import Counter
from pathlib import Path
from typing import Any

import pytest

from petri.execution.runlog import read_log
from tests.support import MISSIONS, budget, cli

jsonschema = pytest.importorskip("jsonschema")
reader = pytest.importorskip("mcap.reader")

DAM = str(MISSIONS / "dam_inspection.mcl")
SHORT = "path=[(0, 1), (0, 1.6)]"  # one short leg of the dam survey: a 51 s run, 8 images
PNG = b"\x89PNG\r\n\x1a\n"


def read_mcap(path: Path) -> dict[str, Any]:
    """Everything the file holds, as its reader gives it."""
    with path.open("rb") as f:
        r = reader.make_reader(f)
        messages = [(schema, channel, message, json.loads(message.data))
                    for schema, channel, message in r.iter_messages(log_time_order=False)]
        metadata = {m.name: m.metadata for m in r.iter_metadata()}
        attachments = {a.name: a for a in r.iter_attachments()}
    return {"messages": messages, "metadata": metadata, "attachments": attachments}


@pytest.fixture(scope="module")
def short_run(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path, Any]:
    folder = tmp_path_factory.mktemp("mcap")
    log, out = folder / "dam.jsonl", folder / "dam.mcap"
    result = cli("mcl", "run", DAM, "--param", SHORT, "--log", str(log), "--mcap", str(out),
                 "--quiet", timeout=budget(240))
    assert result.returncode == 0, result.stdout + result.stderr
    return log, out, result


def test_run_writes_an_mcap_whose_every_message_validates(short_run: Any) -> None:
    log, out, result = short_run
    assert f"mcap: {out}" in result.stdout
    held = read_mcap(out)
    topics = Counter(channel.topic for _, channel, _, _ in held["messages"])
    for schema, channel, _, data in held["messages"]:
        assert schema.encoding == "jsonschema" and channel.message_encoding == "json"
        jsonschema.validate(data, json.loads(schema.data))
    names = {channel.topic: schema.name for schema, channel, _, _ in held["messages"]}
    assert names["/mission/log"] == "foxglove.Log"
    assert names["/vehicle/pose/true"] == names["/vehicle/pose/estimated"] == \
        "foxglove.PoseInFrame"
    assert names["/vehicle/track"] == "foxglove.SceneUpdate"
    assert names["/camera/image"] == "foxglove.CompressedImage"
    assert names["/mission/status"] == "mcl.MissionStatus"
    records = read_log(log)
    assert topics["/mission/log"] == len(records) - 1  # every record but the header
    images = sorted((log.with_suffix(".images")).glob("*.png"))
    assert topics["/camera/image"] == len(images) > 0
    # a 51 s run at 5 poses a second (the survey's samples)
    assert topics["/vehicle/pose/true"] >= 5 * 45


def test_log_times_never_go_back_and_stamps_agree(short_run: Any) -> None:
    _, out, _ = short_run
    times = [message.log_time for _, _, message, _ in read_mcap(out)["messages"]]
    assert times == sorted(times) and times[-1] > 50e9
    for _, _, message, data in read_mcap(out)["messages"]:
        stamp = data.get("timestamp") or data["entities"][0]["timestamp"]
        assert stamp["sec"] * 10**9 + stamp["nsec"] == message.log_time


def test_metadata_names_the_run_and_its_final_digest(short_run: Any) -> None:
    log, out, _ = short_run
    records = read_log(log)
    meta = read_mcap(out)["metadata"]["mcl.run"]
    assert meta["final_digest"] == records[-1]["digest"]
    assert meta["run"] == records[0]["digest"]
    assert meta["net"] == records[0]["net"] and meta["mission"] == "dam_inspection"


def test_attachments_hold_the_mission_its_libraries_and_the_mosaic(short_run: Any) -> None:
    log, out, _ = short_run
    attached = read_mcap(out)["attachments"]
    assert attached["dam_inspection.mcl"].data == Path(DAM).read_bytes()
    assert {"core.tasks", "ictineu.tasks"} <= set(attached)
    mosaic = attached["dam.mosaic.png"]
    assert mosaic.media_type == "image/png"
    assert mosaic.data == log.with_suffix(".mosaic.png").read_bytes()


def test_log_messages_carry_the_mcl_line_and_images_their_png(short_run: Any) -> None:
    log, out, _ = short_run
    held = read_mcap(out)["messages"]
    source = Path(DAM).read_text("utf-8").splitlines()
    logs = [d for _, c, _, d in held if c.topic == "/mission/log"]
    enables = [d for d in logs if d["message"].startswith("enable WallInspection")]
    assert len(enables) == 1
    assert "WallInspect(" in source[enables[0]["line"] - 1]
    reached = [d for d in logs if d["message"].startswith("event GoTo.reached")]
    assert reached and all("GoTo(" in source[d["line"] - 1] for d in reached)
    images = [d for _, c, _, d in held if c.topic == "/camera/image"]
    first = base64.b64decode(images[0]["data"])
    assert first.startswith(PNG)
    assert first == (log.with_suffix(".images") / "00000.png").read_bytes()


def test_status_shows_each_task_states_in_order(short_run: Any) -> None:
    _, out, _ = short_run
    states: dict[str, list[str]] = {}
    for _, c, _, d in read_mcap(out)["messages"]:
        if c.topic == "/mission/status":
            for task in d["tasks"]:
                seen = states.setdefault(task["task"], [])
                if not seen or seen[-1] != task["state"]:
                    seen.append(task["state"])
    inspect = next(v for k, v in states.items() if k.startswith("WallInspect@"))
    assert inspect == ["waiting", "running", "ok"]
    guard = next(v for k, v in states.items() if k.startswith("KeepHeadDistException@"))
    assert guard == ["waiting", "running", "aborted"]  # its TRY ended ok: the CATCH stopped


def test_export_of_the_log_validates_and_matches_the_run(short_run: Any, tmp_path: Path
                                                         ) -> None:
    log, _, _ = short_run
    out = tmp_path / "again.mcap"
    result = cli("mcl", "export", str(log), "--mcap", str(out))
    assert result.returncode == 0, result.stderr
    held = read_mcap(out)
    for schema, _, _, data in held["messages"]:
        jsonschema.validate(data, json.loads(schema.data))
    topics = Counter(c.topic for _, c, _, _ in held["messages"])
    images = len(list(log.with_suffix(".images").glob("*.png")))
    # only what the log and the files beside it hold: a pose per image
    assert topics["/vehicle/pose/true"] == topics["/camera/image"] == images
    assert held["metadata"]["mcl.run"]["final_digest"] == read_log(log)[-1]["digest"]


def test_export_refuses_a_log_whose_chain_breaks(short_run: Any, tmp_path: Path) -> None:
    log, _, _ = short_run
    lines = log.read_text("ascii").splitlines(keepends=True)
    lines[5] = lines[5].replace('"t":0.0', '"t":0.5', 1)
    edited = tmp_path / "edited.jsonl"
    edited.write_text("".join(lines), "ascii")
    out = tmp_path / "edited.mcap"
    result = cli("mcl", "export", str(edited), "--mcap", str(out))
    assert result.returncode == 2, result.stdout + result.stderr
    assert result.stderr.startswith(f"{edited}:6:") and "digest chain" in result.stderr
    assert "Traceback" not in result.stderr and not out.exists()


@pytest.mark.parametrize("args, said", [
    (["missing.jsonl", "--mcap", "x.mcap"], "no such file"),
    (["LOG", "--mcap", "no/such/folder/x.mcap"], "no folder"),
    (["LOG"], "--mcap"),
])
def test_export_bad_input_is_one_line_and_exit_2(short_run: Any, tmp_path: Path,
                                                 args: list[str], said: str) -> None:
    log, _, _ = short_run
    result = cli("mcl", "export", *[str(log) if a == "LOG" else a for a in args],
                 cwd=tmp_path)
    assert result.returncode == 2, result.stdout + result.stderr
    assert said in result.stderr and "Traceback" not in result.stderr


def test_a_fleet_s_logs_go_in_one_file_each_vehicle_in_its_namespace(short_run: Any,
                                                                     tmp_path: Path) -> None:
    log, _, _ = short_run
    other = tmp_path / "auv2.jsonl"  # the same run again, as a second vehicle's (no images)
    other.write_bytes(log.read_bytes())
    out = tmp_path / "fleet.mcap"
    result = cli("mcl", "export", str(log), str(other), "--mcap", str(out))
    assert result.returncode == 0, result.stderr
    held = read_mcap(out)
    topics = Counter(c.topic for _, c, _, _ in held["messages"])
    records = read_log(log)
    assert topics["/dam/mission/log"] == topics["/auv2/mission/log"] == len(records) - 1
    assert topics["/dam/camera/image"] > 0 and "/auv2/camera/image" not in topics
    assert not [t for t in topics if not t.startswith(("/dam/", "/auv2/"))]
    for schema, _, _, data in held["messages"]:
        jsonschema.validate(data, json.loads(schema.data))
    times = [m.log_time for _, _, m, _ in held["messages"]]
    assert times == sorted(times)
    for name in ("dam", "auv2"):
        assert held["metadata"][f"mcl.run/{name}"]["final_digest"] == records[-1]["digest"]
    assert {"dam/dam_inspection.mcl", "auv2/dam_inspection.mcl"} <= set(held["attachments"])


def test_a_fleet_s_logs_must_have_different_names(short_run: Any, tmp_path: Path) -> None:
    log, _, _ = short_run
    (tmp_path / "b").mkdir()
    twin = tmp_path / "b" / log.name
    twin.write_bytes(log.read_bytes())
    result = cli("mcl", "export", str(log), str(twin), "--mcap", str(tmp_path / "x.mcap"))
    assert result.returncode == 2 and "two run logs named 'dam'" in result.stderr
    assert "Traceback" not in result.stderr and not (tmp_path / "x.mcap").exists()


@pytest.mark.parametrize("source", ["run", "export"])
def test_the_wall_tracker_s_estimate_and_error_are_numbers_to_plot(
        short_run: Any, tmp_path: Path, source: str) -> None:
    log, out, _ = short_run
    if source == "export":  # from the camera's index beside the log: one sample per image
        out = tmp_path / "again.mcap"
        assert cli("mcl", "export", str(log), "--mcap", str(out), "--no-images"
                   ).returncode == 0
    samples = [d for _, c, _, d in read_mcap(out)["messages"] if c.topic == "/wall_tracker"]
    assert len(samples) >= 8
    for s in samples:  # the tracker against the truth: within centimetres and degrees
        assert s["distance_error"] == pytest.approx(s["distance"] - s["distance_true"])
        assert abs(s["distance_error"]) < 0.1 and abs(s["heading_error"]) < 0.1
        assert 1.0 < s["distance_true"] < 2.0  # d = 1.5 m from the wall


def test_run_refuses_an_mcap_it_could_not_write_before_the_start(tmp_path: Path) -> None:
    log = tmp_path / "never.jsonl"
    result = cli("mcl", "run", DAM, "--log", str(log), "--mcap", str(tmp_path / "no" / "x.mcap"))
    assert result.returncode == 2, result.stdout + result.stderr
    assert "--mcap" in result.stderr and "no folder" in result.stderr
    assert "Traceback" not in result.stderr and not log.exists()  # the mission never started


def test_usbl_fixes_are_drawn_when_they_were_taken(short_run: Any) -> None:
    """Each USBL fix comes with the stretch of track driven when it was taken (not all at the
    run's end), and none is lost or drawn twice."""
    _, out, result = short_run
    times = []
    count = 0
    for _, channel, message, data in read_mcap(out)["messages"]:
        if channel.topic != "/vehicle/track":
            continue
        for e in data["entities"]:
            if e["id"].startswith("usbl/"):
                times.append(message.log_time / 1e9)
                count += len(e["spheres"])
    last = max(m.log_time for _, _, m, _ in read_mcap(out)["messages"]) / 1e9
    assert len(times) >= 2 and min(times) < last / 2, times  # spread along the run
    printed = re.search(r"USBL fixes (\d+)", result.stdout)  # the run's summary
    assert printed, result.stdout
    assert count == int(printed.group(1)) > 20  # a fix a second for 51 s, each drawn once
