"""The seabed scene, the downward camera, the seabed behaviours' declaration, and the shipped
seabed missions run by `mcl run` on the default simulator: nominal (they follow the line to
the end, with the tracking figures printed) and without a line (they fail cleanly, surfaced)."""

from __future__ import annotations

import json
import math
import re
from pathlib import Path

import numpy as np
import pytest

from behaviours.seabed import SEABED, statements
from mcl import tasklib
from vehicle.sensors.downward_camera import DownwardCamera
from vehicle.world.seabed import LaidLine, default_scene
from vehicle.control.stack import IctineuStack, StackConfig, parse_fault

from tests.support import REPO, budget, cli

CAM = DownwardCamera()


# --- the scene ----------------------------------------------------------------------------------
def test_the_line_frame_and_its_points_agree() -> None:
    line = LaidLine("pipeline", (-10.0, -4.0), math.pi / 2, 60.0, 0.5, amplitude=1.5,
                    wavelength=40.0)
    for s in (0.0, 7.3, 21.0, 44.4):
        x, y = line.point(s)
        s2, e, d = (float(v) for v in line.frame(x, y))
        assert abs(s2 - s) < 1e-9 and abs(e) < 1e-9
        assert abs(d - line.direction(s)) < 1e-12
        # a point 0.3 m to starboard of the line (its direction turned +90 deg, z down)
        h = line.direction(s)
        _, e2, _ = (float(v) for v in line.frame(x - 0.3 * math.sin(h), y + 0.3 * math.cos(h)))
        assert abs(e2 - 0.3) < 1e-3


def test_buried_partly_buried_and_overgrown_stretches() -> None:
    line = default_scene().line("pipeline")
    assert line is not None
    s = np.array([5.0, 14.0, 22.0, 31.0, 70.0, -1.0])
    assert list(line.visible_share(s)) == [1.0, 1.0 - 0.8, 1.0, 0.0, 0.0, 0.0]
    assert list(line.overgrown(s)) == [False, False, True, False, False, False]


def mean_on_and_off(image: np.ndarray, left: np.ndarray, right: np.ndarray) -> tuple[float,
                                                                                      float]:
    cols = np.arange(image.shape[1])[None, :]
    on = (cols > left[:, None] + 2) & (cols < right[:, None] - 2)
    off = (cols < left[:, None] - 6) | (cols > right[:, None] + 6)
    return float(image[on].mean()), float(image[off].mean())


def test_the_camera_shows_the_pipe_where_it_lies_and_not_where_it_is_buried() -> None:
    bed = default_scene()
    line = bed.line("pipeline")
    assert line is not None
    rng = np.random.default_rng(0)
    x, y = line.point(5.0)
    pose = (x, y, 10.0, line.direction(5.0))
    image = CAM.render(bed, pose, 0.0, rng)
    assert image.shape == (120, 160) and image.dtype == np.uint8
    left, right = CAM.line_in_image(pose, line, bed.floor_depth)
    assert 25 < float(np.mean(right - left)) < 50  # a 0.5 m pipe 1.75 m below: ~38 px
    on, off = mean_on_and_off(image, left, right)
    assert on > off + 40  # the coated pipe is brighter than the sand
    # the same place after a burial: sand all over (only the lamp's falloff from the centre)
    bed.bury(10.0)
    assert CAM.render(bed, pose, 9.0, rng)[60, 80] > off + 40  # not yet
    buried = CAM.render(bed, pose, 11.0, rng)
    on_buried, off_buried = mean_on_and_off(buried, left, right)
    assert on_buried < on - 40 and abs(off_buried - off) < 5
    # the stretch buried in the scene (30-33 m) shows no pipe either
    x, y = line.point(31.0)
    gap = CAM.render(default_scene(), (x, y, 10.0, line.direction(31.0)), 0.0, rng)
    assert float(gap.std()) < float(image.std()) * 0.6


def test_images_are_a_function_of_the_seed() -> None:
    a = default_scene(seed=4)
    b = default_scene(seed=4)
    c = default_scene(seed=5)
    pose = (-10.0, 3.0, 10.0, 1.6)
    ia = CAM.render(a, pose, 0.0, np.random.default_rng(9))
    ib = CAM.render(b, pose, 0.0, np.random.default_rng(9))
    ic = CAM.render(c, pose, 0.0, np.random.default_rng(9))
    assert np.array_equal(ia, ib) and not np.array_equal(ia, ic)


