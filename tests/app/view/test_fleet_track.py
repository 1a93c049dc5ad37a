"""The fleet page's track (issue 25 deliverable 3, "a fleet"): ``mcl run FLEET.mcl`` logs each
vehicle's true pose once a second and the scene in its header (mission/poses.py); ``mcl view
RUNDIR FLEET.mcl`` draws every vehicle's track on one plan over that scene, each vehicle
named where it was at the chosen instant. The logs stay evidence: ``mcl replay`` and ``mcl
export`` take them. In headless Chromium, the dots at a chosen instant are where the logs
say the vehicles were."""

from __future__ import annotations

import json
import shutil
from html.parser import HTMLParser
from pathlib import Path
from typing import Any

import pytest

from app import export, replay, run
from app.view.fleet import fleet_data, load_fleet
from app.view.server import ViewServer
from tests.app.view.test_browser import chromium
from tests.support import MISSIONS

MCM = MISSIONS / "mcm.mcl"
CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser")


@pytest.fixture(scope="module")
def mcm(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, dict[str, Any], Any]:
    folder = tmp_path_factory.mktemp("mcm")
    assert run.main([str(MCM), "--log-dir", str(folder), "--seed", "3", "--quiet"]) == 0
    fleet, logs, record = load_fleet(str(folder), str(MCM))
    return folder, fleet_data(fleet, logs, record, folder), logs


def poses(records: list[dict[str, Any]]) -> list[list[float]]:
    return [[r["t"], r["x"], r["y"], r["z"]] for r in records if r["kind"] == "pose"]


@pytest.mark.slow
def test_every_vehicle_s_log_holds_its_pose_each_second_and_its_page_the_track(
        mcm: Any) -> None:
    _, data, logs = mcm
    for name, records in logs.items():
        mine = poses(records)
        end = records[-1]["t"]
        assert len(mine) >= int(end) - 1 > 10, name  # about one a second, from the start
        times = [p[0] for p in mine]
        assert all(b - a >= 1.0 - 1e-6 for a, b in zip(times, times[1:]))
        assert data["tracks"][name] == mine
        assert data["tracks_from"][name] == "the run log's poses"
    uuv, asv = poses(logs["uuv"]), poses(logs["asv"])
    assert max(p[3] for p in uuv) > 5.0 and max(p[3] for p in asv) == 0.0  # it dives; it floats


@pytest.mark.slow
def test_the_scene_is_the_mine_field_of_the_run_s_seed(mcm: Any) -> None:
    from vehicle.world.mine_field import mine_field

    _, data, logs = mcm
    field = mine_field(3)
    assert data["scene"]["points"]["mine"] == [[round(field.target[0], 3),
                                                round(field.target[1], 3)]]
    assert len(data["scene"]["points"]["clutter"]) == len(field.clutter)
    assert logs["asv"][0]["scene"] == logs["uuv"][0]["scene"]


@pytest.mark.slow
def test_logs_with_poses_replay_and_export(mcm: Any, tmp_path: Path,
                                           capsys: pytest.CaptureFixture[str]) -> None:
    from mcap.reader import make_reader

    folder, _, logs = mcm
    assert replay.main([str(folder), str(MCM)]) == 0
    assert "conforms" in capsys.readouterr().out
    out = tmp_path / "mcm.mcap"
    assert export.main([str(folder / "asv.jsonl"), str(folder / "uuv.jsonl"),
                        str(folder / "channels.jsonl"), "--mcap", str(out)]) == 0
    with out.open("rb") as f:
        messages = [(c.topic, json.loads(m.data))
                    for _, c, m in make_reader(f).iter_messages()]
    for name in ("asv", "uuv"):
        said = [d["pose"]["position"] for topic, d in messages
                if topic == f"/{name}/vehicle/pose/true"]
        assert [[p["x"], p["y"], p["z"]] for p in said] == [p[1:] for p in poses(logs[name])]
        lines = [d["message"] for topic, d in messages if topic == f"/{name}/mission/log"
                 and d["message"].startswith("pose ")]  # a debug line each
        assert lines[0] == "pose x={x} m, y={y} m, z={z} m, yaw={yaw} rad".format(
            **next(r for r in logs[name] if r["kind"] == "pose"))
        assert len(lines) == len(said)


class Plan(HTMLParser):
    """The plan's vehicles (their dots, names and travelled lines) and its scene."""

    def __init__(self) -> None:
        super().__init__()
        self.dots: dict[str, dict[str, str]] = {}
        self.travelled: dict[str, dict[str, str]] = {}
        self.scene: list[str] = []
        self.names: list[str] = []
        self.in_name = False

    def handle_starttag(self, tag: str, attrs: list[tuple[str, str | None]]) -> None:
        a = {k: v or "" for k, v in attrs}
        classes = a.get("class", "").split()
        if tag == "circle" and "vehicle" in classes:
            self.dots[a["data-vehicle"]] = a
        elif tag == "polyline" and "travelled" in classes:
            self.travelled[a["data-vehicle"]] = a
        elif "scene-point" in classes or "scene-line" in classes:
            self.scene.append(a["data-name"])
        self.in_name = tag == "text" and "vehicle-name" in classes

    def handle_data(self, data: str) -> None:
        if self.in_name:
            self.names.append(data)
            self.in_name = False


@pytest.mark.slow
@pytest.mark.skipif(CHROMIUM is None, reason="no Chromium on this machine (Debian: apt-get "
                    "install chromium; .ci/run does)")
def test_the_browser_puts_each_vehicle_where_its_log_says(mcm: Any, tmp_path: Path) -> None:
    _, data, logs = mcm
    t = 30.5  # the uuv has been released and goes down towards the mine
    server = ViewServer(lambda: data, {})
    server.start()
    try:
        plan = Plan()
        plan.feed(chromium(tmp_path, "--dump-dom", f"{server.url}?t={t:g}"))
    finally:
        server.shutdown()
        server.server_close()
    assert sorted(plan.dots) == sorted(plan.names) == ["asv", "uuv"]
    for name, records in logs.items():
        before = [p for p in poses(records) if p[0] <= t]
        dot = plan.dots[name]
        assert [float(dot[k]) for k in ("data-t", "data-x", "data-y")] == before[-1][:3]
        line = plan.travelled[name]
        assert int(line["data-points"]) == len(before)
        last = line["points"].split()[-1].split(",")
        assert [float(v) for v in last] == [float(dot["cx"]), float(dot["cy"])]
    assert plan.scene.count("mine") == 1 and plan.scene.count("clutter") >= 10
