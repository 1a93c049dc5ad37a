"""The two seabed trackers on synthetic images with a known line: Foresti's EKF on the pipe's
edges (vehicle/perception/pipeline_tracker.py, paper 000) and Wirth's Condensation filter on the cable's
borders (vehicle/perception/cable_tracker.py, paper 004). Images come from the downward camera over a
seabed whose line is known exactly (vehicle/world/seabed.py)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from vehicle.perception.cable_tracker import TABLE_5_1, CableTracker, dog_filter
from vehicle.sensors.downward_camera import DownwardCamera
from vehicle.perception.pipeline_tracker import (
    P0_PAPER,
    Q_PAPER,
    FeatureExtraction,
    PipelineTracker,
    PipeModel,
)
from vehicle.world.seabed import LaidLine, Seabed

CAM = DownwardCamera()
FLOOR = 12.0


def straight(kind: str, diameter: float, albedo: float, **kw: object) -> Seabed:
    line = LaidLine(kind, (0.0, 0.0), math.pi / 2, 60.0, diameter, amplitude=0.0,
                    albedo=albedo, **kw)  # type: ignore[arg-type]
    return Seabed(FLOOR, 3, (line,))


def pose_over(line: LaidLine, s: float, offset: float, dpsi: float, altitude: float
              ) -> tuple[float, float, float, float]:
    """The camera ``offset`` m to starboard of the line at s, turned ``dpsi`` to starboard."""
    x, y = line.point(s)
    h = line.direction(s)
    return (x - offset * math.sin(h), y + offset * math.cos(h), FLOOR - altitude, h + dpsi)


def truth_state(line: LaidLine, pose: tuple[float, float, float, float]) -> np.ndarray:
    """(Cx, Cy, θ, φ) of paper 000 for a pose."""
    x, y, z, psi = pose
    _, e, d = (float(v) for v in line.frame(x, y))
    return np.array([e, FLOOR - line.diameter / 2 - z, math.remainder(psi - d, 2 * math.pi),
                     math.pi / 2 - CAM.tilt])


def edges_at_rows(line: LaidLine, pose: tuple[float, float, float, float]) -> np.ndarray:
    left, right = CAM.line_in_image(pose, line, FLOOR)
    return np.array([left[0], right[0], left[-1], right[-1]])


# --- Foresti: scene model, measurement, EKF ---------------------------------------------------
def test_the_measure_model_g_matches_the_rendered_edges() -> None:
    bed = straight("pipeline", 0.5, 0.9)
    line = bed.lines[0]
    model = PipeModel(line.diameter, CAM.focal, CAM.width, CAM.height)
    for offset, dpsi in ((0.0, 0.0), (0.4, math.radians(8)), (-0.3, math.radians(-12))):
        pose = pose_over(line, 10.0, offset, dpsi, 2.0)
        z_true = edges_at_rows(line, pose)
        assert np.abs(model.g(truth_state(line, pose)) - z_true).max() < 0.5


def test_the_feature_extraction_measures_the_two_edges_within_3_px() -> None:
    bed = straight("pipeline", 0.5, 0.9)
    line = bed.lines[0]
    rng = np.random.default_rng(1)
    features = FeatureExtraction(CAM.width, CAM.height)
    model = PipeModel(line.diameter, CAM.focal, CAM.width, CAM.height)
    for offset, dpsi in ((0.1, 0.0), (0.4, math.radians(8)), (-0.5, math.radians(-10))):
        pose = pose_over(line, 10.0, offset, dpsi, 2.0)
        image = CAM.render(bed, pose, 0.0, rng)
        z_exp = model.g(truth_state(line, pose))
        pairs = features.pairs(features.lines(image), image,
                               (z_exp[1] - z_exp[0], z_exp[3] - z_exp[2]))
        assert pairs, f"no pair at offset {offset}"
        assert np.abs(pairs[0][0] - edges_at_rows(line, pose)).max() < 3.0


def test_no_pair_is_found_on_bare_sand() -> None:
    bed = Seabed(FLOOR, 3, ())
    features = FeatureExtraction(CAM.width, CAM.height)
    rng = np.random.default_rng(2)
    for k in range(5):
        image = CAM.render(bed, (k * 3.0, 1.0, 10.0, 0.3 * k), 0.0, rng)
        pairs = features.pairs(features.lines(image), image, (34.0, 43.0))
        assert not pairs or pairs[0][1] <= 0.35


def run_pipe(bed: Seabed, start: tuple[float, float, float], frames: int, speed: float = 0.5,
             tau: float = 0.25) -> tuple[PipelineTracker, list[tuple[bool, np.ndarray,
                                                                   np.ndarray]]]:
    """Fly straight along +y at ``start`` = (offset, dpsi, altitude), one frame every tau s;
    the tracker predicts with the true speeds (the navigator's role) and measures."""
    line = bed.lines[0]
    offset, dpsi, altitude = start
    pose = pose_over(line, 1.0, offset, dpsi, altitude)
    model = PipeModel(line.diameter, CAM.focal, CAM.width, CAM.height)
    tracker = PipelineTracker.start(model, altitude - line.diameter / 2, math.pi / 2 - CAM.tilt)
    rng = np.random.default_rng(4)
    out = []
    x, y, z, psi = pose
    for _ in range(frames):
        tracker.predict(tau, speed, 0.0)
        x, y = x + speed * tau * math.cos(psi), y + speed * tau * math.sin(psi)
        image = CAM.render(bed, (x, y, z, psi), 0.0, rng)
        measured = tracker.step(image)
        out.append((measured, tracker.x.copy(), truth_state(line, (x, y, z, psi))))
    return tracker, out


def test_the_ekf_converges_from_the_papers_initial_state() -> None:
    bed = straight("pipeline", 0.5, 0.9)
    _, frames = run_pipe(bed, (-0.3, math.radians(4), 2.0), 40)
    assert sum(m for m, _, _ in frames) >= 38
    late = frames[10:]
    cx = [abs(x[0] - t[0]) for _, x, t in late]
    theta = [abs(x[2] - t[2]) for _, x, t in late]
    assert max(cx) < 0.1  # m
    assert math.degrees(max(theta)) < 3.0
    # the vehicle drifts across the pipe (4 deg off its axis): the estimate follows it
    assert frames[-1][2][0] > frames[0][2][0] + 0.3
    assert abs(frames[-1][1][0] - frames[-1][2][0]) < 0.1


def test_frames_without_a_measurement_keep_the_prediction_and_grow_the_covariance() -> None:
    bed = straight("pipeline", 0.5, 0.9, buried=((4.0, 7.0),))
    tracker, frames = run_pipe(bed, (-0.2, math.radians(2), 2.0), 60)
    measured = [m for m, _, _ in frames]
    gap = [k for k, m in enumerate(measured) if not m]
    assert len(gap) >= 8, "the buried stretch hides the pipe for several frames"
    assert measured[-1] and measured[gap[-1] + 1]
    # eq. 17: during the gap the state moves by the model alone, the covariance grows by Q
    model = tracker.model
    t2 = PipelineTracker.start(model, 1.75, math.pi / 2 - CAM.tilt)
    t2.x = np.array([0.1, 1.75, 0.05, 1.3])
    t2.P = np.diag([1e-3, 1e-2, 1e-4, 1e-3])
    traces = []
    for _ in range(5):
        t2.predict(0.25, 0.5, 0.0)
        expected_x = t2.x.copy()
        assert t2.update(None) is False
        assert np.array_equal(t2.x, expected_x)
        traces.append(float(np.trace(t2.P)))
    assert all(b - a >= np.trace(Q_PAPER) - 1e-9 for a, b in zip(traces, traces[1:]))
    assert t2.missing == 5
    # across the gap the estimate stayed on the pipe: error bounded after it is seen again
    after = frames[gap[-1] + 3:]
    assert max(abs(x[0] - t[0]) for _, x, t in after) < 0.1
    assert P0_PAPER[0, 0] == 1.0 and Q_PAPER[2, 2] == 0.0012 and tracker.R[0, 0] == 16.0


# --- Wirth: Condensation ----------------------------------------------------------------------
def image_state(line: LaidLine, pose: tuple[float, float, float, float]) -> tuple[float, float,
                                                                                  float]:
    """(d, α, w) of the thesis for the true cable in the image."""
    left, right = CAM.line_in_image(pose, line, FLOOR)
    rows = np.arange(CAM.height)
    cx, cy = CAM.centre
    k = np.polyfit(cy - rows, (left + right) / 2 - cx, 1)
    alpha = math.atan(k[0])
    return k[1] * math.cos(alpha), alpha, float((right - left)[CAM.height // 2]) * math.cos(alpha)


def fly_cable(bed: Seabed, tracker: CableTracker, s0: float, frames: int, offset: float = 0.1,
              dpsi: float = math.radians(3), speed: float = 0.4, tau: float = 0.25
              ) -> list[tuple[bool, float, float, np.ndarray, float]]:
    line = bed.lines[0]
    rng = np.random.default_rng(5)
    x, y, z, psi = pose_over(line, s0, offset, dpsi, 1.5)
    out = []
    for _ in range(frames):
        x, y = x + speed * tau * math.cos(psi), y + speed * tau * math.sin(psi)
        pose = (x, y, z, psi)
        ok = tracker.step(CAM.render(bed, pose, 0.0, rng))
        d, a, _ = image_state(line, pose)
        s = float(line.frame(x, y)[0])
        out.append((ok, d, a, tracker.estimate.copy(), s))
    return out


def test_the_thesis_parameters_and_filter() -> None:
    assert TABLE_5_1["d"] == 0.5 and TABLE_5_1["v_d"] == 8.0 and TABLE_5_1["w"] == 4.0
    assert TABLE_5_1["filter_size"] == 11 and TABLE_5_1["sample_distance"] == 20
    f = dog_filter(11)
    assert len(f) == 11 and abs(f.sum()) < 1e-12 and f[0] > 0 > f[-1]
    assert np.allclose(f, -f[::-1])
    tracker = CableTracker(CAM.width, CAM.height)
    assert tracker.particles == 500 and tracker.states.shape == (500, 6)
    # no resampling while the weights are even (N_eff = N)
    assert tracker.effective_particles() == pytest.approx(500)


def test_the_cable_is_tracked_within_bounds_from_a_near_start() -> None:
    bed = straight("cable", 0.12, 0.18)
    line = bed.lines[0]
    tracker = CableTracker(CAM.width, CAM.height, seed=3)
    pose = pose_over(line, 2.0, 0.1, math.radians(3), 1.5)
    d, a, w = image_state(line, pose)
    tracker.start_at(d + 6.0, a + 0.05, w + 3.0, 0.0)  # a guess off by 6 px, 3 deg, 3 px
    run = fly_cable(bed, tracker, 2.0, 40)
    late = run[8:]
    assert sum(ok for ok, *_ in late) >= 0.9 * len(late)
    d_err = [abs(est[0] - d) for _, d, _, est, _ in late]
    a_err = [abs(est[1] - a) for _, _, a, est, _ in late]
    assert float(np.sqrt(np.mean(np.square(d_err)))) < 3.0  # px
    assert math.degrees(float(np.sqrt(np.mean(np.square(a_err))))) < 3.0


@pytest.mark.slow
def test_the_particle_filter_recovers_the_cable_after_a_gap() -> None:
    bed = straight("cable", 0.12, 0.18, buried=((5.0, 8.0),))
    line = bed.lines[0]
    tracker = CableTracker(CAM.width, CAM.height, seed=8)
    pose = pose_over(line, 2.0, 0.1, math.radians(3), 1.5)
    d, a, w = image_state(line, pose)
    tracker.start_at(d, a, w, 0.0)
    run = fly_cable(bed, tracker, 2.0, 80)
    ok = [r[0] for r in run]
    hidden = [k for k, r in enumerate(run) if 5.4 < r[4] < 6.6]  # the whole image is buried
    assert hidden and not any(ok[k] for k in hidden), "in the gap the cable is not seen"
    after = [r for r in run if r[4] > 9.0]
    assert after and sum(r[0] for r in after) >= 0.8 * len(after)
    d_err = [abs(est[0] - d) for _, d, _, est, _ in after[3:]]
    assert float(np.median(d_err)) < 3.0  # px: the same cable again, not a ghost