def test_burial_is_a_fault_of_the_simulated_vehicle() -> None:
    assert parse_fault("burial@60") == ("burial", 60.0)
    stack = IctineuStack(StackConfig(faults=[("burial", 12.0)]))
    assert stack.seabed.seabed.buried_from == 12.0
    assert not stack.sensors.housings[-1].faults  # not a housing fault


# --- the behaviours are declared like the others -----------------------------------------------
def test_seabed_tasks_declares_exactly_what_the_vehicle_provides() -> None:
    library = tasklib.load([str(REPO / "missions" / "seabed.tasks")]).behaviours
    for cls in SEABED:
        b = library[cls.name]
        assert (b.dofs, b.events) == (cls.drives, cls.events), cls.name
        assert f"behaviour {cls.name}" in statements()
    stack = IctineuStack()
    assert {cls.name for cls in SEABED} <= set(stack.behaviours)
    from behaviours.capabilities import simulated

    assert "behaviour FollowCable drives x, yaw events ended, lost;" in simulated("sim").text


# --- the shipped missions on the default simulator ---------------------------------------------
FIGURES = re.compile(r"(\w+) tracking: (\d+) frames, (\d+) % with the line measured; "
                     r"cross-track error ([\d.]+) m RMS, ([\d.]+) m max; heading error "
                     r"([\d.]+) deg RMS")


def run_mission(tmp_path: Path, name: str, *extra: str) -> tuple[int, str, list[dict[str, object]]]:
    log = tmp_path / f"{name}.jsonl"
    # verified in test_missions.py (golden); here: the run
    proc = cli("mcl", "run", f"missions/{name}.mcl", "--quiet", "--no-verify", "--log", str(log),
               *extra,
               timeout=budget(15))
    records = [json.loads(line) for line in log.read_text("utf-8").splitlines()]
    return proc.returncode, proc.stdout + proc.stderr, records


def events(records: list[dict[str, object]]) -> list[str]:
    return [str(r["event"]) for r in records if r.get("kind") == "event"]


@pytest.mark.slow
def test_the_pipeline_mission_follows_the_pipe_to_its_end(tmp_path: Path) -> None:
    code, out, records = run_mission(tmp_path, "pipeline_inspection")
    assert code == 0, out
    assert "mission pipeline_inspection ended OK" in out
    assert "FollowPipeline.ended" in events(records)
    assert "FollowPipeline.lost" not in events(records)  # the buried stretch was bridged
    m = FIGURES.search(out)
    assert m, out
    kind, frames, share, rms, worst, heading = m.groups()
    assert kind == "pipeline" and int(frames) > 200
    assert 70 <= int(share) < 100  # the buried stretch: frames without a measurement
    assert float(rms) < 0.15 and float(worst) < 0.5 and float(heading) < 8.0
    assert re.search(r"line out of sight [\d.]+ s in all, [1-9]\d* stretches of 1 s or more, "
                     r"[1-9]\d* of them recovered", out), out
    svg = (tmp_path / "pipeline_inspection.seabed.svg").read_text("utf-8")
    assert svg.startswith("<svg") and svg.count("<polyline") >= 1 and "<circle" in svg


@pytest.mark.slow
def test_the_cable_mission_tracks_the_cable_to_its_end(tmp_path: Path) -> None:
    code, out, records = run_mission(tmp_path, "cable_tracking")
    assert code == 0, out
    assert "FollowCable.ended" in events(records)
    m = FIGURES.search(out)
    assert m, out
    kind, _, share, rms, worst, heading = m.groups()
    assert kind == "cable" and int(share) >= 70
    assert float(rms) < 0.25 and float(worst) < 0.8 and float(heading) < 10.0


@pytest.mark.slow
def test_without_a_line_the_mission_searches_then_fails_at_the_surface(tmp_path: Path) -> None:
    code, out, records = run_mission(tmp_path, "cable_tracking", "--inject", "burial@0")
    assert code == 1, out
    assert "mission cable_tracking ended FAIL" in out
    seen = events(records)
    assert seen.index("FollowCable.lost") < seen.index("SearchLine.exhausted") < seen.index(
        "Surface.surfaced")
    assert "FollowCable.ended" not in seen
    end = records[-1]
    assert end["kind"] == "end" and end["how"] == "fail"
    assert "Traceback" not in out
